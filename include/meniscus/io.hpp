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

/// Reads a triangle mesh (.ply ascii/binary with a face list). Used by tests and `inspect`.
TriangleMesh read_mesh(const std::string& path);

/// File extensions understood, for `meniscus info`.
std::vector<std::string> particle_formats();
std::vector<std::string> mesh_formats();

}  // namespace meniscus
