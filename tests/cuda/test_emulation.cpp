// The emulated CUDA device (MENISCUS_CUDA_EMULATION builds): it runs a block's threads with the
// blockDim the launch asked for, honours __syncthreads and the warp reductions as barriers, keeps
// one __shared__ copy per block, and changes the threads' order from block to block and launch to
// launch — so a missing barrier, a race between a block's threads or a barrier that not every
// thread reaches fails here as it would on a GPU, where the device parity tests would otherwise
// pass.
#include <gtest/gtest.h>

#include <cuda_runtime.h>

#include <cstdint>
#include <set>
#include <vector>

namespace {

using meniscus::cuda::emulation::launch;

constexpr unsigned kThreads = 256, kBlocks = 64;

/// Each block reverses its 256 values through shared memory.
template <bool kBarrier>
void reverse_kernel(const uint32_t* in, uint32_t* out) {
  __shared__ uint32_t s[kThreads];
  const unsigned t = threadIdx.x, base = blockIdx.x * blockDim.x;
  s[t] = in[base + t];
  if (kBarrier) __syncthreads();
  out[base + t] = s[blockDim.x - 1 - t];
}

/// Launches the reversal and counts the values it got wrong.
template <bool kBarrier>
int reverse_errors(uint32_t launch_number) {
  std::vector<uint32_t> in(kThreads * kBlocks), out(in.size(), 0);
  for (uint32_t i = 0; i < in.size(); ++i) in[i] = launch_number * 100000u + i;  // never what an earlier launch left
  launch(reverse_kernel<kBarrier>, dim3(kBlocks), dim3(kThreads))(in.data(), out.data());
  EXPECT_EQ(cudaGetLastError(), cudaSuccess);
  int wrong = 0;
  for (unsigned b = 0; b < kBlocks; ++b)
    for (unsigned t = 0; t < kThreads; ++t) wrong += out[b * kThreads + t] != in[b * kThreads + kThreads - 1 - t];
  return wrong;
}

TEST(EmulatedDevice, ABarrierOrdersTheBlocksSharedMemory) {
  for (uint32_t l = 1; l <= 4; ++l) EXPECT_EQ(reverse_errors<true>(l), 0) << "launch " << l;
}

TEST(EmulatedDevice, AMissingBarrierGivesWrongValues) {
  // Without the barrier, of threads t and 255 - t the one that runs first reads the other's slot
  // before it is written, whatever the order: every launch gets values wrong.
  for (uint32_t l = 5; l <= 8; ++l) EXPECT_GT(reverse_errors<false>(l), 0) << "launch " << l;
}

void last_writer_kernel(uint32_t* out) { out[blockIdx.x] = threadIdx.x; }

TEST(EmulatedDevice, ARaceBetweenABlocksThreadsGivesDifferentResults) {
  // Every thread writes the same word: which one wins depends on the order the threads ran in, and
  // that order changes from block to block, so the blocks disagree.
  std::vector<uint32_t> out(kBlocks, ~0u);
  launch(last_writer_kernel, dim3(kBlocks), dim3(kThreads))(out.data());
  ASSERT_EQ(cudaGetLastError(), cudaSuccess);
  const std::set<uint32_t> winners(out.begin(), out.end());
  EXPECT_GE(winners.size(), 3u);
  for (const uint32_t w : winners) EXPECT_LT(w, kThreads);
}

/// Sums a block's thread numbers with a warp reduction per warp and shared memory across warps.
void block_sum_kernel(uint32_t* out) {
  __shared__ int warp_sums[kThreads / 32];
  const int sum = __reduce_add_sync(0xffffffffu, int(threadIdx.x));
  if (threadIdx.x % 32 == 0) warp_sums[threadIdx.x / 32] = sum;
  __syncthreads();
  if (threadIdx.x == 0) {
    int total = 0;
    for (unsigned w = 0; w < blockDim.x / 32; ++w) total += warp_sums[w];
    out[blockIdx.x] = uint32_t(total);
  }
}

TEST(EmulatedDevice, WarpReductionsSeeEveryLaneOfTheirWarp) {
  std::vector<uint32_t> out(kBlocks, 0);
  launch(block_sum_kernel, dim3(kBlocks), dim3(kThreads))(out.data());
  ASSERT_EQ(cudaGetLastError(), cudaSuccess);
  for (unsigned b = 0; b < kBlocks; ++b) EXPECT_EQ(out[b], kThreads * (kThreads - 1) / 2) << "block " << b;
}

/// Odd threads wait at the block's barrier, even ones at a warp reduction the odd lanes never
/// reach: on a GPU this hangs or corrupts; here it is a launch failure.
void divergent_kernel(uint32_t* out) {
  if (threadIdx.x % 2 == 1) __syncthreads();
  else out[blockIdx.x] = uint32_t(__reduce_add_sync(0xffffffffu, 1));
}

TEST(EmulatedDevice, ABarrierNotEveryThreadReachesIsALaunchFailure) {
  std::vector<uint32_t> out(kBlocks, 0);
  launch(divergent_kernel, dim3(kBlocks), dim3(kThreads))(out.data());
  EXPECT_EQ(cudaGetLastError(), cudaErrorLaunchFailure);
  EXPECT_EQ(cudaGetLastError(), cudaSuccess);  // reported once
  // The next launch runs normally.
  EXPECT_EQ(reverse_errors<true>(9), 0);
}

}  // namespace
