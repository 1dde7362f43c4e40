// meniscus io — PLY (ascii, binary little/big endian) particle and mesh reader, binary mesh writer.
#pragma once

#include <string>

#include "io/format_registry.hpp"

namespace meniscus::io {

/// True when the data starts with the "ply" magic line.
bool sniff_ply(ByteView bytes);

/// The vertex element as particles: x y z → positions; vx vy vz, velocity_x/_y/_z → "velocity";
/// nx ny nz → "normal"; red green blue → "color" (uchar scaled to [0, 1]); <n>_x/_y/_z → "<n>" (3);
/// <n>_0 … <n>_k → "<n>" (k+1); anything else a 1-component attribute of its own name. Other
/// elements (faces, edges …) are skipped.
ParticleSet read_ply_particles(const Source& source, const ReadOptions& options, ReadReport* report);

/// The vertex element (nx ny nz become the normals, the rest attributes as above) and the face
/// element's `vertex_indices`/`vertex_index` lists, polygons fan-triangulated.
TriangleMesh read_ply_mesh(const Source& source);

/// binary_little_endian PLY: x y z float, nx ny nz float when the mesh has normals, then the
/// attributes ("color" → red green blue uchar, "velocity" → vx vy vz, other 3-component
/// attributes <n>_x <n>_y <n>_z, k-component ones <n>_0 …, 1-component <n> as float or int),
/// then `property list uchar uint vertex_indices`. Throws InvalidParameter for an inconsistent
/// mesh (index out of range, attribute length, names that PLY cannot hold), IoError on write failure.
void write_ply_mesh(const std::string& path, const TriangleMesh& mesh);

}  // namespace meniscus::io
