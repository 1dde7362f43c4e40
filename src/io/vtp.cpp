// meniscus io — VTK XML PolyData writer (.vtp) and the parallel index of pieces (.pvtp), as
// ParaView reads them (Kitware "VTK XML Formats": appended raw data with UInt64 headers).
#include <fmt/format.h>

#include <bit>
#include <cstdint>
#include <set>
#include <string>
#include <vector>

#include "io/atomic_file.hpp"
#include "io/format_registry.hpp"
#include "io/vtu.hpp"
#include "meniscus/errors.hpp"

namespace meniscus::io {
namespace {

static_assert(std::endian::native == std::endian::little, "the .vtp writer writes this machine's bytes as LittleEndian");

/// A point array's name as an XML attribute value (VTK names are free text; quotes and markup escaped).
std::string xml_escape(const std::string& s) {
  std::string out;
  for (const char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string point_arrays(const TriangleMesh& mesh, const char* tag, uint64_t* offset, std::vector<uint64_t>* sizes) {
  std::string xml;
  const std::size_t nv = mesh.vertices.size();
  const auto array = [&](const std::string& name, const char* type, int components, uint64_t bytes) {
    xml += fmt::format("      <{} type=\"{}\" Name=\"{}\" NumberOfComponents=\"{}\"", tag, type, xml_escape(name), components);
    if (offset) {
      xml += fmt::format(" format=\"appended\" offset=\"{}\"", *offset);
      *offset += 8 + bytes;
      sizes->push_back(bytes);
    }
    xml += "/>\n";
  };
  if (!mesh.normals.empty()) array("Normals", "Float32", 3, nv * 12);
  for (const Attribute& a : mesh.attributes) array(a.name, "Float32", a.components, nv * std::size_t(a.components) * 4);
  return xml;
}

}  // namespace

void write_vtp_mesh(const std::string& path, const TriangleMesh& mesh) {
  check_mesh_for_writing(path, mesh, "VTK XML PolyData");
  std::set<std::string> names{"Normals"};
  for (const Attribute& a : mesh.attributes)
    if (!names.insert(a.name).second)
      throw InvalidParameter(fmt::format("cannot write '{}': two point arrays are named '{}'", path, a.name));
  const uint64_t nv = mesh.vertices.size(), nt = mesh.triangles.size();
  uint64_t offset = 0;
  std::vector<uint64_t> sizes;
  const auto appended = [&](uint64_t bytes) {
    const uint64_t at = offset;
    offset += 8 + bytes;
    sizes.push_back(bytes);
    return at;
  };
  std::string xml = "<?xml version=\"1.0\"?>\n"
                    "<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n"
                    "  <PolyData>\n";
  xml += fmt::format("    <Piece NumberOfPoints=\"{}\" NumberOfPolys=\"{}\">\n", nv, nt);
  xml += fmt::format("      <Points>\n        <DataArray type=\"Float32\" NumberOfComponents=\"3\" format=\"appended\" "
                     "offset=\"{}\"/>\n      </Points>\n", appended(nv * 12));
  xml += fmt::format("      <Polys>\n        <DataArray type=\"Int64\" Name=\"connectivity\" format=\"appended\" "
                     "offset=\"{}\"/>\n", appended(nt * 24));
  xml += fmt::format("        <DataArray type=\"Int64\" Name=\"offsets\" format=\"appended\" offset=\"{}\"/>\n      "
                     "</Polys>\n", appended(nt * 8));
  xml += fmt::format("      <PointData{}>\n", mesh.normals.empty() ? "" : " Normals=\"Normals\"");
  std::string arrays = point_arrays(mesh, "DataArray", &offset, &sizes);
  xml += arrays + "      </PointData>\n    </Piece>\n  </PolyData>\n  <AppendedData encoding=\"raw\">\n   _";

  AtomicFile file(path);
  file.write(xml);
  std::size_t block = 0;
  const auto header = [&] { file.write(&sizes[block++], 8); };
  header();
  file.write(mesh.vertices.data(), nv * 12);
  header();
  std::vector<int64_t> buffer;
  constexpr std::size_t kBatch = 1 << 16;
  for (std::size_t t = 0; t < nt; t += kBatch) {
    buffer.clear();
    for (std::size_t u = t; u < std::min<std::size_t>(nt, t + kBatch); ++u)
      for (const uint32_t v : mesh.triangles[u]) buffer.push_back(int64_t(v));
    file.write(buffer.data(), buffer.size() * 8);
  }
  header();
  for (std::size_t t = 0; t < nt; t += kBatch) {
    buffer.clear();
    for (std::size_t u = t; u < std::min<std::size_t>(nt, t + kBatch); ++u) buffer.push_back(int64_t(3 * (u + 1)));
    file.write(buffer.data(), buffer.size() * 8);
  }
  if (!mesh.normals.empty()) {
    header();
    file.write(mesh.normals.data(), nv * 12);
  }
  for (const Attribute& a : mesh.attributes) {
    header();
    file.write(a.values.data(), a.values.size() * 4);
  }
  file.write("\n  </AppendedData>\n</VTKFile>\n");
  file.commit();
}

void write_pvtp_index(const std::string& path, const std::vector<std::string>& pieces, const TriangleMesh& layout) {
  std::string xml = "<?xml version=\"1.0\"?>\n"
                    "<VTKFile type=\"PPolyData\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n"
                    "  <PPolyData GhostLevel=\"0\">\n"
                    "    <PPoints>\n      <PDataArray type=\"Float32\" NumberOfComponents=\"3\"/>\n    </PPoints>\n";
  xml += fmt::format("    <PPointData{}>\n", layout.normals.empty() ? "" : " Normals=\"Normals\"");
  xml += point_arrays(layout, "PDataArray", nullptr, nullptr);
  xml += "    </PPointData>\n";
  for (const std::string& piece : pieces) xml += fmt::format("    <Piece Source=\"{}\"/>\n", xml_escape(piece));
  xml += "  </PPolyData>\n</VTKFile>\n";
  AtomicFile file(path);
  file.write(xml);
  file.commit();
}

}  // namespace meniscus::io
