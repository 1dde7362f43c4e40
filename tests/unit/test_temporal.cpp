// Temporal smoothing of a frame's particles with the frames either side (meniscus/temporal.hpp):
// matched by id whatever their order, steady motion kept, noise filtered, the shift limited, and
// every frame that cannot be matched left as it is, with the reason.
#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <numeric>
#include <random>

#include "meniscus/errors.hpp"
#include "meniscus/temporal.hpp"

namespace meniscus {
namespace {

/// n particles on a jittered line of blocks, each with its id, in a shuffled order.
ParticleSet frame(std::size_t n, const std::function<Vec3f(std::size_t id)>& position, unsigned shuffle_seed) {
  std::vector<std::size_t> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::shuffle(order.begin(), order.end(), std::mt19937(shuffle_seed));
  ParticleSet p;
  Attribute ids{"id", 1, true, {}};
  Attribute speed{"speed", 1, false, {}};
  for (const std::size_t id : order) {
    p.positions.push_back(position(id));
    ids.values.push_back(float(id));
    speed.values.push_back(float(id) * 0.5f);
  }
  p.attributes = {speed, ids};
  return p;
}

Vec3f rest(std::size_t id) { return Vec3f{float(id % 10), float((id / 10) % 10), float(id / 100)} * 0.1f; }

/// The position of the particle with this id in a frame.
Vec3f of(const ParticleSet& p, std::size_t id) {
  const Attribute* ids = p.find("id");
  for (std::size_t i = 0; i < p.size(); ++i)
    if (ids->values[i] == float(id)) return p.positions[i];
  ADD_FAILURE() << "no particle " << id;
  return {};
}

/// The frame with its positions replaced, as the CLI surfaces it.
ParticleSet with_positions(ParticleSet frame, std::vector<Vec3f> positions) {
  EXPECT_EQ(positions.size(), frame.size());
  frame.positions = std::move(positions);
  return frame;
}

/// Bit for bit.
bool same(Vec3f a, Vec3f b) { return std::memcmp(&a, &b, sizeof(Vec3f)) == 0; }

constexpr std::size_t kN = 3000;

TEST(TemporalSmoothing, SteadyMotionIsKept) {
  const Vec3f v{0.037f, -0.021f, 0.013f};
  const ParticleSet a = frame(kN, [&](std::size_t id) { return rest(id) + v * 4.0f; }, 1);
  const ParticleSet b = frame(kN, [&](std::size_t id) { return rest(id) + v * 5.0f; }, 2);
  const ParticleSet c = frame(kN, [&](std::size_t id) { return rest(id) + v * 6.0f; }, 3);
  TemporalReport report;
  const std::vector<Vec3f> s = temporal_smoothing(a, b, c, 0.25, 0.025, &report);
  EXPECT_TRUE(report.applied);
  EXPECT_EQ(report.matched, kN);
  EXPECT_EQ(report.clamped, 0u);
  EXPECT_LT(report.max_shift, 1e-6);
  ASSERT_EQ(s.size(), kN);
  for (std::size_t i = 0; i < kN; ++i) EXPECT_LT(length(s[i] - b.positions[i]), 1e-6f) << i;
}

TEST(TemporalSmoothing, EachPositionIsTheWeightedMeanOfItsOwnThreeAndTheOrderDoesNotMatter) {
  std::mt19937 rng(7);
  std::normal_distribution<float> noise(0.0f, 0.005f);
  std::vector<Vec3f> e[3];
  for (auto& frame_noise : e)
    for (std::size_t i = 0; i < kN; ++i) frame_noise.push_back({noise(rng), noise(rng), noise(rng)});
  const auto at = [&](int f) { return [&, f](std::size_t id) { return rest(id) + e[f][id]; }; };
  const ParticleSet a = frame(kN, at(0), 11), b = frame(kN, at(1), 12), c = frame(kN, at(2), 13);
  TemporalReport report;
  const double w = 0.3;
  const ParticleSet s = with_positions(b, temporal_smoothing(a, b, c, w, 1.0, &report));
  EXPECT_EQ(report.matched, kN);
  double before = 0, after = 0;
  for (std::size_t id = 0; id < kN; id += 7) {
    const Vec3f got = of(s, id);
    for (int k = 0; k < 3; ++k) {
      const double expected = (1 - 2 * w) * double(of(b, id)[k]) + w * (double(of(a, id)[k]) + double(of(c, id)[k]));
      EXPECT_NEAR(double(got[k]), expected, 2e-6) << "id " << id << " axis " << k;
    }
    before += double(length2(of(b, id) - rest(id))), after += double(length2(got - rest(id)));
  }
  // Independent noise on each frame: its variance falls to (1 − 2w)² + 2w² = 0.34 of its own.
  EXPECT_NEAR(after / before, 0.34, 0.05);
  // The same particles in another order, and the frames in reverse, come out the same, bit for bit.
  const ParticleSet b2 = frame(kN, at(1), 99);
  const ParticleSet s2 = with_positions(b2, temporal_smoothing(c, b2, a, w, 1.0));
  for (std::size_t id = 0; id < kN; id += 13) EXPECT_TRUE(same(of(s, id), of(s2, id))) << id;
}

TEST(TemporalSmoothing, ShiftsAreCutToTheLimitAndUnmatchedParticlesKeepTheirPositions) {
  const ParticleSet a = frame(kN, rest, 1), b = frame(kN, rest, 2);
  // Particle 5 jumps far in the next frame (a collision, an id reused); particle 9 is gone from it.
  ParticleSet c = frame(kN, [](std::size_t id) { return id == 5 ? rest(id) + Vec3f{4, 0, 0} : rest(id); }, 3);
  const std::size_t gone = std::size_t(std::find(c.attributes[1].values.begin(), c.attributes[1].values.end(), 9.0f) -
                                       c.attributes[1].values.begin());
  c.positions.erase(c.positions.begin() + std::ptrdiff_t(gone));
  for (Attribute& x : c.attributes) x.values.erase(x.values.begin() + std::ptrdiff_t(gone));
  TemporalReport report;
  const ParticleSet s = with_positions(b, temporal_smoothing(a, b, c, 0.25, 0.02, &report));
  EXPECT_EQ(report.matched, kN - 1);
  EXPECT_EQ(report.clamped, 1u);
  EXPECT_NEAR(report.max_shift, 0.02, 1e-7);
  EXPECT_NEAR(double(length(of(s, 5) - rest(5))), 0.02, 1e-6);
  EXPECT_NEAR(double(of(s, 5)[0] - rest(5)[0]), 0.02, 1e-6);  // towards where it went
  EXPECT_TRUE(same(of(s, 9), of(b, 9)));
}

TEST(TemporalSmoothing, FramesThatCannotBeMatchedAreLeftAsTheyAreAndSayWhy) {
  const ParticleSet a = frame(100, rest, 1), b = frame(100, rest, 2);
  ParticleSet c = frame(100, [](std::size_t id) { return rest(id) + Vec3f{0.01f, 0, 0}; }, 3);
  const auto skipped = [&](const ParticleSet& x, const ParticleSet& y, const ParticleSet& z, double w = 0.25) {
    TemporalReport report;
    const std::vector<Vec3f> s = temporal_smoothing(x, y, z, w, 1.0, &report);
    EXPECT_FALSE(report.applied);
    EXPECT_EQ(s, y.positions);
    return report.skipped;
  };
  ParticleSet no_ids = c;
  no_ids.attributes.pop_back();
  EXPECT_EQ(skipped(a, b, no_ids), "no 'id' attribute in the next frame");
  EXPECT_EQ(skipped(no_ids, b, c), "no 'id' attribute in the previous frame");
  ParticleSet twice = b;
  twice.attributes[1].values[3] = twice.attributes[1].values[4];
  EXPECT_NE(skipped(a, twice, c).find("two particles with id"), std::string::npos);
  ParticleSet fractional = b;
  fractional.attributes[1].values[0] = 2.5f;
  EXPECT_NE(skipped(a, fractional, c).find("not all whole numbers"), std::string::npos);
  ParticleSet huge = b;
  huge.attributes[1].values[0] = 3e7f;  // beyond 2^24, where floats no longer hold every whole number
  EXPECT_NE(skipped(a, huge, c).find("not all whole numbers"), std::string::npos);
  EXPECT_EQ(skipped(a, b, c, 0.0), "the weight is 0");
  EXPECT_THROW(temporal_smoothing(a, b, c, 0.6, 1.0), InvalidParameter);
  EXPECT_THROW(temporal_smoothing(a, b, c, -0.1, 1.0), InvalidParameter);
  EXPECT_THROW(temporal_smoothing(a, b, c, 0.25, std::nan("")), InvalidParameter);
}

// Ids far apart (a Houdini emitter's over a long run) are matched through sorted keys instead of a
// table over the ids: the same positions.
TEST(TemporalSmoothing, SparseIdsGiveWhatDenseOnesGive) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<float> u(-0.01f, 0.01f);
  std::vector<Vec3f> e(3 * kN);
  for (Vec3f& x : e) x = {u(rng), u(rng), u(rng)};
  const auto at = [&](int f) { return [&, f](std::size_t id) { return rest(id) + e[std::size_t(f) * kN + id]; }; };
  ParticleSet dense[3] = {frame(kN, at(0), 1), frame(kN, at(1), 2), frame(kN, at(2), 3)}, sparse[3];
  for (int k = 0; k < 3; ++k) {
    sparse[k] = dense[k];
    for (float& id : sparse[k].attributes[1].values) id = id * 5000.0f + 7.0f;  // up to 1.5e7, below 2^24
  }
  TemporalReport a, b;
  const std::vector<Vec3f> x = temporal_smoothing(dense[0], dense[1], dense[2], 0.25, 1.0, &a);
  const std::vector<Vec3f> y = temporal_smoothing(sparse[0], sparse[1], sparse[2], 0.25, 1.0, &b);
  EXPECT_EQ(a.matched, kN);
  EXPECT_EQ(b.matched, kN);
  EXPECT_EQ(std::memcmp(x.data(), y.data(), kN * sizeof(Vec3f)), 0);
  sparse[1].attributes[1].values[5] = sparse[1].attributes[1].values[6];
  temporal_smoothing(sparse[0], sparse[1], sparse[2], 0.25, 1.0, &b);
  EXPECT_NE(b.skipped.find("two particles with id"), std::string::npos) << b.skipped;
}

TEST(TemporalSmoothing, TheSameOnAnyThreadCount) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-0.01f, 0.01f);
  std::vector<Vec3f> e(3 * 20000);
  for (Vec3f& x : e) x = {u(rng), u(rng), u(rng)};
  const auto at = [&](int f) { return [&, f](std::size_t id) { return rest(id) + e[std::size_t(f) * 20000 + id]; }; };
  const ParticleSet a = frame(20000, at(0), 1), b = frame(20000, at(1), 2), c = frame(20000, at(2), 3);
  std::vector<Vec3f> one, three;
  tbb::task_arena(1).execute([&] { one = temporal_smoothing(a, b, c, 0.25, 0.005); });
  tbb::task_arena(3).execute([&] { three = temporal_smoothing(a, b, c, 0.25, 0.005); });
  ASSERT_EQ(one.size(), three.size());
  EXPECT_EQ(std::memcmp(one.data(), three.data(), one.size() * sizeof(Vec3f)), 0);
}

}  // namespace
}  // namespace meniscus
