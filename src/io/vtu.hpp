// meniscus io — VTK XML UnstructuredGrid/PolyData (".vtu"/".vtp", Kitware "VTK XML Formats") particle reader.
#pragma once

#include "io/format_registry.hpp"

namespace meniscus::io {

/// True when the first kilobyte holds a `<VTKFile` tag.
bool sniff_vtu(ByteView bytes);

/// Every <Piece>'s <Points> DataArray become the positions (pieces concatenated; they must carry
/// the same point arrays) and each <PointData> DataArray an attribute of its Name. DataArrays may
/// be `ascii`, `binary` (base64, optionally vtkZLibDataCompressor blocks with UInt32/UInt64
/// headers) or `appended` (raw or base64); any VTK numeric type, either byte order. Cells and
/// cell data are not read. Sizes from the headers are checked against the data before any
/// allocation. Throws FormatError naming the byte offset (of the decoded file) on malformed input.
ParticleSet read_vtu_particles(const Source& source, const ReadOptions& options, ReadReport* report);

/// A VTK XML PolyData (.vtp) mesh of triangles: the points and point data as above, every
/// <Piece>'s <Polys> (connectivity, offsets; each polygon a triangle) the triangles, a 3-component
/// point array "Normals" the normals. Throws FormatError as above, also for a polygon that is not
/// a triangle or a corner out of range.
TriangleMesh read_vtp_mesh(const Source& source);

/// Writes a mesh as VTK XML PolyData (.vtp, ParaView): Float32 points, Int64 connectivity and
/// offsets, "Normals" and every attribute as point data, in one raw appended block with UInt64
/// headers. Atomic.
void write_vtp_mesh(const std::string& path, const TriangleMesh& mesh);

/// Writes a parallel PolyData index (.pvtp, ParaView's convention for pieces written by several
/// processes) naming `pieces` (paths relative to the index), with the point arrays of `layout`.
void write_pvtp_index(const std::string& path, const std::vector<std::string>& pieces, const TriangleMesh& layout);

}  // namespace meniscus::io
