// meniscus — the CUDA backend's parallel primitives on the emulated device: host versions of the
// cub radix sorts, scan and unique of primitives.cu, with the same contracts (stable sorts by a
// range of key bits, an exclusive sum with the total at out[n]).
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <numeric>
#include <utility>
#include <vector>

#include "common/radix_sort.hpp"
#include "cuda/primitives.hpp"

namespace meniscus::cuda {

namespace {

template <class K>
void sort_pairs_impl(DeviceBuffer<K>& keys, DeviceBuffer<uint32_t>& values, std::size_t n, int begin_bit, int end_bit) {
  if (n < 2) return;
  std::vector<std::pair<K, uint32_t>> items(n);
  for (std::size_t i = 0; i < n; ++i) items[i] = {keys.data()[i], values.data()[i]};
  radix_sort_by(items, [](const std::pair<K, uint32_t>& p) { return uint64_t(p.first); }, begin_bit, end_bit);
  for (std::size_t i = 0; i < n; ++i) keys.data()[i] = items[i].first, values.data()[i] = items[i].second;
}

template <class T>
void exclusive_sum_impl(const T* in, T* out, std::size_t n) {
  T total = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const T v = in[i];  // in and out may be the same array
    out[i] = total;
    total += v;
  }
  out[n] = total;
}

}  // namespace

void sort_pairs(DeviceBuffer<uint64_t>& keys, DeviceBuffer<uint32_t>& values, std::size_t n, int begin_bit,
                int end_bit) {
  sort_pairs_impl(keys, values, n, begin_bit, end_bit);
}
void sort_pairs(DeviceBuffer<uint32_t>& keys, DeviceBuffer<uint32_t>& values, std::size_t n, int begin_bit,
                int end_bit) {
  sort_pairs_impl(keys, values, n, begin_bit, end_bit);
}
void sort_keys(DeviceBuffer<uint64_t>& keys, std::size_t n) { tbb::parallel_sort(keys.data(), keys.data() + n); }
void exclusive_sum(const uint64_t* in, uint64_t* out, std::size_t n) { exclusive_sum_impl(in, out, n); }
void exclusive_sum(const uint32_t* in, uint32_t* out, std::size_t n) { exclusive_sum_impl(in, out, n); }
std::size_t unique_sorted(DeviceBuffer<uint64_t>& keys, std::size_t n) {
  return std::size_t(std::unique(keys.data(), keys.data() + n) - keys.data());
}

}  // namespace meniscus::cuda
