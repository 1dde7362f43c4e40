// --particle-box: the particles outside the box are ignored before anything else — the mesh is
// the mesh of the particles inside, bit for bit, and the stats count the others.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>

#include "meniscus/errors.hpp"
#include "meniscus/io.hpp"
#include "meniscus/reconstruct.hpp"
#include "support/test_support.hpp"

namespace meniscus {
namespace {

TEST(ParticleBox, TheMeshIsThatOfTheParticlesInsideBitForBit) {
  const ParticleSet ps = read_particles(test::data_file("ply/dam_break_frame_9_6859_particles.ply"));
  Vec3f lo = ps.positions[0], hi = lo;
  for (const Vec3f& x : ps.positions) lo = min(lo, x), hi = max(hi, x);
  // The lower half along x, and the full extent otherwise (faces included).
  const double mid = 0.5 * (double(lo.x) + double(hi.x));
  const std::vector<double> box{lo.x, lo.y, lo.z, mid, hi.y, hi.z};
  ParticleSet inside;
  std::size_t outside = 0;
  const Attribute* velocity = ps.find("velocity");
  ASSERT_NE(velocity, nullptr);
  Attribute v{"velocity", 3, false, {}};
  for (std::size_t i = 0; i < ps.size(); ++i) {
    if (double(ps.positions[i].x) > mid) {
      ++outside;
      continue;
    }
    inside.positions.push_back(ps.positions[i]);
    v.values.insert(v.values.end(), velocity->values.begin() + std::ptrdiff_t(3 * i), velocity->values.begin() + std::ptrdiff_t(3 * i + 3));
  }
  inside.attributes.push_back(v);
  ASSERT_GT(outside, 1000u);
  ASSERT_GT(inside.size(), 1000u);

  Params p;
  p.backend = Backend::cpu;
  p.transfer = {"velocity"};
  const Result expected = reconstruct(inside, p);
  p.particle_box = box;
  const Result boxed = reconstruct(ps, p);
  EXPECT_EQ(boxed.stats.particles_outside_box, outside);
  EXPECT_EQ(boxed.stats.particles, inside.size());
  EXPECT_EQ(boxed.params.spacing, expected.params.spacing) << "the spacing is estimated on the particles inside";
  ASSERT_EQ(boxed.mesh.vertices.size(), expected.mesh.vertices.size());
  EXPECT_EQ(std::memcmp(boxed.mesh.vertices.data(), expected.mesh.vertices.data(), boxed.mesh.vertices.size() * sizeof(Vec3f)), 0);
  EXPECT_TRUE(boxed.mesh.triangles == expected.mesh.triangles);
  ASSERT_EQ(boxed.mesh.attributes.size(), 1u);
  EXPECT_TRUE(boxed.mesh.attributes[0].values == expected.mesh.attributes[0].values);
  // The frame-wide estimates of a sequence are made on the same particles.
  EXPECT_EQ(resolve_frame_estimates(ps, p).spacing, expected.params.spacing);

  // Refused: every particle outside; a box of 5 numbers; min not below max.
  p.particle_box = {hi.x + 1.0, lo.y, lo.z, hi.x + 2.0, hi.y, hi.z};
  EXPECT_THROW(reconstruct(ps, p), InvalidParameter);
  p.particle_box = {0, 0, 0, 1, 1};
  EXPECT_THROW(p.validate(), InvalidParameter);
  p.particle_box = {0, 0, 0, 1, -1, 1};
  EXPECT_THROW(p.validate(), InvalidParameter);
}

// The CLI option and the --config key (an array, or a string of numbers) give the library's mesh.
TEST(ParticleBox, CliOptionAndConfigKey) {
  test::TempDir tmp;
  const std::string frame = test::data_file("ply/dam_break_frame_23_24389_particles.ply");
  Params p;
  p.backend = Backend::cpu;
  p.particle_box = {-10, -10, -10, 0.3, 10, 10};
  const Result lib = reconstruct(read_particles(frame), p);
  ASSERT_GT(lib.stats.particles_outside_box, 0u);
  const std::string counts = "\"triangles\": " + std::to_string(lib.mesh.triangles.size());
  const std::string outside = "\"particles_outside_box\": " + std::to_string(lib.stats.particles_outside_box);
  std::string out;
  ASSERT_EQ(test::run_command(test::cli() + " surface " + frame + " -o " + tmp.file("a.ply") +
                                  " --particle-box=-10,-10,-10,0.3,10,10 --backend cpu -q --stats " + tmp.file("a.json"),
                              &out),
            0)
      << out;
  int k = 0;
  for (const char* config : {R"({"particle_box": [-10, -10, -10, 0.3, 10, 10], "backend": "cpu"})",
                             R"({"particle_box": "-10,-10,-10,0.3,10,10", "backend": "cpu"})"}) {
    const std::string name = tmp.file("c" + std::to_string(k++) + ".json");
    std::ofstream(name) << config;
    ASSERT_EQ(test::run_command(test::cli() + " surface " + frame + " -o " + tmp.file("b.ply") + " --config " + name +
                                    " -q --stats " + tmp.file("b.json"),
                                &out),
              0)
        << out;
    std::ifstream in(tmp.file("b.json"));
    const std::string text((std::istreambuf_iterator<char>(in)), {});
    EXPECT_NE(text.find(counts), std::string::npos) << config;
    EXPECT_NE(text.find(outside), std::string::npos) << config;
  }
  std::ifstream in(tmp.file("a.json"));
  const std::string text((std::istreambuf_iterator<char>(in)), {});
  EXPECT_NE(text.find(counts), std::string::npos);
  EXPECT_NE(text.find("\"particle_box\""), std::string::npos) << "recorded for a replay with --config";
  // A box of 5 numbers, or one that holds no particle: refused, no mesh.
  EXPECT_NE(test::run_command(test::cli() + " surface " + frame + " -o " + tmp.file("c.ply") + " --particle-box 0,0,0,1,1", &out), 0);
  EXPECT_NE(test::run_command(test::cli() + " surface " + frame + " -o " + tmp.file("c.ply") +
                                  " --particle-box=100,100,100,101,101,101",
                              &out),
            0);
  EXPECT_NE(out.find("outside the box"), std::string::npos) << out;
  EXPECT_FALSE(std::filesystem::exists(tmp.file("c.ply")));
}

}  // namespace
}  // namespace meniscus
