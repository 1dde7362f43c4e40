// meniscus — the CUDA backend's parallel primitives on the emulated device: the CPU's
// (common/primitives.hpp), which have the same contracts as cub's calls in primitives.cu (stable
// sorts by a range of key bits, an exclusive sum with the total at out[n]).
#include "common/primitives.hpp"
#include "cuda/primitives.hpp"

namespace meniscus::cuda {

void sort_pairs(Device, uint64_t* keys, uint32_t* values, std::size_t n, int begin_bit, int end_bit) {
  ::meniscus::sort_pairs(Host{}, keys, values, n, begin_bit, end_bit);
}
void sort_pairs(Device, uint32_t* keys, uint32_t* values, std::size_t n, int begin_bit, int end_bit) {
  ::meniscus::sort_pairs(Host{}, keys, values, n, begin_bit, end_bit);
}
void sort_keys(Device, uint64_t* keys, std::size_t n) { ::meniscus::sort_keys(Host{}, keys, n); }
void exclusive_sum(Device, const uint64_t* in, uint64_t* out, std::size_t n) {
  ::meniscus::exclusive_sum(Host{}, in, out, n);
}
void exclusive_sum(Device, const uint32_t* in, uint32_t* out, std::size_t n) {
  ::meniscus::exclusive_sum(Host{}, in, out, n);
}
std::size_t unique_sorted(Device, uint64_t* keys, std::size_t n) { return ::meniscus::unique_sorted(Host{}, keys, n); }

}  // namespace meniscus::cuda
