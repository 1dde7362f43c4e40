// --min-particles: the surface's closed components that enclose fewer particles than the limit
// are dropped (strays, particles stuck in a wall), counted in the stats; checked against an
// independent count (ray parity of every particle against each component) on real frames and
// against a frame built with a known number of lone particles and pairs.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <numeric>

#include "grid/hash_grid.hpp"
#include "mesh/components.hpp"
#include "mesh/ray_parity_impl.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/io.hpp"
#include "meniscus/quality.hpp"
#include "meniscus/reconstruct.hpp"
#include "support/test_support.hpp"

namespace meniscus {
namespace {

struct ComponentCount {
  std::size_t triangles = 0;
  double volume = 0;
  uint32_t enclosed = 0;  ///< particles inside by ray parity, up to the limit
};

/// Every component of `mesh` (by shared vertices) with its triangle count, its signed volume and
/// the particles it encloses by ray parity (counted up to `limit`).
std::vector<ComponentCount> components_by_ray_parity(const TriangleMesh& mesh, const ParticleSet& ps, uint32_t limit) {
  const std::vector<uint32_t> root = component_roots(mesh.vertices.size(), mesh.triangles);
  std::map<uint32_t, std::vector<uint32_t>> triangles;
  for (uint32_t t = 0; t < mesh.triangles.size(); ++t) triangles[root[mesh.triangles[t][0]]].push_back(t);
  const HashGrid grid(ps.positions, 0.05f);
  std::vector<ComponentCount> out;
  for (const auto& [r, ids] : triangles) {
    ComponentCount c;
    c.triangles = ids.size();
    for (uint32_t t : ids) {
      const Vec3f a = mesh.vertices[mesh.triangles[t][0]], b = mesh.vertices[mesh.triangles[t][1]],
                  d = mesh.vertices[mesh.triangles[t][2]];
      c.volume += double(dot(a, cross(b, d))) / 6.0;
    }
    c.enclosed = count_enclosed_points(grid, mesh.triangles.data()->data(), ids.data(), uint32_t(ids.size()),
                                       mesh.vertices.data(), limit);
    out.push_back(c);
  }
  return out;
}

void expect_strays_removed(const ParticleSet& ps, Params p, const std::string& what) {
  p.backend = Backend::cpu;
  const Result all = reconstruct(ps, p);
  EXPECT_EQ(all.stats.removed_strays, 0u) << what;
  for (int n : {1, 2, 5}) {
    const std::vector<ComponentCount> counted = components_by_ray_parity(all.mesh, ps, uint32_t(n));
    std::size_t expected = 0, expected_triangles = all.mesh.triangles.size();
    for (const ComponentCount& c : counted)
      if (c.volume > 0 && c.enclosed < uint32_t(n)) ++expected, expected_triangles -= c.triangles;
    p.min_particles = n;
    const Result r = reconstruct(ps, p);
    EXPECT_EQ(r.stats.removed_strays, expected) << what << " --min-particles " << n;
    EXPECT_EQ(r.mesh.triangles.size(), expected_triangles) << what << " --min-particles " << n;
    EXPECT_EQ(r.stats.triangles, r.mesh.triangles.size()) << what;
    EXPECT_EQ(r.mesh.normals.size(), r.mesh.vertices.size()) << what;
    const TopologyReport t = analyze_topology(r.mesh);
    EXPECT_TRUE(t.watertight()) << what << " --min-particles " << n;
    EXPECT_EQ(t.unreferenced_vertices, 0u) << what;
  }
}

TEST(MinParticles, RealFramesLoseExactlyTheComponentsRayParityFindsWithFewParticles) {
  for (const char* frame : {"ply/dam_break_frame_23_24389_particles.ply", "ply/double_dam_break_frame_26_4732_particles.ply"}) {
    if (test::large_for_sanitizers(frame)) continue;  // the Release run has it
    const ParticleSet ps = read_particles(test::data_file(frame));
    expect_strays_removed(ps, Params{}, frame);
  }
}

// A block with 7 lone particles and 3 pairs far from it and from each other: --min-particles 2
// drops the 7 singles, 3 drops the pairs too, and the block stays. The anisotropic field (where a
// lone particle's kernel shrinks below the level and makes no surface) agrees with ray parity.
TEST(MinParticles, KnownSinglesAndPairs) {
  ParticleSet ps = test::lattice_block(10, 10, 6, 0.1f, 0.05f);
  for (int i = 0; i < 7; ++i) ps.positions.push_back({3.0f + 0.8f * float(i), 0.5f, 0.3f});
  for (int i = 0; i < 3; ++i) {
    ps.positions.push_back({0.5f, 3.0f + 0.8f * float(i), 0.3f});
    ps.positions.push_back({0.56f, 3.0f + 0.8f * float(i), 0.3f});
  }
  Params p;
  p.spacing = 0.1;
  p.backend = Backend::cpu;
  const Result all = reconstruct(ps, p);
  EXPECT_EQ(analyze_topology(all.mesh).components, 11u);
  for (auto [n, removed] : {std::pair{1, 0}, std::pair{2, 7}, std::pair{3, 10}}) {
    p.min_particles = n;
    const Result r = reconstruct(ps, p);
    EXPECT_EQ(r.stats.removed_strays, std::size_t(removed)) << "--min-particles " << n;
    EXPECT_EQ(analyze_topology(r.mesh).components, std::size_t(11 - removed)) << "--min-particles " << n;
  }
  p.min_particles = 0;
  expect_strays_removed(ps, p, "block with strays");
  p.field = FieldMethod::anisotropic;
  expect_strays_removed(ps, p, "block with strays, anisotropic");
  Params bad;
  bad.min_particles = -1;
  EXPECT_THROW(bad.validate(), InvalidParameter);
}

}  // namespace
}  // namespace meniscus

namespace meniscus {
namespace {

// The CLI option and the --config key give the library's result; the summary counts the strays.
TEST(MinParticles, CliOptionAndConfigKey) {
  test::TempDir tmp;
  const std::string frame = test::data_file("ply/dam_break_frame_23_24389_particles.ply");
  Params p;
  p.backend = Backend::cpu;
  p.min_particles = 2;
  const Result lib = reconstruct(read_particles(frame), p);
  ASSERT_GT(lib.stats.removed_strays, 0u);
  std::string out;
  ASSERT_EQ(test::run_command(test::cli() + " surface " + frame + " -o " + tmp.file("a.ply") +
                                  " --min-particles 2 --backend cpu --stats " + tmp.file("a.json"),
                              &out),
            0)
      << out;
  {
    std::ofstream config(tmp.file("c.json"));
    config << R"({"min_particles": 2, "backend": "cpu"})";
  }
  ASSERT_EQ(test::run_command(test::cli() + " surface " + frame + " -o " + tmp.file("b.ply") + " --config " +
                                  tmp.file("c.json") + " -q --stats " + tmp.file("b.json")),
            0);
  for (const char* stats : {"a.json", "b.json"}) {
    std::ifstream in(tmp.file(stats));
    const std::string text((std::istreambuf_iterator<char>(in)), {});
    EXPECT_NE(text.find("\"removed_strays\": " + std::to_string(lib.stats.removed_strays)), std::string::npos) << stats;
    EXPECT_NE(text.find("\"triangles\": " + std::to_string(lib.mesh.triangles.size())), std::string::npos) << stats;
  }
  std::string refused;
  EXPECT_NE(test::run_command(test::cli() + " surface " + frame + " -o " + tmp.file("c.ply") + " --min-particles -3", &refused), 0);
  EXPECT_FALSE(std::filesystem::exists(tmp.file("c.ply")));
}

}  // namespace
}  // namespace meniscus
