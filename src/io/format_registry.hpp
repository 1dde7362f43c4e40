// meniscus io — the table of particle readers, mesh readers and mesh writers behind io.hpp.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "io/file_bytes.hpp"
#include "meniscus/io.hpp"

namespace meniscus::io {

/// What a reader gets: the (already gunzipped) file content and where it came from.
struct Source {
  ByteView bytes;
  std::string path;
  bool gzip = false;  ///< the bytes were inflated: offsets count the decompressed stream
  ReadLimit limit;    ///< what the read may hold in all, `bytes` included (ReadOptions::max_memory_gb)
};

/// Throws ResourceError, naming the file, `what` and the limit, when `extra` bytes beside the
/// source's bytes would take the read past its limit. Readers call it with what they are about to
/// allocate for the particles (their decoded columns and the particle set: 2 × 4 bytes a value)
/// or for data they decompress.
void check_read_memory(const Source& source, double extra, std::string_view what);

/// check_read_memory for `count` particles of `values` floats each (positions included), held
/// twice while a reader turns its columns into the particle set.
void check_particle_memory(const Source& source, uint64_t count, std::size_t values);

/// A particle file format. `sniff` (optional) recognises the format from its first bytes and
/// takes precedence over the extension; `read` returns the particles and may set
/// report->format. Readers throw FormatError on malformed input; the caller handles NaN/Inf
/// coordinates and empty results the same way for every format.
struct ParticleReader {
  std::string name;                     ///< e.g. "ply"
  std::vector<std::string> extensions;  ///< lower case with the dot, e.g. ".ply"
  bool (*sniff)(ByteView bytes) = nullptr;
  ParticleSet (*read)(const Source& source, const ReadOptions& options, ReadReport* report) = nullptr;
};

/// A triangle mesh format that can be read back (tests, `inspect`).
struct MeshReader {
  std::string name;
  std::vector<std::string> extensions;
  bool (*sniff)(ByteView bytes) = nullptr;
  TriangleMesh (*read)(const Source& source) = nullptr;
};

/// A triangle mesh output format; writers go through AtomicFile.
struct MeshWriter {
  std::string name;
  std::vector<std::string> extensions;
  void (*write)(const std::string& path, const TriangleMesh& mesh) = nullptr;
};

/// Checks what every mesh writer needs before it creates a file: triangle indices below the
/// vertex count, normals empty or one per vertex, attributes with ≥ 1 component and one element
/// per vertex. Throws InvalidParameter naming `path`, `format` and the first problem.
void check_mesh_for_writing(const std::string& path, const TriangleMesh& mesh, std::string_view format);

/// The tables, in the order formats are tried. Adding a format is one entry here plus its
/// reader/writer file: the table is explicit rather than self-registering because static
/// registration objects in a static library are dropped by the linker when nothing refers to them.
const std::vector<ParticleReader>& particle_readers();
const std::vector<MeshReader>& mesh_readers();
const std::vector<MeshWriter>& mesh_writers();

/// The lower-case extension of `path` that selects a format: ".ply" for "a/B.PLY", and the inner
/// extension for compressed names ("x.ply.gz" → ".ply"), since gzip is detected from the content.
std::string format_extension(const std::string& path);

}  // namespace meniscus::io
