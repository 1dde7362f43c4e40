// meniscus — what this process may use, as a scheduler or a container grants it: CPUs and memory.
#pragma once

#include <functional>
#include <string>

namespace meniscus {

/// Reads an environment variable; nullptr when unset (std::getenv by default, a map in tests).
using EnvFn = std::function<const char*(const char*)>;

/// A granted amount and where it comes from ("CPU affinity", "SLURM_CPUS_PER_TASK", ...).
struct Grant {
  double amount = 0;
  std::string source;
};

/// The worker threads this process should run: the CPUs of its affinity mask (what a scheduler that
/// binds tasks, mpirun's binding or `taskset` leave it), or fewer where Slurm grants fewer without
/// binding them (SLURM_CPUS_PER_TASK, as `--cpus-per-task` sets it under `task/none`). At least 1.
Grant granted_threads(const EnvFn& env = {});

/// The memory this process may use, in bytes: the smallest of the machine's physical memory, the
/// memory limit of its cgroup and of every cgroup above it (v2 `memory.max`, v1
/// `memory.limit_in_bytes`; a container's or a Slurm task's `--mem` under `task/cgroup`), and the
/// memory Slurm granted the job (SLURM_MEM_PER_NODE, or SLURM_MEM_PER_CPU times its CPUs), shared
/// by the tasks of a step on the node. `cgroup_root` is where the cgroup file systems are mounted.
Grant granted_memory(const EnvFn& env = {}, const std::string& proc_self_cgroup = "/proc/self/cgroup",
                     const std::string& cgroup_root = "/sys/fs/cgroup");

/// The memory a run may use, in bytes: `max_memory_gb` when it is given (> 0), else 90 % of
/// granted_memory() (the rest is the margin for what estimates miss). `source` says which:
/// "--max-memory" or "90 % of the cgroup limit (…)".
Grant memory_limit(double max_memory_gb, const EnvFn& env = {});

}  // namespace meniscus
