// Tests of the sparse distance field against brute-force nearest distances.
#include <gtest/gtest.h>

#include <random>
#include <set>

#include "field/band_field.hpp"
#include "field/distance_field.hpp"
#include "field/distance_field_impl.hpp"
#include "grid/build_grid.hpp"
#include "meniscus/io.hpp"
#include "meniscus/reconstruct.hpp"
#include "support/io_helpers.hpp"
#include "support/test_support.hpp"

namespace meniscus {
namespace {

void check_against_brute_force(SampleLattice::Kind kind) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<Vec3f> pts(300);
  for (auto& p : pts) p = {u(rng), u(rng), 0.3f * u(rng)};
  pts.push_back({6.0f, 6.0f, 6.0f});  // an isolated droplet far away
  const float band = 0.35f;
  const HashGrid grid(pts, 0.2f);
  SampleLattice lattice{kind, kind == SampleLattice::Kind::cubic ? 0.05f : 0.1f};
  const SparseField field = distance_field(grid, lattice, band, band_blocks(grid, lattice, band));
  ASSERT_GT(field.block_count(), 0u);
  EXPECT_EQ(field.background(), band);

  // Every allocated sample equals the brute-force distance clamped to the band.
  std::size_t checked = 0, inside = 0;
  const int n = lattice.block_cells();
  for (std::size_t b = 0; b < field.block_count(); ++b) {
    const Vec3i o = field.block_origin(b);
    for (int z = 0; z < n; ++z)
      for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x)
          for (int s = 0; s < lattice.samples_per_cell(); ++s) {
            const Vec3i cell{o.x + x, o.y + y, o.z + z};
            const Vec3f q = lattice.sample_position(cell, s);
            float best = INFINITY;
            for (const Vec3f& p : pts) best = std::min(best, length(p - q));
            const float expected = std::min(best, band);
            ASSERT_NEAR(field.value(cell, s), expected, 1e-5f) << "sample " << q.x << "," << q.y << "," << q.z;
            ++checked;
            inside += best < band;
          }
  }
  EXPECT_GT(inside, 1000u);
  // Samples in unallocated blocks are at least a band away from every particle.
  std::uniform_real_distribution<float> wide(-8.0f, 8.0f);
  for (int i = 0; i < 20000; ++i) {
    const Vec3i cell{int32_t(wide(rng) / lattice.cell_size), int32_t(wide(rng) / lattice.cell_size),
                     int32_t(wide(rng) / lattice.cell_size)};
    if (field.find_block(field.block_of(cell)) != kNotFound) continue;
    const Vec3f q = lattice.sample_position(cell, 0);
    float best = INFINITY;
    for (const Vec3f& p : pts) best = std::min(best, length(p - q));
    ASSERT_GE(best, band);
  }
  // The far droplet has its own few blocks; memory follows the band, not the bounding box.
  const double box_blocks = std::pow(7.0 / (double(lattice.cell_size) * n), 3);
  EXPECT_LT(double(field.block_count()), 0.2 * box_blocks);
}

TEST(DistanceField, CubicMatchesBruteForce) { check_against_brute_force(SampleLattice::Kind::cubic); }
TEST(DistanceField, A15MatchesBruteForce) { check_against_brute_force(SampleLattice::Kind::a15); }

/// The band's blocks, by either of band_blocks' paths — the byte map over the blocks' box (a
/// compact cloud) and the sorted key list (the same cloud and a particle far away, whose box would
/// need a map hundreds of times the cloud's) — are every block some hash cell's band box touches,
/// listed in key order once each, as a std::set of the same boxes lists them.
TEST(DistanceField, BandBlocksListEveryBlockOfTheBandInKeyOrder) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<Vec3f> cloud(2000);
  for (auto& p : cloud) p = {u(rng), 0.5f * u(rng), 0.2f * u(rng)};
  std::vector<Vec3f> spread = cloud;
  spread.push_back({40.0f, -35.0f, 30.0f});
  for (const auto& pts : {cloud, spread})
    for (const SampleLattice::Kind kind : {SampleLattice::Kind::cubic, SampleLattice::Kind::a15}) {
      const float band = 0.13f;
      const HashGrid grid(pts, 0.1f);
      const SampleLattice lattice{kind, kind == SampleLattice::Kind::cubic ? 0.02f : 0.04f};
      const float block_size = lattice.cell_size * float(lattice.block_cells());
      std::set<uint64_t> expected;
      for (const uint64_t key : grid.cell_keys()) {
        const Vec3i cell = unpack_coords(key);
        int32_t lo[3], hi[3];
        for (int a = 0; a < 3; ++a) band_block_range(cell[a], grid.cell_size(), band, block_size, &lo[a], &hi[a]);
        for (int32_t z = lo[2]; z <= hi[2]; ++z)
          for (int32_t y = lo[1]; y <= hi[1]; ++y)
            for (int32_t x = lo[0]; x <= hi[0]; ++x) expected.insert(pack_coords(x, y, z));
      }
      const std::vector<uint64_t> keys = band_blocks(grid, lattice, band);
      ASSERT_GT(keys.size(), 100u);
      EXPECT_EQ(keys, std::vector<uint64_t>(expected.begin(), expected.end()))
          << (pts.size() == cloud.size() ? "compact cloud" : "spread cloud");
    }
}

// The CPU's band blocks (a byte map over the blocks' box, or per-thread key lists) and its
// distance field (each block scatters its particles, rows of samples at a time) are fast paths of
// band_blocks and distance_field written once for both backends (field/band_field.hpp: keys
// sorted and made unique, each sample gathering its particles): run with Host{} on a real frame,
// on both lattices, they give the same block keys and the same field values (on every fifth
// block), bit for bit.
TEST(DistanceField, SharedGatherOnTheHostIsTheCpuScatterBitForBit) {
  const ParticleSet ps = read_particles(test::data_file("ply/dam_break_frame_23_24389_particles.ply"));
  const float d = float(estimate_spacing(ps));
  const uint32_t n = uint32_t(ps.positions.size());
  const float cell = 2 * d, band = 1.2f * d;  // as the pipeline's: cells of 2 r_outer, a band past r_outer = d
  const HashGrid cpu(ps.positions, cell);
  Vec3f lo, hi;
  point_bounds(Host{}, ps.positions.data(), n, &lo, &hi);
  const GridBuffers<Host> grid =
      build_grid(Host{}, ps.positions.data(), n, cell, grid_cell_of(lo, cell), grid_cell_of(hi, cell));
  for (const SampleLattice::Kind kind : {SampleLattice::Kind::a15, SampleLattice::Kind::cubic}) {
    SCOPED_TRACE(kind == SampleLattice::Kind::a15 ? "a15" : "cubic");
    const SampleLattice lattice{kind, kind == SampleLattice::Kind::a15 ? d : d / 2};
    const std::vector<uint64_t> cpu_keys = band_blocks(cpu, lattice, band);
    std::size_t blocks = 0;
    HostBuffer<uint64_t> keys = band_blocks(Host{}, grid, lattice, band, &blocks);
    ASSERT_EQ(blocks, cpu_keys.size());
    ASSERT_GT(blocks, 100u);
    for (std::size_t b = 0; b < blocks; ++b) ASSERT_EQ(keys.data()[b], cpu_keys[b]) << b;
    const SparseField scattered = distance_field(cpu, lattice, band, cpu_keys);
    EXPECT_EQ(scattered.background(), band);
    // The gather over every fifth block: on the CPU it costs far more than the scatter.
    std::vector<uint64_t> every_fifth;
    for (std::size_t b = 0; b < blocks; b += 5) every_fifth.push_back(cpu_keys[b]);
    keys.upload(every_fifth.data(), every_fifth.size());
    const FieldBuffers<Host> gathered = distance_field(Host{}, grid, lattice, band, std::move(keys), every_fifth.size());
    ASSERT_EQ(gathered.blocks, every_fifth.size());
    EXPECT_EQ(gathered.background, band);
    std::size_t inside = 0;
    for (std::size_t g = 0; g < every_fifth.size(); ++g) {
      const auto values = scattered.block_values(5 * g);
      for (std::size_t j = 0; j < std::size_t(kBlockSamples); ++j) {
        const float value = gathered.values.data()[g * kBlockSamples + j];
        ASSERT_TRUE(test::same_bits(value, values[j])) << "block " << 5 * g << " sample " << j << ": " << value << " vs " << values[j];
        inside += values[j] < band;
      }
    }
    EXPECT_GT(inside, every_fifth.size() * kBlockSamples / 10);  // not just the band's limit
  }
}

}  // namespace
}  // namespace meniscus
