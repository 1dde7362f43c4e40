// End-to-end tests of what a new user meets first: misspelt options and commands get the nearest
// name, outputs are checked before the work, the preview and render agree on pictures, an empty
// result is a warning naming the option that emptied it, inspect says when a file holds no
// triangles, the flicker says when it hit its cap, --help matches the parameter table.
#include <gtest/gtest.h>

#include <algorithm>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "support/test_support.hpp"

namespace meniscus {
namespace {

using test::TempDir;

std::string frame() { return test::data_file("ply/dam_break_frame_9_6859_particles.ply"); }

test::Measured run(const std::string& args) { return test::run_measured("exec " + test::cli() + " " + args); }

TEST(Newcomer, MisspeltOptionsAndCommandsGetTheNearestName) {
  TempDir t;
  const std::string out = " -o " + t.file("m.ply");
  const std::vector<std::tuple<std::string, std::string>> cases = {
      {"surface " + frame() + out + " --smoothnes 0.7", "unknown option '--smoothnes' for 'surface' — did you mean '--smoothness'?"},
      {"surface " + frame() + out + " --stepsa 3", "did you mean '--steps-a'?"},
      {"surface " + frame() + out + " --max-memry=2", "did you mean '--max-memory'?"},
      {"render " + frame() + " -o " + t.file("r.png") + " --colour-by v", "did you mean '--color-by'?"},
      {"surfce " + frame() + out, "unknown command 'surfce' — did you mean 'surface'?"},
      {"inpsect " + frame(), "did you mean 'inspect'?"},
      {"frobnicate", "unknown command 'frobnicate' (commands: surface, render, inspect, merge, info)"},
  };
  for (const auto& [args, says] : cases) {
    const test::Measured r = run(args);
    EXPECT_EQ(r.status, 2) << args << "\n" << r.output;
    EXPECT_NE(r.output.find(says), std::string::npos) << args << "\n" << r.output;
  }
}

TEST(Newcomer, AnOutputThatCannotBeWrittenIsRefusedBeforeTheWork) {
  TempDir t;
  std::filesystem::create_directory(t.path / "taken.ply");
  const test::Measured r = run("surface " + test::data_file("dam_break_frame_23_24389_particles.bgeo") + " -o " +
                               t.file("taken.ply"));
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("is a folder"), std::string::npos) << r.output;
  EXPECT_LT(r.seconds, 1.0) << "the frame was surfaced before the output was checked";
}

TEST(Newcomer, PreviewAndRenderBothWritePngAndSayIt) {
  TempDir t;
  for (const std::string& args : {"surface " + frame() + " -o " + t.file("m.ply") + " --preview " + t.file("p.jpg"),
                                  "render " + frame() + " -o " + t.file("r.jpg")}) {
    const test::Measured r = run(args);
    EXPECT_EQ(r.status, 2) << args << "\n" << r.output;
    EXPECT_NE(r.output.find("PNG pictures (name it .png)"), std::string::npos) << args << "\n" << r.output;
  }
  EXPECT_TRUE(std::filesystem::is_empty(t.path));
}

TEST(Newcomer, AnEmptyResultIsAWarningNamingTheOptionThatEmptiedIt) {
  TempDir t;
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"--clip-box 10,10,10,11,11,11", "warning: --clip-box 10,10,10,11,11,11 holds none of the surface: the mesh is empty"},
      {"--min-particles 1000000", "warning: --min-particles 1000000 dropped every piece of the surface"},
  };
  for (const auto& [option, says] : cases) {
    const test::Measured r = run("surface " + frame() + " -o " + t.file("m.ply") + " --stats " + t.file("s.json") + " " + option);
    EXPECT_EQ(r.status, 0) << option << "\n" << r.output;
    EXPECT_NE(r.output.find(says), std::string::npos) << option << "\n" << r.output;
    std::ifstream in(t.file("s.json"));
    const nlohmann::json stats = nlohmann::json::parse(in);
    EXPECT_EQ(stats["triangles"], 0);
    EXPECT_EQ(stats["warnings"].size(), 1u) << stats["warnings"];
  }
}

TEST(Newcomer, InspectSaysAPointCloudHasNoTriangles) {
  const test::Measured r = run("inspect " + frame());
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_NE(r.output.find("holds 6859 points and no triangles: a point cloud, not a surface"), std::string::npos)
      << r.output;
  EXPECT_EQ(r.output.find("watertight"), std::string::npos) << r.output;
}

TEST(Newcomer, AFlickerAtItsCapSaysSo) {
  // Frames that jump: the second frame's vertices are far from the first frame's surface.
  TempDir t;
  std::filesystem::copy_file(test::data_file("ply/cube_2366_particles.ply"), t.path / "f_0001.ply");
  std::filesystem::copy_file(test::data_file("ply/free_particles_1000_particles.ply"), t.path / "f_0002.ply");
  const test::Measured r = run("surface '" + t.file("f_####.ply") + "' -o '" + t.file("m_####.ply") + "' --spacing 0.05");
  EXPECT_EQ(r.status, 0) << r.output;
  EXPECT_NE(r.output.find("vertices were farther than the search's"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("cap of 4 d and count at it"), std::string::npos) << r.output;
  const test::Measured i = run("inspect '" + t.file("m_####.ply") + "' --flicker --spacing 0.05");
  EXPECT_EQ(i.status, 0) << i.output;
  EXPECT_NE(i.output.find("counted at it"), std::string::npos) << i.output;
  EXPECT_NE(i.output.find("vertices at the search's cap"), std::string::npos) << i.output;
}

TEST(Newcomer, HelpAndTheParameterTableAgree) {
  const test::Measured table = run("info --parameters");
  ASSERT_EQ(table.status, 0) << table.output;
  const nlohmann::json parameters = nlohmann::json::parse(table.output);
  const test::Measured help = run("surface --help");
  ASSERT_EQ(help.status, 0) << help.output;
  std::size_t options = 0;
  for (const nlohmann::json& p : parameters) {
    const std::string option = p["option"];
    if (option.empty()) continue;
    ++options;
    const std::size_t at = help.output.find("  " + option + " ");
    ASSERT_NE(at, std::string::npos) << option << " is not in --help";
    // The option's entry, its wrapped lines joined: up to the next option's line.
    std::size_t end = help.output.find("\n  -", at);
    end = std::min(end, help.output.find("\n\n", at));
    std::string entry;
    for (const char c : help.output.substr(at, end - at))
      if (!(c == ' ' && !entry.empty() && (entry.back() == ' ' || entry.back() == '\n'))) entry += c == '\n' ? ' ' : c;
    if (p["type"] == "flag") continue;  // a flag takes no value: nothing to accept
    EXPECT_NE(entry.find(p["accepts"].get<std::string>().substr(0, 20)), std::string::npos) << option << ": " << entry;
  }
  EXPECT_GE(options, 30u);
  // And the help points to files that exist, not to sections that moved.
  EXPECT_EQ(help.output.find("README: Field methods"), std::string::npos);
  EXPECT_NE(help.output.find("docs/fields.md"), std::string::npos);
}

}  // namespace
}  // namespace meniscus
