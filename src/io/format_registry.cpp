// meniscus io — format tables and the public entry points of io.hpp (format choice, gzip, NaN policy).
#include "io/format_registry.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>

#include <fmt/format.h>

#include "io/atomic_file.hpp"
#include "io/bgeo_classic.hpp"
#include "io/bgeo_json.hpp"
#include "io/blosc_container.hpp"
#include "io/ply.hpp"
#include "io/xyz.hpp"
#include "io/csv.hpp"
#include "io/npy.hpp"
#include "io/obj.hpp"
#include "io/usda.hpp"
#include "io/vtk_legacy.hpp"
#include "io/vtu.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/messages.hpp"
#include "meniscus/resources.hpp"

namespace meniscus::io {

const std::vector<ParticleReader>& particle_readers() {
  static const std::vector<ParticleReader> table = {
      {"ply", {".ply"}, &sniff_ply, &read_ply_particles},
      {"xyz", {".xyz"}, nullptr, &read_xyz_particles},
      {"bgeo", {".bgeo", ".bhclassic"}, &sniff_bgeo_classic, &read_bgeo_classic_particles},
      {"bgeo (binary JSON)", {}, &sniff_bgeo_json, &read_bgeo_json_particles},
      {"bgeo.sc", {".sc"}, &sniff_blosc_container, &read_bgeo_sc_particles},
      {"vtk", {".vtk"}, &sniff_vtk_legacy, &read_vtk_legacy_particles},
      {"vtu", {".vtu", ".vtp"}, &sniff_vtu, &read_vtu_particles},
      {"npy", {".npy"}, &sniff_npy, &read_npy_particles},
      {"csv", {".csv", ".txt"}, nullptr, &read_csv_particles},
  };
  return table;
}

const std::vector<MeshReader>& mesh_readers() {
  static const std::vector<MeshReader> table = {
      {"ply", {".ply"}, &sniff_ply, &read_ply_mesh},
      {"bgeo", {".bgeo"}, &sniff_bgeo_classic, &read_bgeo_classic_mesh},
      {"bgeo (binary JSON)", {}, &sniff_bgeo_json, &read_bgeo_json_mesh},
      {"bgeo.sc", {".sc"}, &sniff_blosc_container, &read_bgeo_sc_mesh},
      {"vtk", {".vtk"}, &sniff_vtk_legacy, &read_vtk_legacy_mesh},
      {"obj", {".obj"}, nullptr, &read_obj_mesh},
      {"vtp", {".vtp"}, &sniff_vtu, &read_vtp_mesh},
  };
  return table;
}

const std::vector<MeshWriter>& mesh_writers() {
  static const std::vector<MeshWriter> table = {
      {"ply", {".ply"}, &write_ply_mesh},
      {"bgeo", {".bgeo"}, &write_bgeo_mesh},
      {"bgeo.sc", {".bgeo.sc", ".sc"}, &write_bgeo_sc_mesh},
      {"obj", {".obj"}, &write_obj_mesh},
      {"vtk", {".vtk"}, &write_vtk_legacy_mesh},
      {"vtp", {".vtp"}, &write_vtp_mesh},
      {"usda", {".usda"}, &write_usda_mesh},
  };
  return table;
}

void check_read_memory(const Source& source, double extra, std::string_view what) {
  if (source.limit.bytes == 0) return;
  const double held = double(source.bytes.size());
  if (held + extra <= double(source.limit.bytes)) return;
  throw ResourceError(fmt::format("'{}': {} take {} beside the {} read: more than {}", printable(source.path), what,
                                  human_bytes(extra), human_bytes(held), source.limit.description));
}

void check_particle_memory(const Source& source, uint64_t count, std::size_t values) {
  check_read_memory(source, 2.0 * double(count) * double(values) * sizeof(float),
                    fmt::format("{} particles of {} values", count, values));
}

void check_mesh_for_writing(const std::string& path, const TriangleMesh& mesh, std::string_view format) {
  const std::size_t nv = mesh.vertices.size();
  if (!mesh.normals.empty() && mesh.normals.size() != nv)
    throw InvalidParameter(fmt::format("cannot write {} '{}': {} normals for {} vertices", format, path,
                                       mesh.normals.size(), nv));
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
    for (const uint32_t v : mesh.triangles[t])
      if (v >= nv)
        throw InvalidParameter(fmt::format("cannot write {} '{}': triangle {} refers to vertex {}, but the mesh has "
                                           "{} vertices",
                                           format, path, t, v, nv));
  for (const Attribute& a : mesh.attributes) {
    if (a.components < 1)
      throw InvalidParameter(fmt::format("cannot write {} '{}': attribute '{}' has {} components", format, path,
                                         a.name, a.components));
    if (a.values.size() != nv * std::size_t(a.components))
      throw InvalidParameter(fmt::format("cannot write {} '{}': attribute '{}' has {} values, expected {} ({} "
                                         "vertices × {})",
                                         format, path, a.name, a.values.size(), nv * std::size_t(a.components), nv,
                                         a.components));
  }
}

std::string format_extension(const std::string& path) {
  std::filesystem::path p(path);
  auto lower = [](std::string s) {
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    return s;
  };
  std::string ext = lower(p.extension().string());
  if (ext == ".gz") ext = lower(p.stem().extension().string());
  return ext;
}

namespace {

template <class Table>
std::string list_formats(const Table& table) {
  std::string text;
  for (const auto& entry : table)
    for (const std::string& ext : entry.extensions) text += (text.empty() ? "" : ", ") + ext;
  return text;
}

// Magic bytes win over the name: a mislabelled file is read as what it is, and formats without
// magic (xyz) are only ever chosen by name.
template <class Table>
const typename Table::value_type* choose(const Table& table, const Source& source) {
  for (const auto& entry : table)
    if (entry.sniff && entry.sniff(source.bytes)) return &entry;
  const std::string ext = format_extension(source.path);
  for (const auto& entry : table)
    if (std::find(entry.extensions.begin(), entry.extensions.end(), ext) != entry.extensions.end()) return &entry;
  return nullptr;
}

template <class Table>
[[noreturn]] void unknown_format(const Table& table, const Source& source, const char* what) {
  const std::string ext = format_extension(source.path);
  throw FormatError(source.path, "",
                    fmt::format("unknown {} format ({}); expected one of the supported formats: {}", what,
                                ext.empty() ? "no extension and no known magic bytes"
                                            : "extension '" + ext + "' and no known magic bytes",
                                list_formats(table)));
}

bool finite(Vec3f p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z); }

// One NaN/Inf policy for every format: refuse by default (naming the first bad particle), or drop
// the particle and its attribute values when asked.
void handle_invalid(ParticleSet& particles, const std::string& path, const ReadOptions& options,
                    ReadReport* report) {
  const std::size_t n = particles.positions.size();
  std::size_t first_bad = n;
  for (std::size_t i = 0; i < n; ++i)
    if (!finite(particles.positions[i])) {
      first_bad = i;
      break;
    }
  if (first_bad == n) return;
  if (!options.drop_invalid) {
    const Vec3f p = particles.positions[first_bad];
    throw FormatError(path, fmt::format("particle {}", first_bad),
                      fmt::format("expected finite coordinates, found ({}, {}, {}) ({} drops such particles)",
                                  p.x, p.y, p.z, spelled_setting("drop_invalid", "true")));
  }
  const std::size_t dropped = particles.keep_if([](Vec3f x) { return finite(x); });
  if (report) report->dropped_invalid += dropped;
}

}  // namespace

}  // namespace meniscus::io

namespace meniscus {

namespace io {

ReadLimit read_limit(double max_memory_gb) {
  const Grant limit = memory_limit(max_memory_gb);
  return {std::size_t(limit.amount),
          max_memory_gb > 0 ? fmt::format("the {} that {} allows", human_bytes(limit.amount),
                                          spelled_setting("max_memory_gb", fmt::format("{:g}", max_memory_gb)))
                            : fmt::format("the {} a run may use ({}; raise it with {})", human_bytes(limit.amount),
                                          limit.source, spelled("max_memory_gb"))};
}

}  // namespace io

ParticleSet read_particles(const std::string& path, const ReadOptions& options, ReadReport* report) {
  bool gzip = false;
  const io::ReadLimit limit = io::read_limit(options.max_memory_gb);
  const io::ByteBuffer bytes = io::read_file_content(path, limit, &gzip);
  const io::Source source{bytes, path, gzip, limit};
  const io::ParticleReader* reader = io::choose(io::particle_readers(), source);
  if (!reader) io::unknown_format(io::particle_readers(), source, "particle");

  ReadReport local;
  ReadReport& r = report ? *report : local;
  r = ReadReport{};
  r.format = reader->name;
  ParticleSet particles = reader->read(source, options, &r);
  if (gzip) r.format += ", gzip-compressed";
  particles.validate();
  io::handle_invalid(particles, path, options, &r);
  if (particles.positions.empty())
    throw FormatError(path, "",
                      r.dropped_invalid > 0
                          ? fmt::format("contains no particles once the {} with NaN/Inf coordinates are dropped",
                                        r.dropped_invalid)
                          : std::string("contains no particles"));
  return particles;
}

namespace {

/// The fixed records of a particle file (particle_records), from its size and first bytes.
struct Records {
  std::size_t offset = 0, record = 0, count = 0;
  std::optional<io::PlyRecords> ply;  // a PLY's header for a part
};

std::optional<Records> fixed_records(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return std::nullopt;
  in.seekg(0, std::ios::end);
  const auto end = in.tellg();
  if (end <= 0) return std::nullopt;
  const std::size_t size = std::size_t(end);
  io::Bytes head(std::min<std::size_t>(size, std::size_t(1) << 16));
  in.seekg(0);
  if (!in.read(reinterpret_cast<char*>(head.data()), std::streamsize(head.size()))) return std::nullopt;
  if (head.size() >= 2 && head[0] == 0x1f && head[1] == 0x8b) return std::nullopt;  // gzip
  const io::Source source{head, path, false, {}};
  const io::ParticleReader* reader = io::choose(io::particle_readers(), source);
  if (!reader) return std::nullopt;
  Records r;
  if (reader->name == "xyz") {
    r.record = 12, r.count = size / 12;
  } else if (reader->name == "ply") {
    r.ply = io::ply_vertex_records(source);
    if (!r.ply) return std::nullopt;
    r.offset = r.ply->offset, r.record = r.ply->record, r.count = r.ply->count;
  } else {
    return std::nullopt;
  }
  // The records must all be there (a short file is read_particles' to report).
  if (r.record == 0 || r.count == 0 || r.offset + r.count * r.record > size) return std::nullopt;
  if (reader->name == "xyz" && size % 12 != 0) return std::nullopt;
  return r;
}

}  // namespace

std::size_t particle_records(const std::string& path) {
  const std::optional<Records> r = fixed_records(path);
  return r ? r->count : 0;
}

ParticleSet read_particle_range(const std::string& path, std::size_t first, std::size_t count,
                                const ReadOptions& options, ReadReport* report) {
  const std::optional<Records> r = fixed_records(path);
  if (!r) throw InvalidParameter(fmt::format("'{}' cannot be read in parts (not fixed-size records)", path));
  if (first > r->count || count > r->count - first)
    throw InvalidParameter(fmt::format("'{}': particles {}..{} asked for, the file has {}", path, first, first + count,
                                       r->count));
  ReadReport local;
  ReadReport& rep = report ? *report : local;
  rep = ReadReport{};
  if (count == 0) return ParticleSet{};
  // The part's bytes, behind a header for them alone (PLY): the format's own reader decodes them.
  const std::string header = r->ply ? io::ply_range_header(*r->ply, count) : std::string();
  io::Bytes bytes(header.size() + count * r->record);
  std::copy(header.begin(), header.end(), bytes.begin());
  std::ifstream in(path, std::ios::binary);
  in.seekg(std::streamoff(r->offset + first * r->record));
  if (!in.read(reinterpret_cast<char*>(bytes.data() + header.size()), std::streamsize(count * r->record)))
    throw IoError(fmt::format("cannot read particles {}..{} of '{}'", first, first + count, path));
  const io::Source source{bytes, path, false, {}};
  const io::ParticleReader* reader = io::choose(io::particle_readers(), source);
  ParticleSet particles = reader->read(source, options, &rep);
  particles.validate();
  const std::size_t n = particles.positions.size();
  for (std::size_t i = 0; i < n; ++i)
    if (!options.drop_invalid && !io::finite(particles.positions[i])) {
      const Vec3f p = particles.positions[i];
      throw FormatError(path, fmt::format("particle {}", first + i),
                        fmt::format("expected finite coordinates, found ({}, {}, {}) ({} drops such particles)",
                                    p.x, p.y, p.z, spelled_setting("drop_invalid", "true")));
    }
  io::handle_invalid(particles, path, options, &rep);
  return particles;
}

TriangleMesh read_mesh(const std::string& path, double max_memory_gb) {
  bool gzip = false;
  const io::ReadLimit limit = io::read_limit(max_memory_gb);
  const io::ByteBuffer bytes = io::read_file_content(path, limit, &gzip);
  const io::Source source{bytes, path, gzip, limit};
  const io::MeshReader* reader = io::choose(io::mesh_readers(), source);
  if (!reader) io::unknown_format(io::mesh_readers(), source, "mesh");
  return reader->read(source);
}

namespace {

/// The writer for a file name (lower case): the one with the longest extension the name ends
/// with, so "x.bgeo.sc" goes to the .bgeo.sc writer and never to ".bgeo"'s. Sets `*ext` to it.
const io::MeshWriter* writer_for(const std::string& name, std::string* ext) {
  const io::MeshWriter* found = nullptr;
  for (const io::MeshWriter& writer : io::mesh_writers())
    for (const std::string& e : writer.extensions)
      if (name.size() > e.size() && name.ends_with(e) && (!found || e.size() > ext->size())) {
        found = &writer;
        *ext = e;
      }
  return found;
}

}  // namespace

void write_mesh(const std::string& path, const TriangleMesh& mesh) {
  const std::string ext = std::filesystem::path(path).extension().string();
  std::string name = std::filesystem::path(path).filename().string();
  std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  std::string inner;
  const io::MeshWriter* packed = name.ends_with(".gz") ? writer_for(name.substr(0, name.size() - 3), &inner) : nullptr;
  // Any format gzip-compressed (Houdini reads .bgeo.gz; our readers inflate by content): the
  // inner format's writer, whose AtomicFile compresses a name ending in .gz as it writes.
  if (packed) return packed->write(path, mesh);
  if (const io::MeshWriter* writer = writer_for(name, &inner)) return writer->write(path, mesh);
  throw InvalidParameter(fmt::format("cannot write '{}': unknown mesh format '{}'; supported: {}", path,
                                     ext.empty() ? "(no extension)" : ext, io::list_formats(io::mesh_writers())));
}

std::vector<std::string> particle_formats() {
  std::vector<std::string> out;
  for (const io::ParticleReader& r : io::particle_readers())
    out.insert(out.end(), r.extensions.begin(), r.extensions.end());
  return out;
}

std::vector<std::string> mesh_formats() {
  std::vector<std::string> out;
  for (const io::MeshWriter& w : io::mesh_writers()) out.insert(out.end(), w.extensions.begin(), w.extensions.end());
  return out;
}

}  // namespace meniscus
