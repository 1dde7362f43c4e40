// meniscus io — NumPy ".npy" arrays (numpy.lib.format, NEP 1 "A Simple File Format for NumPy Arrays", versions 1–3).
#pragma once

#include "io/format_registry.hpp"

namespace meniscus::io {

/// True when the data starts with the magic "\x93NUMPY".
bool sniff_npy(ByteView bytes);

/// A float32/float64 array of shape (N, k ≥ 3) (columns 0..2 are x y z, the rest an attribute
/// "values" of k − 3 components), or a structured array whose fields are x, y, z (or one field
/// "P"/"position"/"pos" of shape (3,)) plus any numeric fields, each an attribute (vx vy vz
/// grouped into "velocity"). Either byte order, C or Fortran order. The header's shape and dtype
/// must account for exactly the bytes after the header. Throws FormatError naming the byte offset.
ParticleSet read_npy_particles(const Source& source, const ReadOptions& options, ReadReport* report);

}  // namespace meniscus::io
