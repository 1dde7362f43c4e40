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

}  // namespace meniscus::io
