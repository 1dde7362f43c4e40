// meniscus io — Pixar USD text layer (".usda"; openusd.org UsdGeomMesh schema) mesh writer.
#pragma once

#include <string>

#include "io/format_registry.hpp"

namespace meniscus::io {

/// `def Xform "meniscus" { def Mesh "surface" { … } }` with faceVertexCounts, faceVertexIndices,
/// points, extent, normals (vertex interpolation) when present, the "color" attribute as
/// primvars:displayColor, other attributes as primvars:<name> (float/int, float3 for three
/// components, float with elementSize otherwise; names made into valid identifiers), orientation
/// rightHanded (the library's triangles are counter-clockwise seen from outside), no
/// subdivision; layer metadata upAxis = "Y", metersPerUnit = 1. Throws InvalidParameter for an
/// inconsistent mesh or attribute names that collide once sanitised, IoError on write failure.
void write_usda_mesh(const std::string& path, const TriangleMesh& mesh);

}  // namespace meniscus::io
