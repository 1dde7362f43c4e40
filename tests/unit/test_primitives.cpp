// Tests of the CPU backend's parallel primitives (common/primitives.hpp) against serial versions:
// reductions, the fixed-tree reduction on several thread counts, sort, per-thread scratch and the
// chunked prefix count.
#include <gtest/gtest.h>
#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_reduce.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstdint>
#include <functional>
#include <numeric>
#include <random>
#include <stdexcept>
#include <tuple>
#include <utility>
#include <vector>

#include "common/atomic.hpp"
#include "common/buffer.hpp"
#include "common/primitives.hpp"

namespace meniscus {
namespace {

/// Runs f with at most `threads` worker threads.
template <class F>
auto with_threads(int threads, F&& f) {
  tbb::global_control cap(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
  tbb::task_arena arena(threads);
  return arena.execute(std::forward<F>(f));
}

/// Floats spread over many magnitudes and both signs, so the order of a sum changes its bits.
std::vector<float> spread_floats(std::size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> mantissa(-1.0f, 1.0f);
  std::uniform_int_distribution<int> exponent(-20, 20);
  std::vector<float> x(n);
  for (float& v : x) v = std::ldexp(mantissa(rng), exponent(rng));
  return x;
}

/// The fixed tree written out serially: split at the midpoint while longer than the grain, leaves
/// summed from zero, nodes left + right.
double tree_sum(const std::vector<float>& x, std::size_t begin, std::size_t end, std::size_t grain) {
  if (end - begin > grain) {
    const std::size_t mid = begin + (end - begin) / 2;
    return tree_sum(x, begin, mid, grain) + tree_sum(x, mid, end, grain);
  }
  double s = 0.0;
  for (std::size_t i = begin; i < end; ++i) s += double(x[i]);
  return s;
}

double deterministic_sum(const std::vector<float>& x, std::size_t grain) {
  return deterministic_reduce(
      x.size(), grain, 0.0,
      [&](std::size_t begin, std::size_t end, double s) {
        for (std::size_t i = begin; i < end; ++i) s += double(x[i]);
        return s;
      },
      std::plus<>());
}

TEST(Primitives, ReduceEqualsSerialSum) {
  std::mt19937_64 rng(3);
  std::vector<uint64_t> x(100'003);
  for (uint64_t& v : x) v = rng() >> 20;
  const uint64_t serial = std::accumulate(x.begin(), x.end(), uint64_t(0));
  for (const std::size_t grain : {std::size_t(1), std::size_t(1000), std::size_t(1) << 20}) {
    std::size_t calls = 0;
    const uint64_t sum = reduce(
        x.size(), grain, uint64_t(0),
        [&](std::size_t begin, std::size_t end, uint64_t s) {
          std::atomic_ref<std::size_t>(calls).fetch_add(1);
          for (std::size_t i = begin; i < end; ++i) s += x[i];
          return s;
        },
        std::plus<>());
    EXPECT_EQ(sum, serial) << "grain " << grain;
    EXPECT_GE(calls, 1u);
    if (grain >= x.size()) {
      EXPECT_EQ(calls, 1u);  // never split below the grain
    }
  }
  // Min and max of a struct, the way the bounding boxes use it; nothing to reduce gives the identity.
  struct MinMax {
    uint64_t lo = UINT64_MAX, hi = 0;
  };
  const auto fold = [&](std::size_t begin, std::size_t end, MinMax m) {
    for (std::size_t i = begin; i < end; ++i) m.lo = std::min(m.lo, x[i]), m.hi = std::max(m.hi, x[i]);
    return m;
  };
  const auto join = [](MinMax a, const MinMax& b) { return MinMax{std::min(a.lo, b.lo), std::max(a.hi, b.hi)}; };
  const MinMax m = reduce(x.size(), 256, MinMax{}, fold, join);
  EXPECT_EQ(m.lo, *std::min_element(x.begin(), x.end()));
  EXPECT_EQ(m.hi, *std::max_element(x.begin(), x.end()));
  const MinMax none = reduce(0, 256, MinMax{}, fold, join);
  EXPECT_EQ(none.lo, UINT64_MAX);
  EXPECT_EQ(none.hi, 0u);
}

TEST(Primitives, ReducePropagatesExceptions) {
  EXPECT_THROW(reduce(
                   10'000, 16, 0,
                   [](std::size_t begin, std::size_t end, int acc) {
                     if (begin <= 5000 && 5000 < end) throw std::invalid_argument("index 5000");
                     return acc;
                   },
                   std::plus<>()),
               std::invalid_argument);
}

TEST(Primitives, DeterministicReduceIsTheSameOnAnyThreadCount) {
  const std::vector<float> x = spread_floats(1'000'003, 11);
  for (const std::size_t grain : {std::size_t(1), std::size_t(4096), std::size_t(100'000)}) {
    const double one = with_threads(1, [&] { return deterministic_sum(x, grain); });
    const double two = with_threads(2, [&] { return deterministic_sum(x, grain); });
    const double eight = with_threads(8, [&] { return deterministic_sum(x, grain); });
    EXPECT_EQ(std::bit_cast<uint64_t>(one), std::bit_cast<uint64_t>(two)) << "grain " << grain;
    EXPECT_EQ(std::bit_cast<uint64_t>(one), std::bit_cast<uint64_t>(eight)) << "grain " << grain;
    // The tree is the documented one, and the one of a direct oneTBB call with the same grain (the
    // call the quality metrics made before they went through the primitive).
    EXPECT_EQ(std::bit_cast<uint64_t>(one), std::bit_cast<uint64_t>(tree_sum(x, 0, x.size(), grain)));
    const double direct = with_threads(8, [&] {
      return tbb::parallel_deterministic_reduce(
          tbb::blocked_range<std::size_t>(0, x.size(), grain), 0.0,
          [&](const tbb::blocked_range<std::size_t>& r, double s) {
            for (std::size_t i = r.begin(); i != r.end(); ++i) s += double(x[i]);
            return s;
          },
          std::plus<>());
    });
    EXPECT_EQ(std::bit_cast<uint64_t>(one), std::bit_cast<uint64_t>(direct)) << "grain " << grain;
  }
  // The data are such that the summation order shows in the bits (else the above proves little).
  EXPECT_NE(std::bit_cast<uint64_t>(tree_sum(x, 0, x.size(), 1)), std::bit_cast<uint64_t>(tree_sum(x, 0, x.size(), 4096)));
  EXPECT_EQ(deterministic_sum({}, 4096), 0.0);
}

TEST(Primitives, SortMatchesStdSort) {
  std::mt19937_64 rng(5);
  std::vector<uint64_t> keys(200'000);
  for (uint64_t& k : keys) k = rng() % 50'000;  // many repeats
  std::vector<uint64_t> expected = keys;
  std::sort(expected.begin(), expected.end());
  sort(Host{}, keys.begin(), keys.end());
  EXPECT_EQ(keys, expected);

  // With a comparator, over pairs whose full order leaves no ties that can be told apart.
  std::vector<std::pair<uint32_t, uint32_t>> pairs(100'000);
  for (auto& [a, b] : pairs) a = uint32_t(rng() % 1000), b = uint32_t(rng() % 1000);
  std::vector<std::pair<uint32_t, uint32_t>> by_second = pairs;
  const auto second_first = [](const auto& p, const auto& q) { return std::tie(p.second, p.first) < std::tie(q.second, q.first); };
  std::sort(by_second.begin(), by_second.end(), second_first);
  sort(Host{}, pairs.begin(), pairs.end(), second_first);
  EXPECT_EQ(pairs, by_second);
}

TEST(Primitives, PerThreadCollectsEveryItemOnce) {
  const std::size_t n = 300'000;
  PerThread<std::vector<uint32_t>> seen;
  with_threads(8, [&] {
    for_each_chunk(n, 64, [&](std::size_t begin, std::size_t end) {
      std::vector<uint32_t>& local = seen.local();
      for (std::size_t i = begin; i < end; ++i) local.push_back(uint32_t(i));
    });
  });
  std::vector<uint32_t> all;
  std::size_t copies = 0;
  for (const std::vector<uint32_t>& local : seen) all.insert(all.end(), local.begin(), local.end()), ++copies;
  EXPECT_GE(copies, 1u);
  EXPECT_LE(copies, 8u);
  std::sort(all.begin(), all.end());
  std::vector<uint32_t> expected(n);
  std::iota(expected.begin(), expected.end(), 0u);
  EXPECT_EQ(all, expected);

  // Made by the given function, once per thread that asks.
  std::atomic<int> made{0};
  PerThread<std::vector<int>> scratch([&] {
    ++made;
    return std::vector<int>(16, 7);
  });
  with_threads(2, [&] {
    for_each_index(1000, [&](std::size_t) { EXPECT_EQ(scratch.local().size(), 16u); });
  });
  int count = 0;
  for (const std::vector<int>& s : scratch) count += s.front() == 7;
  EXPECT_EQ(count, made.load());
  EXPECT_GE(count, 1);
  EXPECT_LE(count, 2);
}

TEST(Primitives, ChunkOffsetsAreTheSerialPrefixSum) {
  // Several chunks, a partial last one, an empty chunk and a full one.
  const std::size_t n = 4 * kOffsetChunk + 123;
  std::mt19937 rng(9);
  std::vector<uint8_t> flags(n);
  for (uint8_t& f : flags) f = rng() % 3 == 0;
  std::fill(flags.begin() + std::ptrdiff_t(kOffsetChunk), flags.begin() + std::ptrdiff_t(2 * kOffsetChunk), 0);
  std::fill(flags.begin() + std::ptrdiff_t(2 * kOffsetChunk), flags.begin() + std::ptrdiff_t(3 * kOffsetChunk), 1);
  std::vector<std::size_t> serial(n + 1, 0);  // serial[i]: set indices below i
  for (std::size_t i = 0; i < n; ++i) serial[i + 1] = serial[i] + flags[i];

  std::vector<std::size_t> offsets;
  const std::size_t total = chunk_offsets(flags, offsets);
  EXPECT_EQ(total, serial[n]);
  ASSERT_EQ(offsets.size(), 6u);
  for (std::size_t c = 0; c < offsets.size(); ++c) EXPECT_EQ(offsets[c], serial[std::min(n, c * kOffsetChunk)]) << c;

  // The predicate form gives the same offsets, and for_each_set hands each set index its rank once.
  std::vector<std::size_t> by_predicate;
  EXPECT_EQ(chunk_offsets(n, [&](std::size_t i) { return flags[i] != 0; }, by_predicate), total);
  EXPECT_EQ(by_predicate, offsets);
  std::vector<uint32_t> at_rank(total, UINT32_MAX);
  for_each_set(flags, offsets, [&](std::size_t i, std::size_t rank) {
    EXPECT_EQ(rank, serial[i]);
    at_rank[rank] = uint32_t(i);
  });
  std::vector<uint32_t> expected;
  for (std::size_t i = 0; i < n; ++i)
    if (flags[i]) expected.push_back(uint32_t(i));
  EXPECT_EQ(at_rank, expected);

  EXPECT_EQ(chunk_offsets(std::vector<uint8_t>{}, offsets), 0u);
  EXPECT_EQ(offsets, std::vector<std::size_t>{0});
}


// --- the backend primitives' CPU versions (the device's have the same contracts) -----------------

TEST(BackendPrimitives, ExclusiveSumHasTheTotalAtTheEndAndMayRunInPlace) {
  for (std::size_t n : {std::size_t(0), std::size_t(1), std::size_t(1000), 3 * kOffsetChunk + 17}) {
    std::vector<uint64_t> in(n);
    std::mt19937 rng(static_cast<uint32_t>(n));
    for (uint64_t& v : in) v = rng() % 7;
    std::vector<uint64_t> expected(n + 1, 0);
    for (std::size_t i = 0; i < n; ++i) expected[i + 1] = expected[i] + in[i];
    std::vector<uint64_t> out(n + 1, 99);
    with_threads(4, [&] { exclusive_sum(Host{}, in.data(), out.data(), n); });
    EXPECT_EQ(out, expected) << n;
    std::vector<uint64_t> same(in);
    same.push_back(0);
    exclusive_sum(Host{}, same.data(), same.data(), n);
    EXPECT_EQ(same, expected) << n << " in place";
  }
}

TEST(BackendPrimitives, SortPairsIsStableOnTheBitsAskedFor) {
  const std::size_t n = 300000;
  std::vector<uint64_t> keys(n);
  std::vector<uint32_t> values(n);
  std::mt19937_64 rng(5);
  for (std::size_t i = 0; i < n; ++i) keys[i] = rng(), values[i] = uint32_t(i);
  // Bits [8, 20) only: many ties, which must keep their order (the values ascend within a key).
  std::vector<std::pair<uint64_t, uint32_t>> expected(n);
  for (std::size_t i = 0; i < n; ++i) expected[i] = {keys[i], values[i]};
  std::stable_sort(expected.begin(), expected.end(),
                   [](const auto& a, const auto& b) { return (a.first >> 8 & 0xfff) < (b.first >> 8 & 0xfff); });
  sort_pairs(Host{}, keys.data(), values.data(), n, 8, 20);
  for (std::size_t i = 0; i < n; ++i) {
    ASSERT_EQ(keys[i], expected[i].first) << i;
    ASSERT_EQ(values[i], expected[i].second) << i;
  }
}

TEST(BackendPrimitives, UniqueSortedAndReduceIndex) {
  std::vector<uint64_t> keys = {1, 1, 2, 5, 5, 5, 9};
  ASSERT_EQ(unique_sorted(Host{}, keys.data(), keys.size()), 4u);
  EXPECT_EQ(std::vector<uint64_t>(keys.begin(), keys.begin() + 4), (std::vector<uint64_t>{1, 2, 5, 9}));
  const std::vector<float> v = spread_floats(100000, 3);
  const float expected = *std::min_element(v.begin(), v.end());
  const float got = with_threads(
      4, [&] { return reduce_index(Host{}, v.size(), INFINITY, [&](std::size_t i) { return v[i]; },
                                   [](float a, float b) { return b < a ? b : a; }); });
  EXPECT_EQ(got, expected);
  EXPECT_EQ(reduce_index(Host{}, 0, 7, [](std::size_t) { return 1; }, [](int a, int b) { return a + b; }), 7);
}

TEST(BackendPrimitives, HostBufferHasTheDeviceBufferInterface) {
  BufferOf<Host, uint32_t> b(5);
  b.zero();
  EXPECT_EQ(b.size(), 5u);
  EXPECT_EQ(b.get(4), 0u);
  const uint32_t in[3] = {7, 8, 9};
  b.upload(in, 3);
  EXPECT_EQ(b.size(), 3u);
  HostBuffer<uint32_t> c;
  c.copy_from(b);
  uint32_t out[3] = {};
  c.download(out, 3);
  EXPECT_EQ(out[2], 9u);
  EXPECT_THROW(c.download(out, 4), std::out_of_range);
  b.resize(0);
  EXPECT_EQ(b.data(), nullptr);
}


TEST(BackendPrimitives, AtomicsOfSharedCodeCountAndTakeMinimaUnderContention) {
  uint32_t count = 0, least = UINT32_MAX, most = 0;
  unsigned long long wide = 0;
  with_threads(4, [&] {
    for_each_index(Host{}, 100000, [&](std::size_t i) {
      atomic_add(&count, 1u);
      atomic_add(&wide, 2ull);
      atomic_min(&least, uint32_t(i ^ 0x5555));
      atomic_max(&most, uint32_t(i ^ 0x5555));
    });
  });
  EXPECT_EQ(count, 100000u);
  EXPECT_EQ(wide, 200000ull);
  uint32_t lo = UINT32_MAX, hi = 0;
  for (uint32_t i = 0; i < 100000; ++i) lo = std::min(lo, i ^ 0x5555u), hi = std::max(hi, i ^ 0x5555u);
  EXPECT_EQ(least, lo);
  EXPECT_EQ(most, hi);
  uint32_t slot = 3;
  EXPECT_EQ(atomic_exchange(&slot, 9u), 3u);
  EXPECT_EQ(slot, 9u);
}

}  // namespace
}  // namespace meniscus
