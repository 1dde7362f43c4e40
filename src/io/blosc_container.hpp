// meniscus io — Houdini's ".bgeo.sc" container ("scf1", Blosc-1 chunks, big-endian index, "1fcs") reader and writer.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "io/atomic_file.hpp"
#include "io/format_registry.hpp"

namespace meniscus::io {

/// True when the data starts with "scf1".
bool sniff_blosc_container(ByteView bytes);

/// The concatenated decompressed chunks of a ".bgeo.sc" file. The index is checked against the
/// file size and every chunk's header against the index before anything is allocated or
/// decompressed. Throws FormatError (file, byte offset in the file, expectation).
Bytes decompress_blosc_container(ByteView bytes, const std::string& path, const ReadLimit& limit = {});

/// A ".bgeo.sc" file: decompressed, then read as binary-JSON bgeo (error offsets of that stage
/// count bytes of the decompressed stream).
ParticleSet read_bgeo_sc_particles(const Source& source, const ReadOptions& options, ReadReport* report);

/// A ".bgeo.sc" polygon mesh: decompressed, then read_bgeo_json_mesh (error offsets of that stage
/// count bytes of the decompressed stream).
TriangleMesh read_bgeo_sc_mesh(const Source& source);

/// Writes a ".bgeo.sc" container the way Houdini 18.5 does from a plain stream that arrives in
/// pieces: every 1 MiB slice (the last one shorter) becomes one Blosc-1 chunk (LZ4, byte
/// shuffle, type size 4, one block per chunk, compression level 9), then the big-endian index
/// and "1fcs" (layout in blosc_container.cpp). Holds one chunk in memory; the file goes through
/// AtomicFile, created at the first chunk and renamed over `path` by commit() — without
/// commit() (an exception) nothing is left behind. Throws IoError naming `path` when Blosc or the
/// file fails. Not thread-safe.
class BloscContainerWriter {
 public:
  explicit BloscContainerWriter(std::string path);

  /// Appends bytes of the plain stream.
  void write(ByteView bytes);
  /// Compresses what is left, writes the index and trailer, renames the file into place.
  void commit();

 private:
  void compress_chunk();

  std::string path_;
  std::optional<AtomicFile> file_;
  Bytes plain_, compressed_;
  std::vector<uint64_t> chunk_ends_;  // relative to byte 12, where the first chunk starts
  std::size_t last_size_ = 0;         // uncompressed size of the last chunk written
};

/// A triangle mesh as ".bgeo.sc": encode_bgeo_json_mesh's stream through a BloscContainerWriter.
/// Throws InvalidParameter for a mesh that cannot be written (before any file is created),
/// IoError on write failure (never a partial file).
void write_bgeo_sc_mesh(const std::string& path, const TriangleMesh& mesh);

}  // namespace meniscus::io
