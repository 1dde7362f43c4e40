// --clip-box / --clip-cap: the finished surface cut by a box, open along the cut or closed with
// the box's faces. Checked on real frames: every vertex in the box, the uncut part bit for bit the
// surface without the box (the cut runs after the smoothing), the open edges on the box's faces,
// and — the independent count — the capped pieces of a frame cut by boxes that tile its bounds
// enclose together exactly the uncut surface's volume.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <set>

#include "meniscus/errors.hpp"
#include "meniscus/io.hpp"
#include "meniscus/quality.hpp"
#include "meniscus/reconstruct.hpp"
#include "support/test_support.hpp"

namespace meniscus {
namespace {

using Box = std::array<double, 6>;

double volume(const TriangleMesh& mesh) {
  double v = 0;
  for (const Triangle& t : mesh.triangles)
    v += double(dot(mesh.vertices[t[0]], cross(mesh.vertices[t[1]], mesh.vertices[t[2]]))) / 6.0;
  return v;
}

bool on_face(Vec3f x, const Box& box) {
  for (int c = 0; c < 3; ++c)
    if (x[c] == float(box[std::size_t(c)]) || x[c] == float(box[std::size_t(c) + 3])) return true;
  return false;
}

/// The undirected edges used by one triangle only.
std::vector<std::pair<uint32_t, uint32_t>> open_edges(const TriangleMesh& mesh) {
  std::map<std::pair<uint32_t, uint32_t>, int> uses;
  for (const Triangle& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) {
      const uint32_t a = t[std::size_t(k)], b = t[std::size_t((k + 1) % 3)];
      ++uses[{std::min(a, b), std::max(a, b)}];
    }
  std::vector<std::pair<uint32_t, uint32_t>> open;
  for (const auto& [e, n] : uses)
    if (n == 1) open.push_back(e);
  return open;
}

Result surface(const ParticleSet& ps, const std::vector<double>& box, bool cap) {
  Params p;
  p.backend = Backend::cpu;
  p.clip_box = box;
  p.clip_cap = cap;
  return reconstruct(ps, p);
}

TEST(ClipBox, CutsTheDamBreakExactlyAndLeavesTheRestAsItWas) {
  const ParticleSet ps = read_particles(test::data_file("ply/dam_break_frame_23_24389_particles.ply"));
  const Result full = surface(ps, {}, false);
  // Off the tank's floor and side walls, through the splash.
  const Box box{-1.45, 0.04, -0.7, 1.2, 1.5, 0.7};
  const Result cut = surface(ps, {box.begin(), box.end()}, false);
  EXPECT_GT(cut.stats.clipped_triangles, 100000u);
  EXPECT_GT(cut.stats.cut_triangles, 1000u);
  EXPECT_EQ(cut.stats.cap_triangles, 0u);
  EXPECT_EQ(cut.stats.triangles, cut.mesh.triangles.size());
  ASSERT_EQ(cut.mesh.normals.size(), cut.mesh.vertices.size());

  // Every vertex in the box (the box's floats, as the mesh's coordinates are).
  for (const Vec3f x : cut.mesh.vertices)
    for (int c = 0; c < 3; ++c) {
      ASSERT_GE(x[c], float(box[std::size_t(c)]));
      ASSERT_LE(x[c], float(box[std::size_t(c) + 3]));
    }
  // Off the faces, the vertices (and their normals) are the uncut surface's, bit for bit; and
  // every uncut triangle inside the box is there.
  std::map<std::array<float, 3>, uint32_t> uncut;
  for (uint32_t v = 0; v < full.mesh.vertices.size(); ++v) {
    const Vec3f x = full.mesh.vertices[v];
    uncut[{x.x, x.y, x.z}] = v;
  }
  std::size_t inner = 0;
  for (uint32_t v = 0; v < cut.mesh.vertices.size(); ++v) {
    const Vec3f x = cut.mesh.vertices[v];
    if (on_face(x, box)) continue;
    ++inner;
    const auto it = uncut.find({x.x, x.y, x.z});
    ASSERT_NE(it, uncut.end()) << "vertex " << v << " inside the box moved";
    EXPECT_TRUE(cut.mesh.normals[v] == full.mesh.normals[it->second]);
  }
  EXPECT_GT(inner, 40000u);
  std::set<std::array<std::array<float, 3>, 3>> kept;
  for (const Triangle& t : cut.mesh.triangles) {
    std::array<std::array<float, 3>, 3> corners;
    for (int k = 0; k < 3; ++k) {
      const Vec3f x = cut.mesh.vertices[t[std::size_t(k)]];
      corners[std::size_t(k)] = {x.x, x.y, x.z};
    }
    std::rotate(corners.begin(), std::min_element(corners.begin(), corners.end()), corners.end());
    kept.insert(corners);
  }
  const auto strictly_inside = [&](Vec3f x) {
    for (int c = 0; c < 3; ++c)
      if (!(x[c] > box[std::size_t(c)] && x[c] < box[std::size_t(c) + 3])) return false;
    return true;
  };
  std::size_t expected = 0;
  for (const Triangle& t : full.mesh.triangles) {
    std::array<std::array<float, 3>, 3> corners;
    bool inside = true;
    for (int k = 0; k < 3; ++k) {
      const Vec3f x = full.mesh.vertices[t[std::size_t(k)]];
      inside = inside && strictly_inside(x);
      corners[std::size_t(k)] = {x.x, x.y, x.z};
    }
    if (!inside) continue;
    ++expected;
    std::rotate(corners.begin(), std::min_element(corners.begin(), corners.end()), corners.end());
    EXPECT_TRUE(kept.count(corners)) << "an uncut triangle inside the box is missing";
  }
  EXPECT_GT(expected, 80000u);

  // Open exactly along the cut: every open edge lies on one face of the box, and nothing else is.
  const std::vector<std::pair<uint32_t, uint32_t>> open = open_edges(cut.mesh);
  EXPECT_GT(open.size(), 1000u);
  for (const auto& [a, b] : open) {
    bool shared_face = false;
    for (std::size_t c = 0; c < 6; ++c)
      shared_face = shared_face || (cut.mesh.vertices[a][int(c % 3)] == float(box[c]) &&
                                    cut.mesh.vertices[b][int(c % 3)] == float(box[c]));
    EXPECT_TRUE(shared_face) << "open edge " << a << "-" << b << " off the box's faces";
  }
  const TopologyReport t = analyze_topology(cut.mesh);
  EXPECT_EQ(t.boundary_edges, open.size());
  EXPECT_EQ(t.nonmanifold_edges, 0u);
  EXPECT_EQ(t.misoriented_edges, 0u);
  EXPECT_EQ(t.unreferenced_vertices, 0u);
}

// Boxes that tile the frame's bounds: each capped piece watertight, and their volumes add up to the
// uncut surface's (the caps of neighbouring boxes are the same regions of their shared face,
// facing opposite ways). The cuts run through the water, the splash and the droplets.
void expect_capped_pieces_add_up(const char* frame, int axis_a, int axis_b) {
  const ParticleSet ps = read_particles(test::data_file(frame));
  const Result full = surface(ps, {}, false);
  ASSERT_TRUE(analyze_topology(full.mesh).watertight());
  Vec3f lo = full.mesh.vertices[0], hi = lo;
  for (const Vec3f x : full.mesh.vertices)
    for (int c = 0; c < 3; ++c) lo[c] = std::min(lo[c], x[c]), hi[c] = std::max(hi[c], x[c]);
  const double full_volume = volume(full.mesh);
  double sum = 0;
  std::size_t caps = 0;
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 3; ++j) {
      Box box;
      for (int c = 0; c < 3; ++c) box[std::size_t(c)] = lo[c] - 1.0, box[std::size_t(c) + 3] = hi[c] + 1.0;
      // axis_a in halves at 45 %, axis_b in thirds at 30 % and 62 %.
      const double split_a = lo[axis_a] + 0.45 * (hi[axis_a] - lo[axis_a]);
      const double split_b[2] = {lo[axis_b] + 0.30 * (hi[axis_b] - lo[axis_b]), lo[axis_b] + 0.62 * (hi[axis_b] - lo[axis_b])};
      if (i == 0) box[std::size_t(axis_a) + 3] = split_a; else box[std::size_t(axis_a)] = split_a;
      if (j > 0) box[std::size_t(axis_b)] = split_b[j - 1];
      if (j < 2) box[std::size_t(axis_b) + 3] = split_b[j];
      const Result piece = surface(ps, {box.begin(), box.end()}, true);
      const TopologyReport t = analyze_topology(piece.mesh);
      EXPECT_TRUE(t.watertight()) << frame << " piece " << i << "," << j << ": " << t.boundary_edges << " open, "
                                  << t.nonmanifold_edges << " non-manifold, " << t.misoriented_edges << " misoriented edges";
      EXPECT_EQ(piece.stats.cap_open_edges, 0u);
      EXPECT_EQ(t.degenerate_triangles, 0u) << frame;
      EXPECT_EQ(piece.mesh.normals.size(), piece.mesh.vertices.size());
      for (const Vec3f x : piece.mesh.vertices)
        for (int c = 0; c < 3; ++c) {
          ASSERT_GE(x[c], float(box[std::size_t(c)]));
          ASSERT_LE(x[c], float(box[std::size_t(c) + 3]));
        }
      EXPECT_GE(volume(piece.mesh), 0.0);
      sum += volume(piece.mesh);
      caps += piece.stats.cap_triangles;
    }
  EXPECT_GT(caps, 1000u) << frame;
  EXPECT_NEAR(sum, full_volume, 1e-5 * full_volume) << frame;
}

TEST(ClipBox, CappedPiecesOfTheDamBreakAreWatertightAndAddUpToTheWhole) {
  if (test::kSanitized) GTEST_SKIP() << "a large frame: the Release run has it (the bunny's pieces below run here)";
  expect_capped_pieces_add_up("ply/dam_break_frame_23_24389_particles.ply", 0, 2);
}

TEST(ClipBox, CappedPiecesOfTheBunnyAreWatertightAndAddUpToTheWhole) {
  expect_capped_pieces_add_up("ply/bunny_frame_14_7705_particles.ply", 1, 0);
}

// A box holding the whole surface changes nothing; the attributes follow the cut.
TEST(ClipBox, AttributesFollowAndAWideBoxChangesNothing) {
  const ParticleSet ps = read_particles(test::data_file("ply/double_dam_break_frame_26_4732_particles.ply"));
  Params p;
  p.backend = Backend::cpu;
  p.transfer = {"velocity"};
  const Result full = reconstruct(ps, p);
  p.clip_box = {-100, -100, -100, 100, 100, 100};
  p.clip_cap = true;
  const Result wide = reconstruct(ps, p);
  EXPECT_EQ(wide.mesh.vertices, full.mesh.vertices);
  EXPECT_EQ(wide.mesh.triangles, full.mesh.triangles);
  EXPECT_EQ(wide.stats.cap_triangles, 0u);

  Vec3f lo = full.mesh.vertices[0], hi = lo;
  for (const Vec3f x : full.mesh.vertices)
    for (int c = 0; c < 3; ++c) lo[c] = std::min(lo[c], x[c]), hi[c] = std::max(hi[c], x[c]);
  p.clip_box = {lo.x, lo.y, lo.z, 0.5 * (lo.x + hi.x), hi.y, hi.z};
  const Result half = reconstruct(ps, p);
  ASSERT_EQ(half.mesh.attributes.size(), 1u);
  const Attribute& v = half.mesh.attributes[0];
  ASSERT_EQ(v.size(), half.mesh.vertices.size());
  // A crossing vertex's velocity lies between those of its edge's ends: within the full mesh's range.
  float vmin = INFINITY, vmax = -INFINITY;
  for (float value : full.mesh.attributes[0].values) vmin = std::min(vmin, value), vmax = std::max(vmax, value);
  for (float value : v.values) {
    EXPECT_GE(value, vmin);
    EXPECT_LE(value, vmax);
  }
  EXPECT_TRUE(analyze_topology(half.mesh).watertight());
}

TEST(ClipBox, RefusesBadBoxesAndACapWithoutABox) {
  const ParticleSet ps = test::lattice_block(4, 4, 4, 0.1f);
  Params p;
  p.clip_cap = true;
  EXPECT_THROW(reconstruct(ps, p), InvalidParameter);
  p.clip_box = {0, 0, 0, 1, 1};
  EXPECT_THROW(reconstruct(ps, p), InvalidParameter);
  p.clip_box = {0, 0, 0, 1, -1, 1};
  EXPECT_THROW(reconstruct(ps, p), InvalidParameter);

  test::TempDir tmp;
  const std::string frame = test::data_file("ply/dam_break_frame_9_6859_particles.ply");
  std::string out;
  EXPECT_NE(test::run_command(test::cli() + " surface " + frame + " -o " + tmp.file("a.ply") + " --clip-cap", &out), 0);
  EXPECT_NE(out.find("--clip-cap: there is no --clip-box to cap"), std::string::npos) << out;
  EXPECT_FALSE(std::filesystem::exists(tmp.file("a.ply")));
  ASSERT_EQ(test::run_command(test::cli() + " surface " + frame + " -o " + tmp.file("b.ply") +
                                  " --clip-box 0.1,0.05,0.1,0.5,0.5,0.5 --clip-cap -q --stats " + tmp.file("b.json"),
                              &out),
            0)
      << out;
  const TriangleMesh capped = read_mesh(tmp.file("b.ply"));
  EXPECT_TRUE(analyze_topology(capped).watertight());
  std::ifstream in(tmp.file("b.json"));
  const std::string stats((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(stats.find("\"cap_triangles\""), std::string::npos);
  EXPECT_NE(stats.find("\"clip_box\""), std::string::npos);
}

}  // namespace
}  // namespace meniscus
