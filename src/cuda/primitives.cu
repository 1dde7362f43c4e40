// meniscus — cub wrappers of the CUDA backend (Merrill & Grimshaw 2011 radix sort; single-pass
// prefix scan, Merrill & Garland 2016). Temporary storage is queried, then allocated per call.
#include <cub/device/device_radix_sort.cuh>
#include <cub/device/device_scan.cuh>
#include <cub/device/device_select.cuh>

#include "cuda/primitives.hpp"

namespace meniscus::cuda {

namespace {

template <class K>
void sort_pairs_impl(K* keys, uint32_t* values, std::size_t n, int begin_bit, int end_bit) {
  if (n < 2) return;
  DeviceBuffer<K> keys_out(n);
  DeviceBuffer<uint32_t> values_out(n);
  std::size_t temp_bytes = 0;
  MENISCUS_CUDA_CHECK(cub::DeviceRadixSort::SortPairs(nullptr, temp_bytes, keys, keys_out.data(), values,
                                                      values_out.data(), n, begin_bit, end_bit));
  DeviceBuffer<unsigned char> temp(temp_bytes);
  MENISCUS_CUDA_CHECK(cub::DeviceRadixSort::SortPairs(temp.data(), temp_bytes, keys, keys_out.data(),
                                                      values, values_out.data(), n, begin_bit, end_bit));
  MENISCUS_CUDA_CHECK(counted_memcpy(keys, keys_out.data(), n * sizeof(K), cudaMemcpyDeviceToDevice));
  MENISCUS_CUDA_CHECK(counted_memcpy(values, values_out.data(), n * sizeof(uint32_t), cudaMemcpyDeviceToDevice));
}

template <class T>
void exclusive_sum_impl(const T* in, T* out, std::size_t n) {
  if (n == 0) {
    MENISCUS_CUDA_CHECK(counted_memset(out, 0, sizeof(T)));
    return;
  }
  std::size_t temp_bytes = 0;
  MENISCUS_CUDA_CHECK(cub::DeviceScan::ExclusiveSum(nullptr, temp_bytes, in, out, n));
  DeviceBuffer<unsigned char> temp(temp_bytes);
  MENISCUS_CUDA_CHECK(cub::DeviceScan::ExclusiveSum(temp.data(), temp_bytes, in, out, n));
  // out[n] = out[n-1] + in[n-1]
  T last_out = 0, last_in = 0;
  MENISCUS_CUDA_CHECK(counted_memcpy(&last_out, out + n - 1, sizeof(T), cudaMemcpyDeviceToHost));
  MENISCUS_CUDA_CHECK(counted_memcpy(&last_in, in + n - 1, sizeof(T), cudaMemcpyDeviceToHost));
  const T total = last_out + last_in;
  MENISCUS_CUDA_CHECK(counted_memcpy(out + n, &total, sizeof(T), cudaMemcpyHostToDevice));
}

}  // namespace

void sort_pairs(Device, uint64_t* keys, uint32_t* values, std::size_t n, int begin_bit, int end_bit) {
  sort_pairs_impl(keys, values, n, begin_bit, end_bit);
}
void sort_pairs(Device, uint32_t* keys, uint32_t* values, std::size_t n, int begin_bit, int end_bit) {
  sort_pairs_impl(keys, values, n, begin_bit, end_bit);
}

void sort_keys(Device, uint64_t* keys, std::size_t n) {
  if (n < 2) return;
  DeviceBuffer<uint64_t> out(n);
  std::size_t temp_bytes = 0;
  MENISCUS_CUDA_CHECK(cub::DeviceRadixSort::SortKeys(nullptr, temp_bytes, keys, out.data(), n));
  DeviceBuffer<unsigned char> temp(temp_bytes);
  MENISCUS_CUDA_CHECK(cub::DeviceRadixSort::SortKeys(temp.data(), temp_bytes, keys, out.data(), n));
  MENISCUS_CUDA_CHECK(counted_memcpy(keys, out.data(), n * sizeof(uint64_t), cudaMemcpyDeviceToDevice));
}

void exclusive_sum(Device, const uint64_t* in, uint64_t* out, std::size_t n) { exclusive_sum_impl(in, out, n); }
void exclusive_sum(Device, const uint32_t* in, uint32_t* out, std::size_t n) { exclusive_sum_impl(in, out, n); }

std::size_t unique_sorted(Device, uint64_t* keys, std::size_t n) {
  if (n < 2) return n;
  DeviceBuffer<uint64_t> out(n);
  DeviceBuffer<std::size_t> count(1);
  std::size_t temp_bytes = 0;
  MENISCUS_CUDA_CHECK(cub::DeviceSelect::Unique(nullptr, temp_bytes, keys, out.data(), count.data(), n));
  DeviceBuffer<unsigned char> temp(temp_bytes);
  MENISCUS_CUDA_CHECK(cub::DeviceSelect::Unique(temp.data(), temp_bytes, keys, out.data(), count.data(), n));
  const std::size_t m = count.get(0);
  MENISCUS_CUDA_CHECK(counted_memcpy(keys, out.data(), m * sizeof(uint64_t), cudaMemcpyDeviceToDevice));
  return m;
}

}  // namespace meniscus::cuda
