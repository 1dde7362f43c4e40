// End-to-end tests of the artist-facing CLI: `surface --config/--preset/--smoothness/--detail`
// and `meniscus render` (size, turntable, particle overlay, --color-by, sequences, refusals).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <set>
#include <thread>

#include <nlohmann/json.hpp>

#include "meniscus/io.hpp"
#include "meniscus/render.hpp"
#include "support/png_decode.hpp"
#include "support/test_support.hpp"


namespace meniscus {
namespace {

using test::cli;
using test::run_command;
using test::TempDir;

std::string frame9() { return test::data_file("ply/dam_break_frame_9_6859_particles.ply"); }

using test::read_png;

std::array<int, 3> pixel(const Image& image, int x, int y) {
  const std::size_t i = (std::size_t(y) * std::size_t(image.width) + std::size_t(x)) * 3;
  return {image.rgb[i], image.rgb[i + 1], image.rgb[i + 2]};
}

/// Hue buckets (of 12) among the saturated pixels.
std::size_t hue_buckets(const Image& image) {
  std::set<int> buckets;
  for (std::size_t i = 0; i + 2 < image.rgb.size(); i += 3) {
    const int r = image.rgb[i], g = image.rgb[i + 1], b = image.rgb[i + 2];
    const int hi = std::max({r, g, b}), lo = std::min({r, g, b});
    if (hi - lo < 40) continue;  // grey: background, highlights
    double h = hi == r ? double(g - b) / (hi - lo) : hi == g ? 2.0 + double(b - r) / (hi - lo) : 4.0 + double(r - g) / (hi - lo);
    if (h < 0) h += 6;
    buckets.insert(int(h * 2) % 12);
  }
  return buckets.size();
}

std::size_t files_in(const std::filesystem::path& dir) {
  return std::size_t(std::distance(std::filesystem::directory_iterator(dir), std::filesystem::directory_iterator{}));
}

nlohmann::json parameters(const std::string& stats) {
  std::ifstream in(stats);
  return nlohmann::json::parse(in)["parameters"];
}

/// One preview-quality mesh with a vector (velocity) and a scalar (density) attribute for all tests.
class CliRender : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new TempDir;
    std::string out;
    ASSERT_EQ(run_command(cli() + " surface " + frame9() + " -o " + mesh() + " --preset preview --transfer velocity,density -q",
                          &out),
              0)
        << out;
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  static std::string mesh() { return dir_->file("mesh.ply"); }
  static TempDir* dir_;
};
TempDir* CliRender::dir_ = nullptr;

TEST_F(CliRender, PictureHasTheRequestedSizeAndATurntableIsNViewsWide) {
  TempDir tmp;
  std::string out;
  ASSERT_EQ(run_command(cli() + " render " + mesh() + " -o " + tmp.file("a/view.png") + " --size 160x120 --up y", &out), 0)
      << out;
  const Image view = read_png(tmp.file("a/view.png"));
  EXPECT_EQ(view.width, 160);
  EXPECT_EQ(view.height, 120);
  ASSERT_EQ(run_command(cli() + " render " + mesh() + " -o " + tmp.file("turn.png") + " --size 160x120 --up y --turntable 4 -q",
                        &out),
            0)
      << out;
  const Image strip = read_png(tmp.file("turn.png"));
  EXPECT_EQ(strip.width, 4 * 160);
  EXPECT_EQ(strip.height, 120);
  // The first view is the single picture; the others look from elsewhere.
  for (int y = 0; y < 120; ++y)
    for (int x = 0; x < 160; ++x) ASSERT_EQ(pixel(strip, x, y), pixel(view, x, y)) << x << ", " << y;
  int differing = 0;
  for (int y = 0; y < 120; ++y)
    for (int x = 0; x < 160; ++x) differing += pixel(strip, 2 * 160 + x, y) != pixel(view, x, y);
  EXPECT_GT(differing, 1000);
}

TEST_F(CliRender, ColorByGivesVariedHuesOverTheRangePrinted) {
  TempDir tmp;
  std::string out;
  ASSERT_EQ(run_command(cli() + " render " + mesh() + " -o " + tmp.file("plain.png") + " --size 240x180 --up y", &out), 0) << out;
  ASSERT_EQ(run_command(cli() + " render " + mesh() + " -o " + tmp.file("speed.png") + " --size 240x180 --up y --color-by velocity",
                        &out),
            0)
      << out;
  EXPECT_NE(out.find("'velocity' (magnitude)"), std::string::npos) << out;
  const std::size_t plain = hue_buckets(read_png(tmp.file("plain.png")));
  const std::size_t speed = hue_buckets(read_png(tmp.file("speed.png")));
  EXPECT_GE(speed, 4u) << "plain " << plain;
  EXPECT_GT(speed, plain);

  // A range far above every value maps the whole surface to the low end: fewer hues.
  ASSERT_EQ(run_command(cli() + " render " + mesh() + " -o " + tmp.file("low.png") +
                            " --size 240x180 --up y --color-by density --range 1e9,2e9",
                        &out),
            0)
      << out;
  EXPECT_LT(hue_buckets(read_png(tmp.file("low.png"))), speed);
}

TEST_F(CliRender, ParticlesInFrontOfTheSurfaceAreDrawn) {
  TempDir tmp;
  const TriangleMesh m = read_mesh(mesh());
  RenderOptions options;
  options.width = 200;
  options.height = 150;
  options.up = {0, 1, 0};
  const Camera camera = frame_camera(m, options);
  // One particle halfway between the camera and the mesh's centre: in front of everything.
  const Vec3f p = camera.target + (camera.eye - camera.target) * 0.5f;
  {
    std::ofstream f(tmp.file("front.ply"));
    f << "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n"
      << p.x << " " << p.y << " " << p.z << "\n";
  }
  std::string out;
  const std::string base = cli() + " render " + mesh() + " --size 200x150 --up y -q";
  ASSERT_EQ(run_command(base + " -o " + tmp.file("without.png"), &out), 0) << out;
  ASSERT_EQ(run_command(base + " -o " + tmp.file("with.png") + " --particles " + tmp.file("front.ply"), &out), 0) << out;
  const Image without = read_png(tmp.file("without.png")), with = read_png(tmp.file("with.png"));
  const Vec3f at = project(camera, p);
  const auto dot = pixel(with, int(at.x), int(at.y));
  EXPECT_NE(dot, pixel(without, int(at.x), int(at.y)));
  EXPECT_GT(dot[0], dot[2] + 40);  // the orange dot over blue water
  // Only around the dot.
  int changed = 0;
  for (int y = 0; y < 150; ++y)
    for (int x = 0; x < 200; ++x) changed += pixel(with, x, y) != pixel(without, x, y);
  EXPECT_GT(changed, 0);
  EXPECT_LT(changed, 200);

  // The particles themselves are inside the surface: most are hidden.
  ASSERT_EQ(run_command(base + " -o " + tmp.file("own.png") + " --particles " + frame9(), &out), 0) << out;
  int visible = 0;
  const Image own = read_png(tmp.file("own.png"));
  for (int y = 0; y < 150; ++y)
    for (int x = 0; x < 200; ++x) visible += pixel(own, x, y) != pixel(without, x, y);
  EXPECT_LT(visible, 200 * 150 / 2);
}

TEST_F(CliRender, ASequenceIsAStripOfOneTilePerFrame) {
  TempDir tmp;
  for (const char* name : {"m_0001.ply", "m_0002.ply", "m_0003.ply"}) std::filesystem::copy_file(mesh(), tmp.file(name));
  std::string out;
  ASSERT_EQ(run_command(cli() + " render " + tmp.file("m_####.ply") + " -o " + tmp.file("all.png") + " --size 100x80 --up y",
                        &out),
            0)
      << out;
  EXPECT_EQ(read_png(tmp.file("all.png")).width, 300);
  ASSERT_EQ(run_command(cli() + " render " + tmp.file("m_####.ply") + " -o " + tmp.file("some.png") +
                            " --size 100x80 --up y --frames 1-3:2 --turntable 2",
                        &out),
            0)
      << out;
  const Image some = read_png(tmp.file("some.png"));
  EXPECT_EQ(some.width, 200);   // 2 views per row
  EXPECT_EQ(some.height, 160);  // 2 frames, one row each
}

TEST_F(CliRender, RefusesBadInputWithAClearMessageAndNoOutput) {
  struct Refusal {
    std::string args, message;
  };
  const std::vector<Refusal> cases = {
      {"MISSING.ply", "MISSING.ply"},
      {"MESH --color-by pressure", "velocity"},  // lists what the mesh has
      {"MESH --color-by pressure", "density"},
      {"MESH --size 0x10", "--size"},
      {"MESH --size big", "--size"},
      {"MESH --size 9000x10", "--size"},
      {"MESH --turntable 0", "--turntable"},
      {"MESH --color-by density --range 2,1", "--range"},
      {"MESH --range 0,1", "--color-by"},
      {"MESH --pitch 95", "pitch"},
      {"MESH --frames 1-3", "--frames"},
      {"MESH --particles MISSING_PARTICLES.ply", "MISSING_PARTICLES"},
  };
  for (const Refusal& c : cases) {
    TempDir tmp;
    std::string args = c.args;
    if (args.starts_with("MESH")) args = mesh() + args.substr(4);
    std::string out;
    const int rc = run_command(cli() + " render " + args + " -o " + tmp.file("out/view.png"), &out);
    EXPECT_NE(rc, 0) << c.args;
    EXPECT_NE(out.find(c.message), std::string::npos) << c.args << " → " << out;
    EXPECT_EQ(files_in(tmp.path), 0u) << c.args << ": left a file behind";
  }
  TempDir tmp;
  std::string out;
  EXPECT_EQ(run_command(cli() + " render " + mesh() + " -o " + tmp.file("view.jpg"), &out), 2);
  EXPECT_NE(out.find(".png"), std::string::npos) << out;
}

TEST(CliArtist, ExplicitOptionsWinOverControlsWhichWinOverPresetAndConfig) {
  TempDir tmp;
  {
    std::ofstream f(tmp.file("config.json"));
    f << R"({"steps-a": 3, "steps_b": 4, "erode": 0.001, "detail": 2, "transfer": ["velocity"]})";
  }
  std::string out;
  ASSERT_EQ(run_command(cli() + " surface " + frame9() + " -o " + tmp.file("m.ply") + " --config " + tmp.file("config.json") +
                            " --preset preview --smoothness 0.25 --steps-free 2 --stats " + tmp.file("s.json") + " -q",
                        &out),
            0)
      << out;
  const auto p = parameters(tmp.file("s.json"));
  EXPECT_EQ(p["steps_a"], 10);   // smoothness 0.25 over the preset over the config
  EXPECT_EQ(p["steps_b"], 5);
  EXPECT_EQ(p["steps_free"], 2);  // the option given
  EXPECT_DOUBLE_EQ(p["detail"].get<double>(), 0.6);  // the preset over the config
  EXPECT_DOUBLE_EQ(p["erode"].get<double>(), 0.001);  // the config where nothing else says
  EXPECT_EQ(p["transfer"], nlohmann::json::array({"velocity"}));
  EXPECT_DOUBLE_EQ(p["voxel_size"].get<double>(), p["spacing"].get<double>() / (2 * 0.6));

  ASSERT_EQ(run_command(cli() + " surface " + frame9() + " -o " + tmp.file("m2.ply") + " --config " + tmp.file("config.json") +
                            " --detail 0.8 --steps-a 5 --stats " + tmp.file("s2.json") + " -q",
                        &out),
            0)
      << out;
  const auto q = parameters(tmp.file("s2.json"));
  EXPECT_EQ(q["steps_a"], 5);
  EXPECT_EQ(q["steps_b"], 4);
  EXPECT_DOUBLE_EQ(q["detail"].get<double>(), 0.8);
}

TEST(CliArtist, AStatsFileReplaysTheSameParametersAndMesh) {
  TempDir tmp;
  std::string out;
  ASSERT_EQ(run_command(cli() + " surface " + frame9() + " -o " + tmp.file("a.ply") + " --preset droplets --smoothness 0.3 --stats " +
                            tmp.file("a.json") + " -q",
                        &out),
            0)
      << out;
  ASSERT_EQ(run_command(cli() + " surface " + frame9() + " -o " + tmp.file("b.ply") + " --config " + tmp.file("a.json") +
                            " --stats " + tmp.file("b.json") + " -q",
                        &out),
            0)
      << out;
  auto a = parameters(tmp.file("a.json")), b = parameters(tmp.file("b.json"));
  EXPECT_TRUE(a["spacing_estimated"].get<bool>());
  EXPECT_FALSE(b["spacing_estimated"].get<bool>());  // the replay gives the spacing
  a.erase("spacing_estimated");
  b.erase("spacing_estimated");
  EXPECT_EQ(a, b);
  EXPECT_EQ(read_mesh(tmp.file("a.ply")).vertices, read_mesh(tmp.file("b.ply")).vertices);
}

TEST(CliArtist, AReplayTakesTheMachineResourcesOfTheMachineThatReplays) {
  TempDir tmp;
  std::string out;
  ASSERT_EQ(run_command(cli() + " surface " + frame9() + " -o " + tmp.file("a.ply") + " --threads 1 --backend cpu --stats " +
                            tmp.file("a.json") + " -q",
                        &out),
            0)
      << out;
  // As if recorded on another machine: far more CPUs than this one has, and a memory bound far
  // below what this frame needs.
  nlohmann::json recorded = nlohmann::json::parse(std::ifstream(tmp.file("a.json")));
  recorded["parameters"]["threads"] = 4096;
  recorded["parameters"]["max_memory_gb"] = 0.001;
  recorded["parameters"]["backend"] = "cuda";
  std::ofstream(tmp.file("other_machine.json")) << recorded.dump(2);
  ASSERT_EQ(run_command(cli() + " surface " + frame9() + " -o " + tmp.file("b.ply") + " --config " +
                            tmp.file("other_machine.json") + " --stats " + tmp.file("b.json") + " -q",
                        &out),
            0)
      << out;
  const nlohmann::json b = nlohmann::json::parse(std::ifstream(tmp.file("b.json")));
  EXPECT_NE(b["threads_from"], "--threads");
  EXPECT_LE(b["parameters"]["threads"].get<int>(), int(std::thread::hardware_concurrency()));
  EXPECT_NE(b["max_memory_from"], "--max-memory");
  EXPECT_GT(b["parameters"]["max_memory_gb"].get<double>(), 0.1);
  EXPECT_EQ(b["parameters"]["backend"], "auto");
  EXPECT_EQ(read_mesh(tmp.file("a.ply")).vertices, read_mesh(tmp.file("b.ply")).vertices);
  // Options given to the replay still win.
  ASSERT_EQ(run_command(cli() + " surface " + frame9() + " -o " + tmp.file("c.ply") + " --config " +
                            tmp.file("other_machine.json") + " --threads 1 --stats " + tmp.file("c.json") + " -q",
                        &out),
            0)
      << out;
  const nlohmann::json c = nlohmann::json::parse(std::ifstream(tmp.file("c.json")));
  EXPECT_EQ(c["threads_from"], "--threads");
  EXPECT_EQ(c["parameters"]["threads"], 1);
}

TEST(CliArtist, BadControlsExitTwoWithAClearMessageAndNoOutput) {
  TempDir tmp;
  {
    std::ofstream(tmp.file("malformed.json")) << "{\n  \"steps_a\": 3,\n  \"steps_b\": 2,\n}\n";
    std::ofstream(tmp.file("typo.json")) << R"({"smoothnes": 0.3})";
  }
  struct Refusal {
    std::string args;
    std::vector<std::string> messages;
  };
  const std::vector<Refusal> cases = {
      {"--config " + tmp.file("malformed.json"), {"malformed.json", "line 4"}},
      {"--config " + tmp.file("typo.json"), {"smoothnes", "did you mean 'smoothness'"}},
      {"--config " + tmp.file("missing.json"), {"missing.json"}},
      {"--preset final", {"final", "preview, production, droplets"}},
      {"--smoothness 1.5", {"smoothness"}},
      {"--smoothness soft", {"--smoothness"}},
      {"--detail 0", {"detail"}},
      {"--detail 20", {"detail"}},
  };
  for (const Refusal& c : cases) {
    TempDir out_dir;
    std::string out;
    EXPECT_EQ(run_command(cli() + " surface " + frame9() + " -o " + out_dir.file("m.ply") + " " + c.args, &out), 2) << c.args;
    for (const std::string& m : c.messages) EXPECT_NE(out.find(m), std::string::npos) << c.args << " → " << out;
    EXPECT_EQ(files_in(out_dir.path), 0u) << c.args;
  }
}

}  // namespace
}  // namespace meniscus
