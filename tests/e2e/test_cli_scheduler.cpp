// End-to-end tests of what makes the CLI fit a scheduler (docs/cluster.md): threads and memory
// from what the process is granted, --skip-existing, --estimates-from, and the flicker of a
// finished sequence as a post-pass.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>

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

std::string bytes_of(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

nlohmann::json json_file(const std::string& path) { return nlohmann::json::parse(std::ifstream(path)); }

TEST(CliScheduler, ThreadsComeFromSlurmAndTheAffinity) {
  TempDir tmp;
  std::string out;
  const std::string job = cli() + " surface " + test::data_file("ply/fluid_250_particles.ply") + " -o " +
                          tmp.file("m.ply") + " --stats " + tmp.file("s.json");
  ASSERT_EQ(run_command("SLURM_CPUS_PER_TASK=1 " + job, &out), 0) << out;
  auto j = json_file(tmp.file("s.json"));
  EXPECT_EQ(j["ranks"], 1) << "one process";
  EXPECT_EQ(j["threads"], 1);
  if (std::thread::hardware_concurrency() > 1) {
    EXPECT_EQ(j["threads_from"], "SLURM_CPUS_PER_TASK");
    EXPECT_NE(out.find("on 1 thread (SLURM_CPUS_PER_TASK)"), std::string::npos) << out;
  }
  if (run_command("command -v taskset >/dev/null") == 0) {  // a scheduler that binds: the affinity mask
    ASSERT_EQ(run_command("taskset -c 0 " + job, &out), 0) << out;
    j = json_file(tmp.file("s.json"));
    EXPECT_EQ(j["threads"], 1);
    EXPECT_EQ(j["threads_from"], "the CPU affinity");
  }
  ASSERT_EQ(run_command(job + " --threads 1", &out), 0) << out;
  EXPECT_EQ(json_file(tmp.file("s.json"))["threads_from"], "--threads");
  ASSERT_EQ(run_command(cli() + " info", &out), 0) << out;
  EXPECT_NE(out.find("\nmpi: "), std::string::npos) << out;
  // Started by an MPI launcher as one of several processes, a build without MPI refuses rather
  // than have every process surface the whole frame; one with MPI says it has it.
  if (out.find("\nmpi: no") != std::string::npos) {
    EXPECT_EQ(run_command("OMPI_COMM_WORLD_SIZE=4 " + job, &out), 2) << out;
    EXPECT_NE(out.find("built without MPI"), std::string::npos) << out;
  }
}

// A grant below what the frame needs is refused before the field is allocated, with a message
// that names the grant; twice what it needs runs. Nothing is written either way but the mesh.
TEST(CliScheduler, MemoryGrantedBySlurmIsHonoured) {
  TempDir tmp;
  std::string out;
  const std::string job = cli() + " surface " + sample() + " -o " + tmp.file("m.ply") + " --stats " + tmp.file("s.json");
  ASSERT_EQ(run_command(job + " -q", &out), 0) << out;
  const double peak_mb = json_file(tmp.file("s.json"))["peak_memory_bytes"].get<double>() / 1048576;
  std::filesystem::remove(tmp.file("m.ply"));
  std::filesystem::remove(tmp.file("s.json"));

  const int starved = int(peak_mb / 2);
  EXPECT_EQ(run_command("SLURM_MEM_PER_NODE=" + std::to_string(starved) + " " + job, &out), 1) << out;
  EXPECT_NE(out.find("this frame would need about"), std::string::npos) << out;
  EXPECT_NE(out.find("Slurm's grant (SLURM_MEM_PER_NODE)"), std::string::npos) << out;
  EXPECT_FALSE(std::filesystem::exists(tmp.file("m.ply")));
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(tmp.path), std::filesystem::directory_iterator{}), 0)
      << "no partial or temporary file";

  const int enough = int(peak_mb * 2 / 0.9) + 1;
  ASSERT_EQ(run_command("SLURM_MEM_PER_NODE=" + std::to_string(enough) + " " + job + " -q", &out), 0) << out;
  const auto j = json_file(tmp.file("s.json"));
  EXPECT_EQ(j["max_memory_from"], "90 % of Slurm's grant (SLURM_MEM_PER_NODE)");
  EXPECT_NEAR(j["parameters"]["max_memory_gb"].get<double>(), 0.9 * enough * 1048576 / 1e9, 1e-9);
}

// Three frames of one scene: frame 2 has a droplet far out, so estimated alone it gets another
// spacing. Surfaced alone with --estimates-from 1 it is byte-identical to the run over 1-3; a
// resubmission with --skip-existing redoes only the frame whose mesh is missing.
TEST(CliScheduler, ChunksOfASequenceMatchOneRun) {
  TempDir tmp;
  std::filesystem::create_directory(tmp.path / "sim");
  const ParticleSet first = read_particles(sample());
  std::filesystem::copy_file(sample(), tmp.file("sim/f_0001.ply"));
  std::filesystem::copy_file(test::data_file("ply/dam_break_frame_23_24389_particles.ply"), tmp.file("sim/f_0003.ply"));
  const double d = estimate_spacing(first);
  TriangleMesh points;
  points.vertices = first.positions;
  for (int k = 0; k < 8; ++k)
    points.vertices.push_back(first.positions[0] + Vec3f{float(60 * d), 0, 0} +
                              Vec3f{float(k % 2), float((k / 2) % 2), float(k / 4)} * float(0.6 * d));
  write_mesh(tmp.file("sim/f_0002.ply"), points);
  ASSERT_NE(estimate_spacing(read_particles(tmp.file("sim/f_0002.ply"))), d);

  const std::string in = " '" + tmp.file("sim/f_####.ply") + "'";
  std::string out;
  ASSERT_EQ(run_command(cli() + " surface" + in + " -o '" + tmp.file("all/m_####.ply") + "' --frames 1-3 -q", &out), 0)
      << out;
  // Frame 2 alone, estimated on frame 1 as the whole run was.
  ASSERT_EQ(run_command(cli() + " surface" + in + " -o '" + tmp.file("chunk/m_####.ply") +
                            "' --frames 2 --estimates-from 1",
                        &out),
            0)
      << out;
  EXPECT_NE(out.find("estimated on frame 1 and used for every frame"), std::string::npos) << out;
  EXPECT_EQ(bytes_of(tmp.file("chunk/m_0002.ply")), bytes_of(tmp.file("all/m_0002.ply")));
  ASSERT_EQ(run_command(cli() + " surface" + in + " -o '" + tmp.file("alone/m_####.ply") + "' --frames 2 -q", &out), 0);
  EXPECT_NE(bytes_of(tmp.file("alone/m_0002.ply")), bytes_of(tmp.file("all/m_0002.ply")))
      << "estimated on frame 2 itself, another spacing";
  // A frame that does not exist cannot be the estimates' frame.
  EXPECT_EQ(run_command(cli() + " surface" + in + " -o '" + tmp.file("x/m_####.ply") + "' --frames 2 --estimates-from 9", &out), 1);
  EXPECT_NE(out.find("--estimates-from 9"), std::string::npos) << out;
  EXPECT_FALSE(std::filesystem::exists(tmp.file("x/m_0002.ply")));

  // Resubmission: frames 1 and 3 exist and stay untouched, frame 2 is made again, identical.
  const std::string all2 = tmp.file("all/m_0002.ply"), before = bytes_of(all2);
  std::filesystem::remove(all2);
  const auto time1 = std::filesystem::last_write_time(tmp.file("all/m_0001.ply"));
  const auto time3 = std::filesystem::last_write_time(tmp.file("all/m_0003.ply"));
  ASSERT_EQ(run_command(cli() + " surface" + in + " -o '" + tmp.file("all/m_####.ply") + "' --frames 1-3 --skip-existing",
                        &out),
            0)
      << out;
  EXPECT_NE(out.find("skipping 2 frame(s) whose mesh exists (--skip-existing): 1,3"), std::string::npos) << out;
  EXPECT_NE(out.find("1 of 1 frames surfaced"), std::string::npos) << out;
  EXPECT_EQ(bytes_of(all2), before);
  EXPECT_EQ(std::filesystem::last_write_time(tmp.file("all/m_0001.ply")), time1);
  EXPECT_EQ(std::filesystem::last_write_time(tmp.file("all/m_0003.ply")), time3);
  ASSERT_EQ(run_command(cli() + " surface" + in + " -o '" + tmp.file("all/m_####.ply") + "' --frames 1-3 --skip-existing",
                        &out),
            0)
      << out;
  EXPECT_NE(out.find("nothing to do"), std::string::npos) << out;
}

// The flicker of a finished sequence, measured afterwards, is what the run measured itself.
TEST(CliScheduler, InspectMeasuresASequencesFlickerAfterwards) {
  TempDir tmp;
  std::filesystem::create_directory(tmp.path / "sim");
  std::filesystem::copy_file(sample(), tmp.file("sim/f_0001.ply"));
  std::filesystem::copy_file(test::data_file("ply/dam_break_frame_23_24389_particles.ply"), tmp.file("sim/f_0002.ply"));
  std::filesystem::copy_file(sample(), tmp.file("sim/f_0003.ply"));
  std::string out;
  ASSERT_EQ(run_command(cli() + " surface '" + tmp.file("sim/f_####.ply") + "' -o '" + tmp.file("m_####.ply") +
                            "' --stats '" + tmp.file("s_####.json") + "' -q",
                        &out),
            0)
      << out;
  ASSERT_EQ(run_command(cli() + " inspect '" + tmp.file("m_####.ply") + "' --flicker --particles '" +
                            tmp.file("sim/f_####.ply") + "' --json",
                        &out),
            0)
      << out;
  const auto j = nlohmann::json::parse(out);
  ASSERT_EQ(j["frames"].size(), 3u);
  EXPECT_FALSE(j["frames"][0].contains("flicker"));
  for (int f = 2; f <= 3; ++f) {
    const auto in_run = json_file(tmp.file("s_000" + std::to_string(f) + ".json"))["flicker"];
    const auto after = j["frames"][f - 1]["flicker"];
    EXPECT_EQ(after["previous_frame"], f - 1);
    for (const char* key : {"mean", "p95", "max", "cap"})
      EXPECT_NEAR(after[key].get<double>(), in_run[key].get<double>(), 1e-9 * (1 + in_run[key].get<double>())) << key;
    EXPECT_EQ(after["beyond_cap"], in_run["beyond_cap"]);
    EXPECT_TRUE(j["frames"][f - 1]["watertight"].get<bool>());
  }
  EXPECT_EQ(j["summary"]["flicker"]["pairs"], 2);
  EXPECT_EQ(j["summary"]["not_watertight"], 0);
  // The text form, and a refusal of --flicker on a single mesh.
  ASSERT_EQ(run_command(cli() + " inspect '" + tmp.file("m_####.ply") + "' --flicker --frames 2-3", &out), 0) << out;
  EXPECT_NE(out.find("frame 3: "), std::string::npos) << out;
  EXPECT_NE(out.find("flicker against frame 2"), std::string::npos) << out;
  EXPECT_EQ(run_command(cli() + " inspect " + tmp.file("m_0001.ply") + " --flicker", &out), 2) << out;
}

}  // namespace
}  // namespace meniscus
