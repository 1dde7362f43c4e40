// meniscus — reading particles and writing meshes. Formats are chosen by content (magic bytes)
// where the format has one, otherwise by file extension.
#pragma once

#include <string>
#include <vector>

#include "meniscus/mesh.hpp"
#include "meniscus/particles.hpp"

namespace meniscus {

struct ReadOptions {
  /// Drop particles with NaN/Inf coordinates instead of refusing the file.
  bool drop_invalid = false;
  /// Column names for headerless text particle files (.csv/.txt), e.g. SPHysics IPART:
  /// {"x","y","z","vx","vy","vz","rho","p","mass"}. Empty: the first line must name the columns.
  std::vector<std::string> columns;
  /// The most memory the read may hold — the file's bytes (inflated as they arrive when it is
  /// gzip-compressed) and the particles decoded from them — in GB; 0: 90 % of the memory the
  /// process is granted, as Params::max_memory_gb. A file past it is refused with ResourceError
  /// naming the file, how much was read and the limit, before the memory is taken.
  double max_memory_gb = 0;
};

struct ReadReport {
  std::string format;            ///< e.g. "ply (binary little endian)"
  std::size_t dropped_invalid = 0;
};

/// Reads a particle file (.ply ascii/binary, .xyz raw float32). Every extra per-vertex property
/// becomes an attribute (x/y/z become positions; vx,vy,vz / nx,ny,nz / red,green,blue are
/// grouped into 3-component attributes "velocity", "normal", "color"). Throws FormatError
/// (file, offset or line, expectation) on malformed input, IoError when the file cannot be read.
ParticleSet read_particles(const std::string& path, const ReadOptions& options = {},
                           ReadReport* report = nullptr);

/// How many particles `path` holds when a part of it can be read alone — fixed-size records at
/// known offsets: raw .xyz, and binary .ply whose first element is the vertices with scalar
/// properties only, not compressed — else 0 (read it whole with read_particles). Reads only
/// the file's size and header. Under MPI each rank reads its own part of such a file.
std::size_t particle_records(const std::string& path);

/// Particles [first, first + count) of a file particle_records() accepts, with every attribute,
/// as read_particles() gives them: NaN/Inf positions refused naming the particle's index in the
/// file, or dropped with options.drop_invalid (counted in `report`). An empty range is allowed.
ParticleSet read_particle_range(const std::string& path, std::size_t first, std::size_t count,
                                const ReadOptions& options = {}, ReadReport* report = nullptr);

/// Writes a mesh (.ply binary little endian, with normals and attributes). The file is written
/// to a temporary name in the same directory and renamed when complete, so a failure never
/// leaves a partial file. Throws IoError / InvalidParameter (unknown extension).
void write_mesh(const std::string& path, const TriangleMesh& mesh);

/// Reads a triangle mesh (any format of mesh_formats() but .usda). Used by `inspect`, `render`,
/// `merge` and the tests. `max_memory_gb` bounds the bytes read as ReadOptions::max_memory_gb does.
TriangleMesh read_mesh(const std::string& path, double max_memory_gb = 0);

/// File extensions understood, for `meniscus info`.
std::vector<std::string> particle_formats();
std::vector<std::string> mesh_formats();

}  // namespace meniscus
