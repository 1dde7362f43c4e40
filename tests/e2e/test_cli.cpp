// End-to-end tests of the meniscus command line: the surface job, its stats, and refusals.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <fmt/format.h>
#include <iterator>
#include <nlohmann/json.hpp>
#include <sstream>
#include <tuple>

#include "meniscus/io.hpp"
#include "meniscus/quality.hpp"
#include "meniscus/reconstruct.hpp"
#include "support/test_support.hpp"

namespace meniscus {
namespace {

using test::cli;
using test::run_command;
using test::TempDir;

std::string sample() { return test::data_file("ply/dam_break_frame_9_6859_particles.ply"); }

std::size_t files_in(const std::filesystem::path& dir) {
  return std::size_t(std::distance(std::filesystem::directory_iterator(dir), std::filesystem::directory_iterator{}));
}

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

TEST(Cli, ThePreviewsUpAxisIsWhatTheFileShowsAndTheSummarySaysSo) {
  TempDir tmp;
  struct Case {
    std::string input, extra;
    char axis;
    std::string why;
  };
  const std::vector<Case> cases = {
      // SPlisHSPlasH, y-up: a PLY says nothing, its velocities and heights do.
      {sample(), "", 'y', "move down y"},
      // The same frame as Houdini geometry: Houdini's convention.
      {test::data_file("dam_break_frame_9_6859_particles.bgeo"), "", 'y', "Houdini"},
      // SPHysics, z-up, at rest: the water settles low along z.
      {test::data_file("sphysics_dam_break_IPART_29814_particles.txt.gz"), " --columns x,y,z,vx,vy,vz,rho,p,mass", 'z',
       "settle low along z"},
  };
  for (const Case& c : cases) {
    std::string out;
    const std::string base = cli() + " surface " + c.input + c.extra + " --preset preview -o " + tmp.file("m.ply");
    ASSERT_EQ(run_command(base + " --preview " + tmp.file("auto.png"), &out), 0) << out;
    EXPECT_NE(out.find(fmt::format("the preview's up axis: {} (", c.axis)), std::string::npos) << c.input << out;
    EXPECT_NE(out.find(c.why), std::string::npos) << c.input << out;
    std::string given;
    ASSERT_EQ(run_command(base + " --preview " + tmp.file("given.png") + " --up " + c.axis, &given), 0) << given;
    EXPECT_NE(given.find(fmt::format("the preview's up axis: {} (--up)", c.axis)), std::string::npos) << given;
    EXPECT_EQ(slurp(tmp.file("auto.png")), slurp(tmp.file("given.png"))) << c.input;
    const char other = c.axis == 'z' ? 'y' : 'z';
    ASSERT_EQ(run_command(base + " --preview " + tmp.file("other.png") + " --up " + other, &given), 0) << given;
    EXPECT_NE(slurp(tmp.file("auto.png")), slurp(tmp.file("other.png"))) << c.input;
  }
  // A sequence's previews share the axis its first frame shows, said once.
  std::string out;
  ASSERT_EQ(run_command(cli() + " surface '" + test::data_file("sequence/fluid_####.bgeo.sc") + "' --frames 1-2 -o '" +
                            tmp.file("s_####.ply") + "' --preview '" + tmp.file("s_####.png") + "' --preset preview",
                        &out),
            0)
      << out;
  EXPECT_NE(out.find("the previews' up axis: y (the file is Houdini geometry"), std::string::npos) << out;
}

/// Display width of a UTF-8 line.
std::size_t columns(const std::string& line) {
  return std::size_t(std::count_if(line.begin(), line.end(), [](char c) { return (static_cast<unsigned char>(c) & 0xC0) != 0x80; }));
}

TEST(Cli, HelpIsGroupedWrappedTypedAndEndsWithExamples) {
  for (const char* command : {"surface", "render", "inspect", "merge", "info"}) {
    std::string out;
    ASSERT_EQ(run_command(cli() + " " + command + " --help", &out), 0) << out;
    std::istringstream lines(out);
    for (std::string line; std::getline(lines, line);) EXPECT_LE(columns(line), 100u) << command << ": " << line;
  }
  std::string help;
  ASSERT_EQ(run_command(cli() + " surface --help", &help), 0) << help;
  // The options an artist reaches for first come first, in their own group.
  const std::size_t common = help.find("Common options:"), next_group = help.find(":\n", common + 16);
  ASSERT_NE(common, std::string::npos) << help;
  for (const char* option : {"-o,--output", "--preset", "--smoothness", "--detail", "--transfer", "--preview", "--stats"}) {
    const std::size_t at = help.find(std::string("  ") + option);
    EXPECT_GT(at, common) << option;
    EXPECT_LT(at, next_group) << option << " is not among the common options";
  }
  EXPECT_LT(common, help.find("Geometry:"));
  // Every value is shown by its type, never CLI11's TEXT for a number.
  EXPECT_EQ(help.find("TEXT"), std::string::npos) << help;
  for (const char* typed : {"--smoothness NUMBER", "--steps-a INT", "--preset NAME", "--transfer NAME,…",
                            "--clip-box X0,Y0,Z0,X1,Y1,Z1", "--jobs INT=1", "--up auto|x|y|z=auto"})
    EXPECT_NE(help.find(typed), std::string::npos) << typed;
  // Two examples at the end.
  const std::size_t examples = help.rfind("Examples:");
  ASSERT_NE(examples, std::string::npos) << help;
  EXPECT_GT(examples, help.find("--max-memory"));
  std::size_t shown = 0;
  for (std::size_t at = help.find("  meniscus surface ", examples); at != std::string::npos;
       at = help.find("  meniscus surface ", at + 1))
    ++shown;
  EXPECT_EQ(shown, 2u) << help.substr(examples);
}

TEST(Cli, SurfacesARealFrameWithStatsAndPreview) {
  TempDir tmp;
  const std::string mesh = tmp.file("out/mesh.ply"), stats = tmp.file("stats.json"), png = tmp.file("view.png");
  std::string out;
  const int rc = run_command(cli() + " surface " + sample() + " -o " + mesh + " --stats " + stats + " --preview " +
                                 png + " --transfer velocity",
                             &out);
  ASSERT_EQ(rc, 0) << out;
  EXPECT_NE(out.find("estimated particle spacing"), std::string::npos) << out;
  EXPECT_NE(out.find("6859 particles"), std::string::npos) << out;

  const TriangleMesh m = read_mesh(mesh);
  EXPECT_TRUE(analyze_topology(m).watertight());
  ASSERT_EQ(m.normals.size(), m.vertices.size());
  ASSERT_NE(m.find("velocity"), nullptr);

  std::ifstream in(stats);
  const auto j = nlohmann::json::parse(in);
  EXPECT_EQ(j["particles"], 6859);
  EXPECT_EQ(j["vertices"], m.vertices.size());
  EXPECT_EQ(j["triangles"], m.triangles.size());
  for (const char* stage : {"read", "grid", "field", "extract", "smooth", "transfer", "normals", "write", "preview"})
    EXPECT_TRUE(j["stages"].contains(stage)) << stage;
  EXPECT_GT(j["peak_memory_bytes"].get<double>(), 1e6);
  const auto& p = j["parameters"];
  for (const char* key : {"spacing", "voxel_size", "r_inner", "r_outer", "steps_a", "steps_b", "steps_free", "relax",
                          "extract", "erode", "transfer", "transfer_radius", "threads"})
    EXPECT_TRUE(p.contains(key)) << key;
  EXPECT_TRUE(p["spacing_estimated"].get<bool>());
  EXPECT_DOUBLE_EQ(p["voxel_size"].get<double>(), p["spacing"].get<double>() / 2);

  std::ifstream png_in(png, std::ios::binary);
  char sig[8] = {};
  png_in.read(sig, 8);
  EXPECT_EQ(std::string(sig + 1, 3), "PNG");
}

TEST(Cli, ParametersGivenAreUsed) {
  TempDir tmp;
  std::string out;
  ASSERT_EQ(run_command(cli() + " surface " + sample() + " -o " + tmp.file("m.ply") + " --spacing 0.05 --voxel-size 0.02"
                            " --r-outer 0.06 --r-inner 0.03 --steps-a 3 --steps-b 4 --steps-free 1 --relax 0.4"
                            " --extract cubes --threads 1 --quiet --stats " + tmp.file("s.json"),
                        &out),
            0)
      << out;
  EXPECT_EQ(out, "");  // --quiet
  std::ifstream in(tmp.file("s.json"));
  const auto p = nlohmann::json::parse(in)["parameters"];
  EXPECT_DOUBLE_EQ(p["spacing"].get<double>(), 0.05);
  EXPECT_DOUBLE_EQ(p["voxel_size"].get<double>(), 0.02);
  EXPECT_DOUBLE_EQ(p["r_outer"].get<double>(), 0.06);
  EXPECT_DOUBLE_EQ(p["r_inner"].get<double>(), 0.03);
  EXPECT_EQ(p["steps_a"], 3);
  EXPECT_EQ(p["steps_b"], 4);
  EXPECT_EQ(p["steps_free"], 1);
  EXPECT_EQ(p["extract"], "cubes");
  EXPECT_EQ(p["threads"], 1);
}

struct Refusal {
  std::string args, message;
};

TEST(Cli, RefusesInvalidOptionsWithAClearMessageAndNoOutput) {
  const std::vector<Refusal> cases = {
      {"--r-outer -1", "--r-outer"},
      {"--r-inner 0.1 --r-outer 0.05", "--r-inner 0.1: must be smaller than --r-outer"},
      {"--relax 2", "relax"},
      {"--relax 1.5 --solver jacobi", "Jacobi"},
      {"--extract spheres", "--extract"},
      {"--voxel-size -0.1", "--voxel-size -0.1: must be a finite number ≥ 0"},
      {"--steps-a 2147483648", "--steps-a 2147483648: must be a whole number from 0 to 10000"},
      {"--threads 2000000000", "--threads 2000000000: must be a whole number from 0 to"},
      {"--spacing 1e400", "--spacing 1e400: must be a finite number"},
      {"--spacing -1", "--spacing -1: must be a finite number ≥ 0 (0: estimated from the particles)"},
      {"--bogus-option 3", "bogus-option"},
      {"--steps-a many", "--steps-a"},
      {"--transfer nothing_like_this", "nothing_like_this"},
      {"--spacing 0.05 --voxel-size 0.00001", "voxel size"},
  };
  for (const Refusal& c : cases) {
    TempDir tmp;
    std::string out;
    const int rc = run_command(cli() + " surface " + sample() + " -o " + tmp.file("m.ply") + " " + c.args, &out);
    EXPECT_NE(rc, 0) << c.args;
    EXPECT_NE(out.find(c.message), std::string::npos) << c.args << " → " << out;
    EXPECT_EQ(files_in(tmp.path), 0u) << c.args << ": left a file behind";
  }
}

TEST(Cli, MissingOrBrokenInputFailsCleanly) {
  TempDir tmp;
  std::string out;
  EXPECT_NE(run_command(cli() + " surface " + tmp.file("nope.ply") + " -o " + tmp.file("m.ply"), &out), 0);
  EXPECT_NE(out.find("nope.ply"), std::string::npos) << out;
  {
    std::ofstream f(tmp.file("bad.ply"));
    f << "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n"
         "0 0 0\n1 1\n";
  }
  EXPECT_NE(run_command(cli() + " surface " + tmp.file("bad.ply") + " -o " + tmp.file("m.ply"), &out), 0);
  EXPECT_NE(out.find("bad.ply"), std::string::npos) << out;
  EXPECT_NE(out.find("line"), std::string::npos) << out;
  EXPECT_FALSE(std::filesystem::exists(tmp.file("m.ply")));
}

TEST(Cli, ProgressBarOnlyOnATerminal) {
  if (run_command("command -v script >/dev/null") != 0) GTEST_SKIP() << "skipped: util-linux 'script' not installed";
  TempDir tmp;
  const std::string job = cli() + " surface " + sample() + " -o " + tmp.file("m.ply");
  std::string out;
  // `script` runs the job on a pseudo-terminal.
  ASSERT_EQ(run_command("script -qec '" + job + "' /dev/null", &out), 0) << out;
  EXPECT_NE(out.find("smooth"), std::string::npos) << out;
  EXPECT_NE(out.find("%"), std::string::npos) << out;
  EXPECT_NE(out.find('\r'), std::string::npos) << "no progress redraws on a terminal";
  ASSERT_EQ(run_command("script -qec '" + job + " --quiet' /dev/null", &out), 0) << out;
  EXPECT_EQ(out.find('%'), std::string::npos) << out;
  // Piped: the summary, but no progress bar.
  ASSERT_EQ(run_command(job, &out), 0) << out;
  EXPECT_EQ(out.find('\r'), std::string::npos) << out;
  EXPECT_NE(out.find("triangles"), std::string::npos) << out;
  EXPECT_NE(out.find("smooth "), std::string::npos) << out;
  EXPECT_NE(out.find("(set-up "), std::string::npos) << "the smoothing's split: " << out;
}

TEST(Cli, TheSummarySpeaksPlainlyWithUnitsAndASequenceShowsTheTimeLeft) {
  TempDir tmp;
  std::string out;
  // One frame: the spacing estimate is told before the work (and its bars), the stages in
  // seconds, the smoothing's sweeps by name.
  const std::string job = cli() + " surface " + sample() + " -o " + tmp.file("m.ply");
  ASSERT_EQ(run_command("script -qec '" + job + "' /dev/null", &out), 0) << out;
  const std::size_t estimate = out.find("estimated particle spacing"), first_bar = out.find('%');
  ASSERT_NE(estimate, std::string::npos) << out;
  ASSERT_NE(first_bar, std::string::npos) << out;
  EXPECT_LT(estimate, first_bar) << "the estimate is told after the progress bars";
  EXPECT_NE(out.find("Laplacian sweeps"), std::string::npos) << out;
  EXPECT_NE(out.find("bilaplacian sweeps"), std::string::npos) << out;
  EXPECT_EQ(out.find(" A 0."), std::string::npos) << out;
  EXPECT_NE(out.find("time per stage: read 0."), std::string::npos) << out;
  EXPECT_NE(out.find(" threads (") == std::string::npos ? out.find(" thread (") : out.find(" threads ("), std::string::npos)
      << out;
  // The surface's pieces and genus, as inspect counts them on the written mesh.
  std::string inspected;
  ASSERT_EQ(run_command(cli() + " inspect " + tmp.file("m.ply") + " --json", &inspected), 0) << inspected;
  const nlohmann::json topology = nlohmann::json::parse(inspected.substr(inspected.find('{')))["topology"];
  EXPECT_NE(out.find(fmt::format("{} piece{}, genus {} (holes and tunnels", topology["components"].get<std::size_t>(),
                                 topology["components"].get<std::size_t>() == 1 ? "" : "s",
                                 topology["genus"].get<long long>())),
            std::string::npos)
      << out;
  // A sequence: the time left on its bar, and the change between frames in spacings.
  const std::string sequence = cli() + " surface \"" + test::data_file("sequence/fluid_####.bgeo.sc") +
                               "\" --frames 1-6 -o \"" + tmp.file("s_####.ply") + "\"";
  ASSERT_EQ(run_command("script -qec '" + sequence + "' /dev/null", &out), 0) << out;
  EXPECT_NE(out.find(" left"), std::string::npos) << "no time left on a sequence's bar: " << out;
  const std::size_t change = out.find("change between frames");
  ASSERT_NE(change, std::string::npos) << out;
  EXPECT_NE(out.find(" d (", change), std::string::npos) << out;
  EXPECT_NE(out.find("scene units", change), std::string::npos) << out;
  EXPECT_NE(out.find("motion included", change), std::string::npos) << out;
}

TEST(Cli, SequencesReportFailedFramesAndGoOn) {
  TempDir tmp;
  const std::string small = test::data_file("ply/fluid_250_particles.ply");
  std::filesystem::create_directory(tmp.path / "sim");
  for (int f : {1, 2, 4}) std::filesystem::copy_file(small, tmp.file("sim/fluid_000" + std::to_string(f) + ".ply"));
  {
    std::ofstream broken(tmp.file("sim/fluid_0003.ply"));
    broken << "ply\nformat binary_little_endian 1.0\nelement vertex 1000\nproperty float x\nproperty float y\n"
              "property float z\nend_header\n1234";
  }
  const std::string base = cli() + " surface '" + tmp.file("sim/fluid_####.ply") + "' -o '" + tmp.file("mesh/m_{}.ply") +
                           "' --steps-a 2 --steps-b 2 --steps-free 0";
  std::string out;
  EXPECT_EQ(run_command(base + " --frames 1-4", &out), 1) << out;
  for (int f : {1, 2, 4}) EXPECT_TRUE(std::filesystem::exists(tmp.file("mesh/m_" + std::to_string(f) + ".ply"))) << f;
  EXPECT_FALSE(std::filesystem::exists(tmp.file("mesh/m_3.ply")));
  EXPECT_NE(out.find("frame 3: error"), std::string::npos) << out;
  EXPECT_NE(out.find("fluid_0003.ply"), std::string::npos) << out;
  EXPECT_NE(out.find("3 of 4 frames"), std::string::npos) << out;

  // --fail-fast stops at frame 3: frame 4 is not written.
  std::filesystem::remove_all(tmp.path / "mesh");
  EXPECT_EQ(run_command(base + " --frames 1-4 --fail-fast", &out), 1) << out;
  EXPECT_TRUE(std::filesystem::exists(tmp.file("mesh/m_2.ply")));
  EXPECT_FALSE(std::filesystem::exists(tmp.file("mesh/m_4.ply")));

  // Frames found on disk, two at a time, printf-style pattern.
  std::filesystem::remove(tmp.file("sim/fluid_0003.ply"));
  std::filesystem::remove_all(tmp.path / "mesh");
  EXPECT_EQ(run_command(cli() + " surface '" + tmp.file("sim/fluid_%04d.ply") + "' -o '" + tmp.file("mesh/m_####.ply") +
                            "' --jobs 2 --steps-a 2 --steps-b 2",
                        &out),
            0)
      << out;
  for (int f : {1, 2, 4}) EXPECT_TRUE(std::filesystem::exists(tmp.file("mesh/m_000" + std::to_string(f) + ".ply"))) << f;
  // The same frame gives the same mesh whichever job ran it.
  EXPECT_EQ(read_mesh(tmp.file("mesh/m_0001.ply")).triangles, read_mesh(tmp.file("mesh/m_0004.ply")).triangles);

  // An output without a placeholder is refused before any work.
  EXPECT_EQ(run_command(cli() + " surface '" + tmp.file("sim/fluid_####.ply") + "' -o " + tmp.file("single.ply"), &out), 2);
  EXPECT_NE(out.find("frame placeholder"), std::string::npos) << out;
}

TEST(Cli, InspectReportsTheQualityOfAnyMesh) {
  TempDir tmp;
  std::string out;
  ASSERT_EQ(run_command(cli() + " surface " + sample() + " -o " + tmp.file("tiles.ply") + " --steps-free 0 -q", &out), 0)
      << out;
  ASSERT_EQ(run_command(cli() + " surface " + sample() + " -o " + tmp.file("cubes.obj") +
                            " --extract cubes --steps-a 0 --steps-b 0 --steps-free 0 -q",
                        &out),
            0)
      << out;
  ASSERT_EQ(run_command(cli() + " inspect " + tmp.file("tiles.ply") + " --particles " + sample() + " --json 2>/dev/null", &out), 0)
      << out;
  const auto tiles = nlohmann::json::parse(out);
  EXPECT_TRUE(tiles["topology"]["watertight"].get<bool>());
  EXPECT_GE(tiles["valence"]["min"].get<int>(), 5);
  EXPECT_LT(tiles["particles"]["constraint_residual"].get<double>(), 1e-5 * tiles["particles"]["r_outer"].get<double>());
  EXPECT_EQ(tiles["particles"]["outside_surface"].get<int>(), 0);
  ASSERT_EQ(run_command(cli() + " inspect " + tmp.file("cubes.obj") + " --json 2>/dev/null", &out), 0) << out;
  const auto cubes = nlohmann::json::parse(out);
  EXPECT_TRUE(cubes["topology"]["watertight"].get<bool>());
  EXPECT_GT(cubes["valence"]["share_below_5"].get<double>(), 0.02);
  EXPECT_LT(cubes["angles"]["min_degrees"].get<double>(), tiles["angles"]["min_degrees"].get<double>());
  // Human-readable form.
  ASSERT_EQ(run_command(cli() + " inspect " + tmp.file("tiles.ply"), &out), 0) << out;
  EXPECT_NE(out.find("watertight"), std::string::npos) << out;
  EXPECT_NE(run_command(cli() + " inspect " + tmp.file("missing.ply"), &out), 0);
  EXPECT_NE(out.find("missing.ply"), std::string::npos) << out;
}

// Frames that jump — another scene, one particle after a full frame, a frame moved far away — as
// one sequence: the flicker against each previous frame is measured in bounded work (an unbounded
// search would take minutes on the first pair), counted at its cap where the frames are apart.
TEST(Cli, SequenceOfDissimilarFramesMeasuresFlickerInBoundedTime) {
  TempDir tmp;
  std::filesystem::create_directory(tmp.path / "sim");
  std::filesystem::copy_file(test::data_file("ply/dam_break_frame_23_24389_particles.ply"), tmp.file("sim/f_0001.ply"));
  std::filesystem::copy_file(test::data_file("ply/double_dam_break_frame_26_4732_particles.ply"), tmp.file("sim/f_0002.ply"));
  TriangleMesh points;  // a PLY of vertices only reads back as particles
  points.vertices = {{0.5f, 0.3f, 0.2f}};
  write_mesh(tmp.file("sim/f_0003.ply"), points);
  points.vertices = read_particles(tmp.file("sim/f_0001.ply")).positions;
  for (Vec3f& p : points.vertices) p += Vec3f{100, 0, 0};
  write_mesh(tmp.file("sim/f_0004.ply"), points);

  std::string out;
  const auto t0 = std::chrono::steady_clock::now();
  ASSERT_EQ(run_command(cli() + " surface '" + tmp.file("sim/f_####.ply") + "' -o '" + tmp.file("m_####.ply") +
                            "' --stats '" + tmp.file("s_####.json") + "' --spacing 0.05",
                        &out),
            0)
      << out;
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_LT(seconds, 60) << "a sequence of four small frames";
  EXPECT_NE(out.find("4 of 4 frames"), std::string::npos) << out;
  EXPECT_NE(out.find("change between frames"), std::string::npos) << out;
  for (int f = 2; f <= 4; ++f) {
    const auto j = nlohmann::json::parse(std::ifstream(tmp.file("s_000" + std::to_string(f) + ".json")));
    ASSERT_TRUE(j.contains("flicker")) << f;
    const auto& fl = j["flicker"];
    const double vertices = j["vertices"].get<double>();
    EXPECT_EQ(fl["previous_frame"].get<int>(), f - 1);
    EXPECT_NEAR(fl["cap"].get<double>(), kFlickerCapSpacings * 0.05, 1e-9);
    // The work: a few dozen point–triangle tests per vertex at most, whatever the two frames are.
    EXPECT_LT(fl["triangle_tests"].get<double>(), 32 * vertices) << f;
    // The time: never more than surfacing the frame itself, plus a quarter second for tiny frames
    // on a loaded machine (the bound that holds on any machine is the work's, above).
    EXPECT_LT(fl["seconds"].get<double>(), j["total_seconds"].get<double>() + 0.25) << f;
    EXPECT_LE(fl["max"].get<double>(), fl["cap"].get<double>());
  }
  const auto far = nlohmann::json::parse(std::ifstream(tmp.file("s_0004.json")));
  EXPECT_EQ(far["flicker"]["beyond_cap"].get<double>(), far["vertices"].get<double>()) << "frame 4 is 100 units away";
  EXPECT_EQ(far["flicker"]["triangle_tests"].get<double>(), 0);
}

// Without --spacing a sequence estimates the spacing on its first frame and uses it for every
// frame: a droplet appearing 60 d away in frame 2 then changes no vertex of the fluid (estimated
// per frame, it would move them all).
TEST(Cli, SequenceEstimatesTheSpacingOnItsFirstFrameOnly) {
  TempDir tmp;
  std::filesystem::create_directory(tmp.path / "sim");
  std::filesystem::copy_file(sample(), tmp.file("sim/f_0001.ply"));
  const ParticleSet first = read_particles(sample());
  const double d = estimate_spacing(first);
  Vec3f hi = first.positions[0];
  for (const Vec3f& p : first.positions) hi = max(hi, p);
  TriangleMesh points;  // a PLY of vertices only reads back as particles
  points.vertices = first.positions;
  for (int k = 0; k < 8; ++k)  // a droplet of 8 particles 0.6 d apart, 60 d beyond the fluid
    points.vertices.push_back(hi + Vec3f{float(60 * d), 0, 0} + Vec3f{float(k % 2), float((k / 2) % 2), float(k / 4)} * float(0.6 * d));
  write_mesh(tmp.file("sim/f_0002.ply"), points);
  ASSERT_NE(estimate_spacing(read_particles(tmp.file("sim/f_0002.ply"))), d) << "frame 2 alone estimates another spacing";

  std::string out;
  ASSERT_EQ(run_command(cli() + " surface '" + tmp.file("sim/f_####.ply") + "' -o '" + tmp.file("m_####.ply") +
                            "' --stats '" + tmp.file("s_####.json") + "'",
                        &out),
            0)
      << out;
  EXPECT_NE(out.find("estimated on frame 1 and used for every frame: spacing"), std::string::npos) << out;
  for (const char* s : {"s_0001.json", "s_0002.json"}) {
    const auto j = nlohmann::json::parse(std::ifstream(tmp.file(s)));
    EXPECT_DOUBLE_EQ(j["parameters"]["spacing"].get<double>(), d) << s;
    EXPECT_TRUE(j["parameters"]["spacing_estimated"].get<bool>()) << s;
    EXPECT_EQ(j["parameters"]["estimated_on"], tmp.file("sim/f_0001.ply")) << s;
  }
  const TriangleMesh m1 = read_mesh(tmp.file("m_0001.ply")), m2 = read_mesh(tmp.file("m_0002.ply"));
  ASSERT_GT(m2.vertices.size(), m1.vertices.size());
  std::vector<Vec3f> a = m1.vertices;
  const auto less = [](const Vec3f& u, const Vec3f& v) { return std::tie(u.x, u.y, u.z) < std::tie(v.x, v.y, v.z); };
  std::sort(a.begin(), a.end(), less);
  std::vector<Vec3f> all = m2.vertices;
  std::sort(all.begin(), all.end(), less);
  std::size_t missing = 0;
  for (const Vec3f& v : a) missing += !std::binary_search(all.begin(), all.end(), v, less);
  EXPECT_EQ(missing, 0u) << "of frame 1's " << a.size() << " vertices, these are not in frame 2";
}

TEST(Cli, InspectFlickerBetweenUnrelatedMeshesIsCapped) {
  TempDir tmp;
  std::string out;
  ASSERT_EQ(run_command(cli() + " surface " + sample() + " -o " + tmp.file("a.ply") + " -q", &out), 0) << out;
  ASSERT_EQ(run_command(cli() + " surface " + test::data_file("ply/double_dam_break_frame_26_4732_particles.ply") +
                            " -o " + tmp.file("b.ply") + " -q",
                        &out),
            0)
      << out;
  ASSERT_EQ(run_command(cli() + " inspect " + tmp.file("a.ply") + " --previous " + tmp.file("b.ply") + " --json", &out), 0)
      << out;
  const auto capped = nlohmann::json::parse(out)["flicker"];
  const double cap = kFlickerCapEdges * mean_edge_length(read_mesh(tmp.file("b.ply")));
  EXPECT_NEAR(capped["cap"].get<double>(), cap, 1e-6 * cap);
  EXPECT_GT(capped["beyond_cap"].get<double>(), 0);
  ASSERT_EQ(run_command(cli() + " inspect " + tmp.file("a.ply") + " --previous " + tmp.file("b.ply") +
                            " --flicker-cap 0 --json",
                        &out),
            0)
      << out;
  const auto exact = nlohmann::json::parse(out)["flicker"];
  EXPECT_TRUE(exact["cap"].is_null());
  EXPECT_EQ(exact["beyond_cap"].get<int>(), 0);
  EXPECT_GT(exact["max"].get<double>(), cap);
  EXPECT_GT(exact["triangle_tests"].get<double>(), capped["triangle_tests"].get<double>());
  // The human-readable form says how many vertices lie beyond the cap.
  ASSERT_EQ(run_command(cli() + " inspect " + tmp.file("a.ply") + " --previous " + tmp.file("b.ply"), &out), 0) << out;
  EXPECT_NE(out.find("farther than the cap"), std::string::npos) << out;
}

TEST(Cli, InfoListsVersionBackendsAndFormats) {
  std::string out;
  ASSERT_EQ(run_command(cli() + " info", &out), 0);
  for (const char* s : {"meniscus", "cpu", "threads", ".ply", ".xyz", "tiles"})
    EXPECT_NE(out.find(s), std::string::npos) << s << " in " << out;
}

}  // namespace
}  // namespace meniscus
