// meniscus io — Houdini's ".bgeo.sc" container ("scf1", Blosc-1 chunks, big-endian index, "1fcs") reader.
#pragma once

#include <string>

#include "io/format_registry.hpp"

namespace meniscus::io {

/// True when the data starts with "scf1".
bool sniff_blosc_container(ByteView bytes);

/// The concatenated decompressed chunks of a ".bgeo.sc" file. The index is checked against the
/// file size and every chunk's header against the index before anything is allocated or
/// decompressed. Throws FormatError (file, byte offset in the file, expectation).
Bytes decompress_blosc_container(ByteView bytes, const std::string& path);

/// A ".bgeo.sc" file: decompressed, then read as binary-JSON bgeo (error offsets of that stage
/// count bytes of the decompressed stream).
ParticleSet read_bgeo_sc_particles(const Source& source, const ReadOptions& options, ReadReport* report);

}  // namespace meniscus::io
