// meniscus io — Houdini 12+ binary-JSON geometry (.bgeo; SideFX UT_JSONDefines.h, geo.html, hgeo.py) reader.
#pragma once

#include "io/format_registry.hpp"

namespace meniscus::io {

/// True when the data starts with 0x7F followed by "NSJb" (little-endian) or "bJSN" (big-endian).
bool sniff_bgeo_json(ByteView bytes);

/// The point attributes of a binary-JSON geometry: P becomes the positions, every other numeric
/// point attribute an Attribute (payloads in `tuples`, `arrays` or paged `rawpagedata` layout).
/// Topology, primitives, groups, string attributes and the other attribute classes are skipped.
/// Offsets in errors count bytes of `source.bytes` (decompressed when source.gzip is set).
/// Throws FormatError on malformed input.
ParticleSet read_bgeo_json_particles(const Source& source, const ReadOptions& options, ReadReport* report);

}  // namespace meniscus::io
