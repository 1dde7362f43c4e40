// meniscus io — raw float32 XYZ particle files (splashsurf's .xyz: x y z triples, little endian, no header).
#pragma once

#include "io/format_registry.hpp"

namespace meniscus::io {

/// Reads 12-byte records of little-endian float32 x, y, z. Throws FormatError for an empty file
/// or a size that is not a multiple of 12.
ParticleSet read_xyz_particles(const Source& source, const ReadOptions& options, ReadReport* report);

}  // namespace meniscus::io
