// One frame over K processes, process by process in one (the MPI transport is tested by
// tests/cluster/test_mpi.sh): the slabs' owned pieces weld into the whole frame's mesh, bit for bit.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <map>
#include <numeric>
#include <tuple>

#include "meniscus/distributed.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/io.hpp"
#include "meniscus/quality.hpp"
#include "meniscus/reconstruct.hpp"
#include "stage_plan.hpp"
#include "support/test_support.hpp"

namespace meniscus {
namespace {

template <class T>
bool same_bits(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

struct Split {
  std::size_t largest_slab = 0;  ///< particles of the largest slab with its halo
  std::size_t piece_triangles = 0;
};

/// Surfaces `particles` whole and in `ranks` slabs; expects the weld of the slabs' pieces to be
/// the whole frame's mesh in canonical order, bit for bit, closed and manifold.
Split expect_split_matches(const ParticleSet& particles, Params given, int ranks, const TriangleMesh& whole,
                           const std::string& what) {
  given = resolve_frame_estimates(particles, given);
  const Params p = resolve_params(particles, given);
  const Decomposition d = decompose(particles, p, ranks);
  EXPECT_EQ(int(d.cuts.size()), ranks - 1) << what;
  EXPECT_GE(d.halo, local_reach(p)) << what;
  std::vector<TriangleMesh> pieces;
  Split s;
  for (int r = 0; r < ranks; ++r) {
    const ParticleSet slab = slab_particles(particles, d, r);
    s.largest_slab = std::max(s.largest_slab, slab.size());
    if (slab.size() == 0) {
      pieces.emplace_back();
      continue;
    }
    pieces.push_back(owned_piece(reconstruct(slab, given).mesh, d, r));
    s.piece_triangles += pieces.back().triangles.size();
  }
  const TriangleMesh canonical = weld_pieces({whole}), merged = weld_pieces(pieces);
  EXPECT_EQ(merged.vertices.size(), whole.vertices.size()) << what;
  EXPECT_EQ(merged.triangles.size(), whole.triangles.size()) << what;
  EXPECT_EQ(s.piece_triangles, whole.triangles.size()) << what << ": a triangle in two pieces, or in none";
  EXPECT_TRUE(same_bits(merged.vertices, canonical.vertices)) << what << ": positions";
  EXPECT_TRUE(same_bits(merged.normals, canonical.normals)) << what << ": normals";
  // Recomputed on the welded mesh, the normals are the whole frame's to rounding.
  EXPECT_EQ(merged.normals.size(), merged.vertices.size()) << what;
  std::map<std::tuple<float, float, float>, Vec3f> original;
  for (std::size_t v = 0; v < whole.vertices.size(); ++v)
    original[{whole.vertices[v].x, whole.vertices[v].y, whole.vertices[v].z}] = whole.normals[v];
  float worst = 1;
  for (std::size_t v = 0; v < merged.normals.size(); ++v) {
    const auto it = original.find({merged.vertices[v].x, merged.vertices[v].y, merged.vertices[v].z});
    worst = std::min(worst, it == original.end() ? -1.0f : dot(it->second, merged.normals[v]));
  }
  EXPECT_GT(worst, 1 - 1e-6f) << what << ": normals against the whole frame's";
  EXPECT_TRUE(merged.triangles == canonical.triangles) << what << ": triangles";
  EXPECT_EQ(merged.attributes.size(), canonical.attributes.size()) << what;
  if (merged.attributes.size() != canonical.attributes.size()) return s;
  for (std::size_t a = 0; a < merged.attributes.size(); ++a)
    EXPECT_TRUE(same_bits(merged.attributes[a].values, canonical.attributes[a].values)) << what << ": " << merged.attributes[a].name;
  const TopologyReport t = analyze_topology(merged);
  EXPECT_TRUE(t.watertight()) << what;
  EXPECT_EQ(t.nonmanifold_vertices, 0u) << what;
  return s;
}

TEST(Distributed, DecompositionCutsOnBlockBoundariesBalancedByCount) {
  const ParticleSet ps = test::wide_splash(60000, 0.01f);
  Params given;
  given.spacing = 0.01;
  const Params p = resolve_params(ps, given);
  const Decomposition d = decompose(ps, p, 4);
  EXPECT_EQ(d.axis, 0) << "the pool is longest along x";
  const StagePlan plan = plan_stages(p);
  const double block = double(plan.lattice.cell_size) * plan.lattice.block_cells();
  std::vector<std::size_t> owned(4);
  for (const Vec3f& x : ps.positions)
    for (int r = 0; r < 4; ++r) owned[std::size_t(r)] += x.x >= d.lo(r) && x.x < d.hi(r);
  for (int r = 0; r < 3; ++r) {
    const double c = d.cuts[std::size_t(r)] / block;
    EXPECT_NEAR(c, std::round(c), 1e-9) << "cut " << r << " is not on a block boundary";
  }
  for (std::size_t n : owned) EXPECT_NEAR(double(n), double(ps.size()) / 4.0, 0.08 * double(ps.size())) << "balanced by count";
  EXPECT_EQ(std::accumulate(owned.begin(), owned.end(), std::size_t(0)), ps.size());
  // The halo holds what local_reach says a vertex reads.
  EXPECT_GE(d.halo, local_reach(p) + 2 * 0.61 * p.spacing);
}

// Every real frame in 2 and 4 slabs; the anisotropic field with its ellipsoid shells on the two
// largest. Most bundled frames are smaller than two halos, so their slabs hold most of the frame;
// the wide splash below is the case where they do not.
TEST(Distributed, RealFramesInSlabsWeldToTheWholeFrameBitForBit) {
  for (const auto& entry : std::filesystem::directory_iterator(test::data_file("ply"))) {
    const std::string name = entry.path().filename().string();
    const ParticleSet ps = read_particles(entry.path().string());
    for (const bool anisotropic : {false, true}) {
      if (anisotropic && name.find("dam_break_frame_23") == std::string::npos && name.find("sphysics") == std::string::npos)
        continue;
      Params given;
      if (anisotropic) given.field = FieldMethod::anisotropic;
      const TriangleMesh whole = reconstruct(ps, resolve_frame_estimates(ps, given)).mesh;
      for (int ranks : {2, 4})
        expect_split_matches(ps, given, ranks, whole, name + (anisotropic ? " anisotropic" : "") + " K=" + std::to_string(ranks));
    }
  }
}

// A 200k-particle wide splash in 4 slabs, where each slab with its halo holds well under the
// whole frame: the weld is the whole frame's mesh bit for bit. (The 1M and 3M splashes over real
// MPI ranks: bench/mpi.sh, bench/RESULTS.md.)
TEST(Distributed, WideSplashInFourSlabs) {
  const ParticleSet ps = test::wide_splash(200000, 0.01f);
  Params given;
  given.spacing = 0.01;
  const TriangleMesh whole = reconstruct(ps, given).mesh;
  const Split s = expect_split_matches(ps, given, 4, whole, "splash 200k K=4");
  EXPECT_LT(double(s.largest_slab), 0.7 * double(ps.size()));
}

// The weld refuses what it cannot do: two vertices of one piece at one position.
TEST(Distributed, WeldRefusesCoincidentVerticesOfOnePiece) {
  TriangleMesh m;
  m.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 0, 0}};
  m.triangles = {{0, 1, 2}, {0, 2, 3}};
  EXPECT_THROW(weld_pieces({m}), InvalidParameter);
  // Two pieces sharing an edge weld into one mesh of 4 vertices.
  TriangleMesh a, b;
  a.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  a.triangles = {{0, 1, 2}};
  b.vertices = {{1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  b.triangles = {{0, 1, 2}};
  const TriangleMesh w = weld_pieces({a, b});
  EXPECT_EQ(w.vertices.size(), 4u);
  EXPECT_EQ(w.triangles.size(), 2u);
}

}  // namespace
}  // namespace meniscus
