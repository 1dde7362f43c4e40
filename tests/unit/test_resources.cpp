// Tests of what the process is granted: threads from the affinity and Slurm, memory from the
// machine, the cgroups (v1 and v2, with their ancestors) and Slurm.
#include <gtest/gtest.h>
#include <sched.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include "meniscus/resources.hpp"
#include "support/test_support.hpp"

namespace meniscus {
namespace {

EnvFn env_of(const std::map<std::string, std::string>& vars) {
  return [vars](const char* name) -> const char* {
    const auto it = vars.find(name);
    return it == vars.end() ? nullptr : it->second.c_str();
  };
}

void write(const std::filesystem::path& file, const std::string& text) {
  std::filesystem::create_directories(file.parent_path());
  std::ofstream(file) << text;
}

int affinity_cpus() {
  cpu_set_t set;
  CPU_ZERO(&set);
  return sched_getaffinity(0, sizeof set, &set) == 0 ? CPU_COUNT(&set) : 0;
}

TEST(Resources, ThreadsFollowTheAffinityAndSlurm) {
  const int cpus = affinity_cpus();
  ASSERT_GT(cpus, 0);
  Grant g = granted_threads(env_of({}));
  EXPECT_EQ(g.amount, cpus);
  EXPECT_EQ(g.source, "the CPU affinity");
  g = granted_threads(env_of({{"SLURM_CPUS_PER_TASK", "1"}}));
  EXPECT_EQ(g.amount, 1);
  EXPECT_EQ(g.source, cpus > 1 ? "SLURM_CPUS_PER_TASK" : "the CPU affinity");
  // More CPUs than the process may run on, or nonsense: the affinity stands.
  for (const char* text : {"100000", "0", "-3", "four", ""}) {
    g = granted_threads(env_of({{"SLURM_CPUS_PER_TASK", text}}));
    EXPECT_EQ(g.amount, cpus) << text;
  }
}

TEST(Resources, MemoryIsTheSmallestGrant) {
  test::TempDir tmp;
  const std::string none = tmp.file("no-cgroup");
  const double ram = granted_memory(env_of({}), none, tmp.file("root")).amount;
  EXPECT_GT(ram, 1e8);
  EXPECT_EQ(granted_memory(env_of({}), none, tmp.file("root")).source, "the physical memory");

  // cgroup v2: the job's own cgroup is unlimited, its parent holds 3 GB ("max" above it).
  write(tmp.file("v2/proc_cgroup"), "0::/slurm/job_7/step_0\n");
  write(tmp.file("v2/root/memory.max"), "max\n");
  write(tmp.file("v2/root/slurm/memory.max"), "max\n");
  write(tmp.file("v2/root/slurm/job_7/memory.max"), "3000000000\n");
  write(tmp.file("v2/root/slurm/job_7/step_0/memory.max"), "max\n");
  Grant g = granted_memory(env_of({}), tmp.file("v2/proc_cgroup"), tmp.file("v2/root"));
  if (ram > 3e9) {
    EXPECT_EQ(g.amount, 3e9);
    EXPECT_NE(g.source.find("slurm/job_7/memory.max"), std::string::npos) << g.source;
  }

  // cgroup v1: the memory controller's own hierarchy; the unlimited value is a huge number.
  write(tmp.file("v1/proc_cgroup"), "7:cpu,cpuacct:/a\n4:memory:/docker/abc\n0::/\n");
  write(tmp.file("v1/root/memory/memory.limit_in_bytes"), "9223372036854771712\n");
  write(tmp.file("v1/root/memory/docker/abc/memory.limit_in_bytes"), "2147483648\n");
  g = granted_memory(env_of({}), tmp.file("v1/proc_cgroup"), tmp.file("v1/root"));
  if (ram > 2147483648.0) {
    EXPECT_EQ(g.amount, 2147483648.0) << g.source;
  }

  // Slurm: --mem (per node, shared by the step's tasks here) and --mem-per-cpu (times the CPUs).
  g = granted_memory(env_of({{"SLURM_MEM_PER_NODE", "64"}}), none, tmp.file("root"));
  EXPECT_EQ(g.amount, 64.0 * 1048576);
  EXPECT_EQ(g.source, "Slurm's grant (SLURM_MEM_PER_NODE)");
  g = granted_memory(env_of({{"SLURM_MEM_PER_NODE", "64"}, {"SLURM_STEP_TASKS_PER_NODE", "4(x2)"}}), none, tmp.file("root"));
  EXPECT_EQ(g.amount, 16.0 * 1048576);
  g = granted_memory(env_of({{"SLURM_MEM_PER_CPU", "10"}, {"SLURM_CPUS_PER_TASK", "3"}}), none, tmp.file("root"));
  EXPECT_EQ(g.amount, 30.0 * 1048576);
  g = granted_memory(env_of({{"SLURM_MEM_PER_CPU", "10"}, {"SLURM_CPUS_ON_NODE", "4"}}), none, tmp.file("root"));
  EXPECT_EQ(g.amount, 40.0 * 1048576);
  // The smallest wins: Slurm's 64 MB under a 2 GB cgroup.
  g = granted_memory(env_of({{"SLURM_MEM_PER_NODE", "64"}}), tmp.file("v1/proc_cgroup"), tmp.file("v1/root"));
  EXPECT_EQ(g.amount, 64.0 * 1048576);
  // Nonsense is ignored.
  g = granted_memory(env_of({{"SLURM_MEM_PER_NODE", "lots"}}), none, tmp.file("root"));
  EXPECT_EQ(g.amount, ram);
}

// The real process: whatever this machine grants, it is positive and at most its memory.
TEST(Resources, ThisProcessHasAGrant) {
  const Grant t = granted_threads(), m = granted_memory();
  EXPECT_GE(t.amount, 1);
  EXPECT_GT(m.amount, 0);
  EXPECT_TRUE(std::isfinite(m.amount));
}

}  // namespace
}  // namespace meniscus
