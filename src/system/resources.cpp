// meniscus — the CPUs and memory this process is granted (include/meniscus/resources.hpp).
#include <algorithm>
#include "meniscus/resources.hpp"

#include "meniscus/messages.hpp"

#include <fmt/format.h>
#include <sched.h>
#include <unistd.h>

#include <charconv>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string_view>

namespace meniscus {
namespace {

const char* call_env(const EnvFn& env, const char* name) { return env ? env(name) : std::getenv(name); }

/// The leading positive integer of a Slurm variable ("4", "2(x3)", "4096M" style values); 0 if none.
double leading_number(const char* text) {
  if (text == nullptr) return 0;
  double value = 0;
  const std::string_view s(text);
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), value);
  return ec == std::errc() && end != s.data() && value > 0 && std::isfinite(value) ? value : 0;
}

/// The first line of a file as a number of bytes; INFINITY for "max", a missing file or an
/// unlimited v1 value (the kernel writes a huge page-rounded number there).
double limit_file(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::string line;
  if (!in || !std::getline(in, line) || line == "max") return INFINITY;
  const double bytes = leading_number(line.c_str());
  return bytes > 0 && bytes < 1e18 ? bytes : INFINITY;
}

/// Whether a v1 hierarchy's controller list ("cpu,cpuacct", "memory") names the memory controller.
bool lists_memory(std::string_view controllers) {
  for (std::size_t at = 0; at <= controllers.size();) {
    const std::size_t comma = std::min(controllers.find(',', at), controllers.size());
    if (controllers.substr(at, comma - at) == "memory") return true;
    at = comma + 1;
  }
  return false;
}

struct CgroupLimit {
  double bytes = INFINITY;
  std::string file;
};

/// The smallest memory limit on a cgroup's path and its ancestors.
void tighten(CgroupLimit& best, const std::filesystem::path& mount, std::string path, const char* file) {
  for (;;) {
    const std::filesystem::path at = mount / std::filesystem::path(path).relative_path() / file;
    if (const double bytes = limit_file(at); bytes < best.bytes) best = {bytes, at.string()};
    if (path.empty() || path == "/") return;
    const std::size_t slash = path.find_last_of('/');
    path = slash == 0 || slash == std::string::npos ? "/" : path.substr(0, slash);
  }
}

}  // namespace

Grant granted_threads(const EnvFn& env) {
  Grant g{double(std::max(1L, sysconf(_SC_NPROCESSORS_ONLN))), "the online CPUs"};
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof set, &set) == 0 && CPU_COUNT(&set) > 0) g = {double(CPU_COUNT(&set)), "the CPU affinity"};
  if (const double slurm = leading_number(call_env(env, "SLURM_CPUS_PER_TASK")); slurm >= 1 && slurm < g.amount)
    g = {std::floor(slurm), "SLURM_CPUS_PER_TASK"};
  return g;
}

Grant granted_memory(const EnvFn& env, const std::string& proc_self_cgroup, const std::string& cgroup_root) {
  const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGE_SIZE);
  Grant g{pages > 0 && page > 0 ? double(pages) * double(page) : 16e9, "the physical memory"};

  // cgroups: "0::/path" (v2, mounted at the root or at unified/ in a hybrid layout) and
  // "N:memory:/path" (v1, mounted at memory/).
  CgroupLimit cg;
  std::ifstream in(proc_self_cgroup);
  std::string line;
  const std::filesystem::path root(cgroup_root);
  while (std::getline(in, line)) {
    const std::size_t a = line.find(':'), b = a == std::string::npos ? a : line.find(':', a + 1);
    if (b == std::string::npos) continue;
    const std::string_view controllers = std::string_view(line).substr(a + 1, b - a - 1);
    const std::string path = line.substr(b + 1);
    if (line.compare(0, a, "0") == 0 && controllers.empty()) {
      tighten(cg, root, path, "memory.max");
      tighten(cg, root / "unified", path, "memory.max");
    } else if (lists_memory(controllers)) {
      tighten(cg, root / "memory", path, "memory.limit_in_bytes");
    }
  }
  if (cg.bytes < g.amount) g = {cg.bytes, fmt::format("the cgroup limit ({})", cg.file)};

  // Slurm's grant (MB), shared by the step's tasks on this node.
  double tasks_here = leading_number(call_env(env, "SLURM_STEP_TASKS_PER_NODE"));
  if (tasks_here < 1) tasks_here = 1;
  double slurm = 0;
  std::string source;
  if (const double per_node = leading_number(call_env(env, "SLURM_MEM_PER_NODE")); per_node > 0) {
    slurm = per_node * 1048576.0 / tasks_here;
    source = "SLURM_MEM_PER_NODE";
  } else if (const double per_cpu = leading_number(call_env(env, "SLURM_MEM_PER_CPU")); per_cpu > 0) {
    double cpus = leading_number(call_env(env, "SLURM_CPUS_PER_TASK"));
    if (cpus < 1) cpus = leading_number(call_env(env, "SLURM_CPUS_ON_NODE")) / tasks_here;
    slurm = per_cpu * 1048576.0 * std::max(1.0, cpus);
    source = "SLURM_MEM_PER_CPU";
  }
  if (slurm > 0 && slurm < g.amount) g = {slurm, fmt::format("Slurm's grant ({})", source)};
  return g;
}

Grant memory_limit(double max_memory_gb, const EnvFn& env) {
  // A bound below one byte is held at one byte: rounded to no bytes it would read as "none".
  if (max_memory_gb > 0) return {std::max(1.0, max_memory_gb * 1e9), spelled("max_memory_gb")};
  constexpr double kShare = 0.9;
  const Grant granted = granted_memory(env);
  return {kShare * granted.amount, fmt::format("90 % of {}", granted.source)};
}

}  // namespace meniscus
