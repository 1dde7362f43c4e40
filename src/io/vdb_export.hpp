// meniscus — exporting the distance field as an OpenVDB level set grid (optional: needs
// meniscus built with OpenVDB; without it write_field_vdb throws).
#pragma once

#include <string>

#include "meniscus/params.hpp"
#include "meniscus/particles.hpp"

namespace meniscus {

/// True when meniscus was built with OpenVDB.
bool has_openvdb();

/// Writes the union-of-spheres level set of the particles — φ − r_outer on a cubic grid of voxel
/// size `params.voxel_size` (negative inside the fluid, background 2h outside the band), grid
/// class level set, named "surface" — to `path` (.vdb), atomically. `params` must
/// be resolved (resolve_params). Throws InvalidParameter without OpenVDB, IoError on failure.
void write_field_vdb(const std::string& path, const ParticleSet& particles, const Params& params);

}  // namespace meniscus
