// meniscus — the CLI without MPI (MENISCUS_MPI off or MPI not found): one process per frame.
#include "meniscus/errors.hpp"
#include "mpi_surface.hpp"

namespace meniscus::cli {

bool mpi_built() { return false; }
MpiSession::MpiSession(int*, char***) {}
MpiSession::~MpiSession() = default;
int run_surface_mpi(const MpiSession&, const MpiJob&) {
  throw InvalidParameter("this meniscus was built without MPI (install libopenmpi-dev and rebuild)");
}

}  // namespace meniscus::cli
