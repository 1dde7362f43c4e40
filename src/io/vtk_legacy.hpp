// meniscus io — legacy VTK (".vtk", docs.vtk.org "Simple Legacy Formats"): particle and mesh reader, mesh writer.
#pragma once

#include <string>

#include "io/format_registry.hpp"

namespace meniscus::io {

/// True when the data starts with "# vtk DataFile Version".
bool sniff_vtk_legacy(ByteView bytes);

/// ASCII or BINARY (big-endian) legacy VTK, DATASET POLYDATA / UNSTRUCTURED_GRID / STRUCTURED_GRID:
/// POINTS become the positions; every POINT_DATA array (SCALARS with any component count, VECTORS,
/// NORMALS, TEXTURE_COORDINATES, TENSORS, COLOR_SCALARS, FIELD arrays with one tuple per point)
/// becomes an attribute of its own name, integer types marked `integer`. Cells (v4 counts or v5.1
/// OFFSETS/CONNECTIVITY) and CELL_DATA are parsed only to be skipped. Throws FormatError naming
/// the line (ASCII) or byte (BINARY) where the file stops matching the format.
ParticleSet read_vtk_legacy_particles(const Source& source, const ReadOptions& options, ReadReport* report);

/// As above; POLYGONS (and CELLS of type triangle, quad, polygon) become triangles (polygons
/// fan-triangulated), the first NORMALS array the normals, the other point arrays attributes.
TriangleMesh read_vtk_legacy_mesh(const Source& source);

/// Binary (big-endian) legacy VTK 4.2 POLYDATA: POINTS float, POLYGONS (3, a, b, c) int32, then
/// POINT_DATA: NORMALS when present, 1-component attributes as SCALARS (float, or int when
/// `integer`), 3-component ones as VECTORS, others as one FIELD. Throws InvalidParameter for an
/// inconsistent mesh or attribute names with whitespace, IoError on write failure.
void write_vtk_legacy_mesh(const std::string& path, const TriangleMesh& mesh);

}  // namespace meniscus::io
