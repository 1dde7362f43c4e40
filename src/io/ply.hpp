// meniscus io — PLY (ascii, binary little/big endian) particle and mesh reader, binary mesh writer.
#pragma once

#include <memory>
#include <optional>
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

/// Where the particles of a binary PLY lie as fixed-size records, for reading a part of the file
/// alone: the vertex element first, scalar properties only. `head` holds at least the header.
struct PlyRecords {
  std::size_t offset = 0, record = 0, count = 0;
  std::string format, properties;  ///< the header's encoding and the vertex properties' lines
};
std::optional<PlyRecords> ply_vertex_records(const Source& head);
/// PlyRecords::header for `count` vertices.
std::string ply_range_header(const PlyRecords& records, std::size_t count);

/// binary_little_endian PLY: x y z float, nx ny nz float when the mesh has normals, then the
/// attributes ("color" → red green blue uchar, "velocity" → vx vy vz, other 3-component
/// attributes <n>_x <n>_y <n>_z, k-component ones <n>_0 …, 1-component <n> as float or int),
/// then `property list uchar uint vertex_indices`. Throws InvalidParameter for an inconsistent
/// mesh (index out of range, attribute length, names that PLY cannot hold), IoError on write failure.
void write_ply_mesh(const std::string& path, const TriangleMesh& mesh);

/// write_ply_mesh() in parts, for a mesh too large to hold at once (an MPI run's rank 0 writes the
/// ranks' pieces as they come): the header from the counts and a layout (its attributes' names,
/// components and kinds, and whether it has normals; its values are not read), then every vertex
/// in parts, then every triangle in parts, to a temporary name that commit() renames once the
/// counts are complete. Destroyed before commit(), it leaves no file. Same file as
/// write_ply_mesh() of the whole mesh; the same refusals, part by part.
class PlyMeshWriter {
 public:
  PlyMeshWriter(const std::string& path, std::size_t vertices, std::size_t triangles, const TriangleMesh& layout);
  ~PlyMeshWriter();
  PlyMeshWriter(const PlyMeshWriter&) = delete;
  PlyMeshWriter& operator=(const PlyMeshWriter&) = delete;
  /// The next vertices: part.vertices with their normals and the layout's attributes.
  void add_vertices(const TriangleMesh& part);
  /// The next triangles (indices into the whole mesh); only after every vertex.
  void add_triangles(const Triangle* triangles, std::size_t count);
  void commit();

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace meniscus::io
