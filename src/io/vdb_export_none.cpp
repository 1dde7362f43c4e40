// meniscus — write_field_vdb when meniscus is built without OpenVDB.
#include "io/vdb_export.hpp"
#include "meniscus/errors.hpp"

namespace meniscus {

bool has_openvdb() { return false; }

void write_field_vdb(const std::string& path, const ParticleSet&, const Params&) {
  throw InvalidParameter(path +
                         ": writing .vdb needs meniscus built with OpenVDB (install libopenvdb-dev and rebuild)");
}

}  // namespace meniscus
