// meniscus — how many processes an MPI launcher started (apps/meniscus/mpi_surface.hpp).
#include <algorithm>
#include <cstdlib>
#include <string>

#include "mpi_surface.hpp"

namespace meniscus::cli {

int launched_ranks() {
  // OpenMPI's mpirun, then PMI/PMIx launchers (srun --mpi=pmix sets PMIX_RANK and Slurm's own
  // step size; MPICH's hydra sets PMI_SIZE).
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE"})
    if (const char* v = std::getenv(name)) return std::max(1, std::atoi(v));
  if (std::getenv("PMIX_RANK") != nullptr) {
    const char* v = std::getenv("SLURM_STEP_NUM_TASKS");
    return v ? std::max(1, std::atoi(v)) : 1;
  }
  return 0;
}

std::string piece_path(const std::string& index, int rank) {
  const std::string stem = index.size() > 5 && index.ends_with(".pvtp") ? index.substr(0, index.size() - 5) : index;
  return stem + "_" + std::to_string(rank) + ".vtp";
}

}  // namespace meniscus::cli
