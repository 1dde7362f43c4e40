// meniscus — `meniscus surface` of one frame over the processes of an MPI job (mpirun, srun
// --mpi=pmix): the ranks read the frame (in parts, or rank 0 whole) and exchange slabs with their
// halos, every rank surfaces its slab, and rank 0 gathers the owned pieces into one process's mesh
// in its order (meniscus/distributed.hpp; docs/cluster.md).
#pragma once

#include <string>

#include "meniscus/io.hpp"
#include "meniscus/params.hpp"

namespace meniscus::cli {

/// Whether this build has MPI (MENISCUS_MPI).
bool mpi_built();

/// How many processes the MPI launcher that started this one started (OMPI_COMM_WORLD_SIZE,
/// PMI_SIZE, or Slurm's SLURM_STEP_NUM_TASKS under srun --mpi); 0 without one. Under one,
/// `meniscus surface` runs over the job's ranks (also one: the same path, "ranks": 1).
int launched_ranks();

/// MPI_Init on construction when an MPI launcher started the process, MPI_Finalize at the end.
class MpiSession {
 public:
  MpiSession(int* argc, char*** argv);
  ~MpiSession();
  MpiSession(const MpiSession&) = delete;
  MpiSession& operator=(const MpiSession&) = delete;
  bool active() const { return active_; }
  int rank() const { return rank_; }
  int size() const { return size_; }

 private:
  bool active_ = false;
  int rank_ = 0, size_ = 1;
};

struct MpiJob {
  std::string input, output, stats;
  Params params;
  ReadOptions read;
  bool quiet = false;
  /// Each rank writes its piece beside the output (`X.pvtp` → `X_0.vtp` …) and rank 0 the
  /// `.pvtp` index instead of gathering and welding (`meniscus merge X.pvtp -o X.ply` welds them).
  bool pieces = false;
};

/// The file of rank `rank`'s piece for an index `X.pvtp`: `X_<rank>.vtp` beside it.
std::string piece_path(const std::string& index, int rank);

/// Surfaces one frame over the session's ranks; every rank returns the job's exit code (0, or 1
/// when any rank failed: each failure is printed by the rank that had it, naming its rank).
int run_surface_mpi(const MpiSession& session, const MpiJob& job);

}  // namespace meniscus::cli
