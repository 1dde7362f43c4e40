// meniscus — the parallel primitives of the CUDA backend: the device versions of the calls of
// common/primitives.hpp (same names, same contracts, the Device tag first), so that a stage
// written once over the backend tag runs on either. Sorts, scans and selects are cub's, behind
// plain functions so only primitives.cu instantiates them (compile time); reduce_index is a
// template (its functor is the caller's). On the emulated device they are the CPU's, except
// deterministic_sum, whose kernels run there as on a GPU.
#pragma once

#include <cstddef>
#include <cstdint>

#include "cuda/cuda_check.hpp"
#include "cuda/for_each.hpp"
#include "meniscus/vec.hpp"

#if defined(MENISCUS_CUDA_EMULATION)
#include "common/primitives.hpp"
#else
#include <thrust/iterator/counting_iterator.h>

#include <cub/device/device_reduce.cuh>
#endif

namespace meniscus::cuda {

/// Sorts the n pairs (keys[i], values[i]) stably by the key bits [begin_bit, end_bit), in place.
void sort_pairs(Device, uint64_t* keys, uint32_t* values, std::size_t n, int begin_bit = 0, int end_bit = 64);
void sort_pairs(Device, uint32_t* keys, uint32_t* values, std::size_t n, int begin_bit = 0, int end_bit = 32);
/// Sorts the n keys in place.
void sort_keys(Device, uint64_t* keys, std::size_t n);
/// out[i] = Σ_{k<i} in[k] for i ≤ n (out has n + 1 elements; out[n] is the total).
void exclusive_sum(Device, const uint64_t* in, uint64_t* out, std::size_t n);
void exclusive_sum(Device, const uint32_t* in, uint32_t* out, std::size_t n);
/// Moves the distinct values of the sorted keys[0, n) to the front; returns their count.
std::size_t unique_sorted(Device, uint64_t* keys, std::size_t n);

/// combine(… combine(identity, f(0)) …, f(n − 1)) for an associative, exact combine (min, max,
/// counts), to the host: f and combine are MENISCUS_HD callables.
template <class T, class F, class Combine>
T reduce_index(Device, std::size_t n, T identity, F f, Combine combine) {
#if defined(MENISCUS_CUDA_EMULATION)
  if (n == 0) return identity;
  DeviceBuffer<T> out(1);  // read back as on a device (a download and a wait)
  *out.data() = ::meniscus::reduce_index(Host{}, n, identity, f, combine);
  return out.get(0);
#else
  if (n == 0) return identity;
  DeviceBuffer<T> out(1);
  std::size_t temp_bytes = 0;
  const thrust::counting_iterator<uint64_t> first(0);
  MENISCUS_CUDA_CHECK(cub::DeviceReduce::TransformReduce(nullptr, temp_bytes, first, out.data(), n, combine, f, identity));
  DeviceBuffer<unsigned char> temp(temp_bytes);
  MENISCUS_CUDA_CHECK(
      cub::DeviceReduce::TransformReduce(temp.data(), temp_bytes, first, out.data(), n, combine, f, identity));
  return out.get(0);
#endif
}

// --- deterministic_sum: the fixed tree of deterministic_reduce, in parallel -------------------------
// The tree over [0, n) splits a range longer than `grain` at begin + (end − begin)/2, so the ranges
// at depth d have ⌊n/2ᵈ⌋ or ⌈n/2ᵈ⌉ elements. Every node above depth D, the least d with
// ⌊n/2ᵈ⌉ ≤ grain, is split; a node at depth D is a leaf or splits once more into two leaves. So one
// thread per node of depth D sums its leaf (or its two leaves, left + right), and the 2ᴰ values are
// then combined as a perfect binary tree, level by level, in one block with barriers: the same
// additions in the same order as the CPU's, in two launches whatever n.

/// D above: the depth of the tree's lowest complete level.
inline unsigned sum_tree_depth(std::size_t n, std::size_t grain) {
  unsigned depth = 0;
  while ((n >> depth) > grain) ++depth;
  return depth;
}

/// Node j (0 ≤ j < 2ᴰ, left to right) of depth D summed: heap[2ᴰ + j].
template <class F>
struct SumTreeNode {
  F term;
  uint64_t n, grain;
  unsigned depth;
  double* heap;
  MENISCUS_HD double leaf(uint64_t begin, uint64_t end) const {
    double s = 0.0;
    for (uint64_t i = begin; i < end; ++i) s += term(i);
    return s;
  }
  MENISCUS_HD void operator()(uint64_t j) const {
    uint64_t begin = 0, end = n;
    for (unsigned k = depth; k-- > 0;) {  // the path from the root: j's bits, highest first
      const uint64_t mid = begin + (end - begin) / 2;
      if ((j >> k) & 1u) begin = mid; else end = mid;
    }
    double s;
    if (end - begin > grain) {
      const uint64_t mid = begin + (end - begin) / 2;
      const double left = leaf(begin, mid), right = leaf(mid, end);
      s = left + right;
    } else {
      s = leaf(begin, end);
    }
    heap[(uint64_t(1) << depth) + j] = s;
  }
};

/// heap[k] = heap[2k] + heap[2k + 1] for the levels above D, deepest first; the root at heap[1].
/// One block: the barrier orders the levels. (A template only so that the header may define it.)
template <int = 0>
__global__ void sum_tree_levels_kernel(double* heap, unsigned depth) {
  for (unsigned d = depth; d-- > 0;) {
    const uint64_t first = uint64_t(1) << d;
    for (uint64_t k = first + threadIdx.x; k < 2 * first; k += blockDim.x) heap[k] = heap[2 * k] + heap[2 * k + 1];
    __syncthreads();
  }
}

/// Σ_{i<n} term(i) in doubles, to the host: the same tree and the same bits as the CPU's
/// deterministic_sum (common/primitives.hpp); term is a MENISCUS_HD callable of the index. Two
/// launches (one for n ≤ grain) and one read back.
template <class F>
double deterministic_sum(Device, std::size_t n, std::size_t grain, F term) {
  const unsigned depth = sum_tree_depth(n, grain);
  const uint64_t nodes = uint64_t(1) << depth;
  DeviceBuffer<double> heap(2 * nodes);
  for_each_index(Device{}, nodes, SumTreeNode<F>{term, uint64_t(n), uint64_t(grain), depth, heap.data()}, 64);
  if (depth > 0) {
    const unsigned threads = nodes / 2 < 1024 ? unsigned(nodes / 2) : 1024u;
    MENISCUS_LAUNCH(sum_tree_levels_kernel<0>, 1, threads)(heap.data(), depth);
    MENISCUS_CUDA_CHECK_LAUNCH();
  }
  return heap.get(1);
}

}  // namespace meniscus::cuda
