// meniscus io — Houdini 12+ binary-JSON geometry (.bgeo; SideFX UT_JSONDefines.h, geo.html, hgeo.py) reader and mesh writer.
#pragma once

#include <functional>
#include <string>

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

/// A polygon mesh in binary-JSON geometry: P → vertices, the numeric point attributes as in
/// read_bgeo_classic_mesh (`N` → normals, `Cd` → "color", `v` → "velocity", the others under
/// their names), closed polygons → triangles (fanned, Houdini's clockwise winding turned back into
/// our counter-clockwise). Polygons come from polygon runs ("p_r"/"Polygon_run" with
/// "r_v"/"nvertices_rle" or "n_v"/"nvertices"), single "Poly" primitives and Houdini 12's
/// "run"s of "Poly", each vertex mapped to its point through topology/pointref/indices; open
/// curves and other primitive types are skipped, vertex attributes ignored. Throws FormatError
/// (file, byte offset, expectation) on malformed input; offsets count bytes of `source.bytes`.
TriangleMesh read_bgeo_json_mesh(const Source& source);

/// Encodes `mesh` as little-endian binary-JSON geometry, the stream Houdini 18.5 writes into a
/// .bgeo.sc (layout in bgeo_json.cpp): points with P (fpreal32 × 3), N when the mesh has
/// normals, every attribute (Houdini's names `Cd` for "color" and `v` for "velocity" as in
/// write_bgeo_mesh, with Houdini's colour and vector type info; fpreal32, or int32 when
/// integer), and one closed polygon run of triangles wound clockwise for Houdini. The whole mesh is checked before the first byte goes to `sink`,
/// which then receives the stream in pieces of about 1 MiB (so the caller never holds it whole).
/// Throws InvalidParameter for an inconsistent mesh, clashing names (e.g. "color" and "Cd") or
/// integer values outside int32; whatever `sink` throws passes through.
void encode_bgeo_json_mesh(const std::string& path, const TriangleMesh& mesh,
                           const std::function<void(ByteView)>& sink);

}  // namespace meniscus::io
