// meniscus io — Houdini classic binary geometry ("BgeoV" version 5; SideFX GPD, partio BGEO.cpp) reader and writer.
#pragma once

#include <string>

#include "io/format_registry.hpp"

namespace meniscus::io {

/// True when the data starts with "BgeoV" (classic binary bgeo; gzip is removed before sniffing).
bool sniff_bgeo_classic(ByteView bytes);

/// The points of a classic bgeo: P.xyz become the positions (P.w is dropped) and every point
/// attribute an Attribute under the file's name (FLOAT/VECTOR as float, INT and INDEX — the
/// string-table index — with integer = true). Part (0x8000) and polygon (1) primitives are read
/// and ignored; any other primitive type ends the parse cleanly (points come first, so nothing is
/// lost). Throws FormatError (file, byte offset, expectation) on malformed input, including the
/// unsupported STRING attribute type.
ParticleSet read_bgeo_classic_particles(const Source& source, const ReadOptions& options, ReadReport* report);

/// The inverse of write_bgeo_mesh: points, polygons (fan-triangulated, winding turned back from
/// Houdini's clockwise into our counter-clockwise), `N` → normals, `Cd` → "color", `v` → "velocity".
TriangleMesh read_bgeo_classic_mesh(const Source& source);

/// Uncompressed classic bgeo v5 that Houdini and partio open: points (P, w = 1) with `N` (the
/// normals, VECTOR 3), `Cd` (the "color" attribute, FLOAT 3), `v` (the "velocity" attribute,
/// VECTOR 3), every other attribute under its name (FLOAT n, INT n when integer); one closed
/// polygon primitive per triangle. Throws InvalidParameter for an inconsistent mesh or names
/// that clash or do not fit, IoError on write failure (through AtomicFile: never a partial file).
void write_bgeo_mesh(const std::string& path, const TriangleMesh& mesh);

}  // namespace meniscus::io
