// meniscus io — Wavefront OBJ (Wavefront "Advanced Visualizer" Appendix B1) mesh writer and reader.
#pragma once

#include <string>
#include <string_view>

#include "io/format_registry.hpp"

namespace meniscus::io {

/// Text OBJ: `v x y z` (shortest round-trip float text), `vn` per vertex when the mesh has
/// normals, `f a//a b//b c//c` (1-based; `f a b c` without normals). OBJ has no per-vertex
/// attribute channel that common readers agree on, so attributes (velocity, color …) are not
/// written. Throws InvalidParameter for an inconsistent mesh, IoError on write failure.
void write_obj_mesh(const std::string& path, const TriangleMesh& mesh);

/// Reads `v` (3 coordinates; 6 → the extra three become a "color" attribute when every vertex has
/// them), `vn`, and `f` with `i`, `i/t`, `i//n`, `i/t/n` corners (negative = relative), polygons
/// fan-triangulated. Normals are kept when every vertex receives one through a face corner.
/// Other statements (o, g, s, usemtl, mtllib, vt, l, p …) are ignored. Throws FormatError with
/// the line on malformed input.
TriangleMesh read_obj_mesh(const Source& source);

}  // namespace meniscus::io
