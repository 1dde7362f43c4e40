// meniscus io — Houdini classic binary geometry ("BgeoV" v5; SideFX GPD.txt, partio BGEO.cpp, splashsurf bgeo_format.rs).
//
// Byte layout (all big-endian, what write_bgeo_mesh emits and the reader accepts):
//   0  "Bgeo" 'V'                                      5 bytes
//   5  int32 version = 5
//   9  int32 nPoints, nPrims, nPointGroups, nPrimGroups, nPointAttrib, nVertexAttrib, nPrimAttrib, nAttrib
//  41  point attribute dictionary: per entry uint16 nameLen, name, uint16 size, int32 type
//      (low 16 bits: 0 FLOAT, 1 INT, 4 INDEX, 5 VECTOR; 2 STRING is not supported), then
//      FLOAT/INT/VECTOR: size × 4-byte defaults; INDEX: int32 nStrings + nStrings × (uint16 len, bytes)
//      point block: nPoints × (float32 P.x P.y P.z P.w, then every attribute's size 32-bit words)
//      vertex attribute dictionary, primitive attribute dictionary (same entry layout)
//      primitives, nPrims in all, either one at a time (int32 type, body) or in runs
//      (uint32 0xFFFFFFFF, uint16 count, int32 type, count bodies — how Houdini writes polygons):
//        Poly  (type 1):      int32 nVerts, uint8 closed, nVerts × (index, vertex attribute words),
//                             primitive attribute words
//        Part  (type 0x8000): int32 nVerts, nVerts × (index, vertex attribute words), primitive attribute words
//      where an index is uint16 when nPoints < 65536, else int32 (partio, Naiad's Bgeo reader);
//      point groups, primitive groups (not parsed: we stop before them), detail attribute
//      dictionary + one record, trailer 00 FF (not required).
// Houdini's polygons wind clockwise seen from the front (its normals follow the left-hand rule),
// ours counter-clockwise, so the writer reverses each triangle and the mesh reader turns it back.
#include "io/bgeo_classic.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <set>

#include <fmt/format.h>

#include "io/atomic_file.hpp"
#include "io/text_lines.hpp"
#include "meniscus/errors.hpp"

namespace meniscus::io {

namespace {

enum AttributeType : uint32_t { type_float = 0, type_int = 1, type_string = 2, type_index = 4, type_vector = 5 };
constexpr uint32_t prim_poly = 1;
constexpr uint32_t prim_part = 0x8000;
constexpr uint32_t prim_run = 0xFFFFFFFFu;

struct DictionaryEntry {
  std::string name;
  uint16_t size = 0;
  uint32_t type = 0;
};

struct Counts {
  uint32_t points = 0, prims = 0, point_groups = 0, prim_groups = 0;
  uint32_t point_attributes = 0, vertex_attributes = 0, prim_attributes = 0, detail_attributes = 0;
};

// Counts are int32 in the format; a negative one is corrupt, not a large unsigned number.
uint32_t read_count(ByteCursor& c, const char* what) {
  const std::size_t at = c.offset();
  const int32_t v = c.read<int32_t>(Endian::big, what);
  if (v < 0) c.fail_at(at, fmt::format("expected a non-negative {}, found {}", what, v));
  return static_cast<uint32_t>(v);
}

Counts read_header(ByteCursor& c) {
  const ByteView magic = c.take(5, "the 'BgeoV' magic");
  if (!std::equal(magic.begin(), magic.end(), "BgeoV"))
    c.fail_at(0, "expected the classic bgeo magic 'BgeoV'");
  const std::size_t at = c.offset();
  const int32_t version = c.read<int32_t>(Endian::big, "the bgeo version");
  if (version != 5) c.fail_at(at, fmt::format("expected bgeo version 5, found {}", version));
  Counts n;
  n.points = read_count(c, "point count");
  n.prims = read_count(c, "primitive count");
  n.point_groups = read_count(c, "point group count");
  n.prim_groups = read_count(c, "primitive group count");
  n.point_attributes = read_count(c, "point attribute count");
  n.vertex_attributes = read_count(c, "vertex attribute count");
  n.prim_attributes = read_count(c, "primitive attribute count");
  n.detail_attributes = read_count(c, "detail attribute count");
  return n;
}

std::vector<DictionaryEntry> read_dictionary(ByteCursor& c, uint32_t count, const char* kind) {
  // The smallest entry is uint16 nameLen + uint16 size + int32 type.
  c.require_records(count, 8, fmt::format("{} attribute dictionary entries", kind));
  std::vector<DictionaryEntry> entries(count);
  for (DictionaryEntry& e : entries) {
    const std::size_t entry_at = c.offset();
    const uint16_t name_length = c.read<uint16_t>(Endian::big, "an attribute name length");
    const ByteView name = c.take(name_length, "an attribute name");
    e.name.assign(reinterpret_cast<const char*>(name.data()), name.size());
    const std::size_t size_at = c.offset();
    e.size = c.read<uint16_t>(Endian::big, "an attribute size");
    if (e.size == 0) c.fail_at(size_at, fmt::format("expected a non-zero size for {} attribute '{}'", kind, excerpt(e.name)));
    // The high 16 bits carry type info flags (e.g. "index pair") that do not change the layout.
    e.type = c.read<uint32_t>(Endian::big, "an attribute type") & 0xFFFFu;
    switch (e.type) {
      case type_float:
      case type_int:
      case type_vector: c.skip(std::size_t(e.size) * 4, "the attribute defaults"); break;
      case type_index: {
        const uint32_t strings = read_count(c, "string count of an indexed string attribute");
        c.require_records(strings, 2, "indexed strings");
        for (uint32_t i = 0; i < strings; ++i) c.skip(c.read<uint16_t>(Endian::big, "a string length"), "a string");
        break;
      }
      case type_string:
        c.fail_at(entry_at, fmt::format("{} attribute '{}' has the STRING type (2), which classic bgeo readers do "
                                        "not support; expected FLOAT (0), INT (1), INDEX (4) or VECTOR (5)",
                                        kind, excerpt(e.name)));
      default:
        c.fail_at(entry_at, fmt::format("expected attribute type FLOAT (0), INT (1), INDEX (4) or VECTOR (5) for {} "
                                        "attribute '{}', found {}",
                                        kind, excerpt(e.name), e.type));
    }
  }
  return entries;
}

std::size_t words(const std::vector<DictionaryEntry>& entries) {
  std::size_t n = 0;
  for (const DictionaryEntry& e : entries) n += e.size;
  return n;
}

// Everything the reader found; mesh-only parts (polygons) are filled when asked for.
struct Decoded {
  ParticleSet points;
  std::vector<std::vector<uint32_t>> polygons;
  bool primitives_complete = true;
};

Decoded decode(const Source& source, bool want_polygons) {
  ByteCursor c(source.bytes, source.path, source.gzip);
  const Counts n = read_header(c);
  const std::vector<DictionaryEntry> point_dict = read_dictionary(c, n.point_attributes, "point");

  Decoded d;
  const std::size_t point_words = 4 + words(point_dict);
  c.require_records(n.points, point_words * 4, "points");
  check_read_memory(source, double(n.points) * double(point_words - 1) * 4,
                    fmt::format("{} points of {} values", n.points, point_words - 1));
  d.points.positions.resize(n.points);
  for (const DictionaryEntry& e : point_dict) {
    Attribute a;
    a.name = e.name;
    a.components = e.size;
    a.integer = e.type == type_int || e.type == type_index;
    a.values.resize(std::size_t(n.points) * e.size);
    d.points.attributes.push_back(std::move(a));
  }
  // The block size was checked above, so the loop decodes without further bounds checks.
  const uint8_t* p = c.take(std::size_t(n.points) * point_words * 4, "points").data();
  for (std::size_t i = 0; i < n.points; ++i) {
    d.points.positions[i] = {ByteCursor::load<float>(p, Endian::big), ByteCursor::load<float>(p + 4, Endian::big),
                             ByteCursor::load<float>(p + 8, Endian::big)};
    p += 16;  // P.w, the homogeneous weight, has no meaning for particles
    for (std::size_t a = 0; a < point_dict.size(); ++a) {
      float* out = d.points.attributes[a].values.data() + i * point_dict[a].size;
      const bool integer = d.points.attributes[a].integer;
      for (std::size_t k = 0; k < point_dict[a].size; ++k, p += 4)
        out[k] = integer ? static_cast<float>(ByteCursor::load<int32_t>(p, Endian::big))
                         : ByteCursor::load<float>(p, Endian::big);
    }
  }

  const std::vector<DictionaryEntry> vertex_dict = read_dictionary(c, n.vertex_attributes, "vertex");
  const std::vector<DictionaryEntry> prim_dict = read_dictionary(c, n.prim_attributes, "primitive");
  const std::size_t index_size = n.points < 65536 ? 2 : 4;
  const std::size_t vertex_size = index_size + 4 * words(vertex_dict);
  const std::size_t prim_attribute_size = 4 * words(prim_dict);

  // nVerts × (point index, vertex attribute words); the indices are kept for polygons.
  auto read_vertex_list = [&](uint32_t count, std::vector<uint32_t>* keep) {
    c.require_records(count, vertex_size, "primitive vertices");
    if (keep) keep->reserve(count);
    for (uint32_t v = 0; v < count; ++v) {
      const std::size_t index_at = c.offset();
      const uint32_t index =
          index_size == 2 ? c.read<uint16_t>(Endian::big, "a point index") : c.read<uint32_t>(Endian::big, "a point index");
      if (index >= n.points)
        c.fail_at(index_at, fmt::format("expected a point index below {}, found {}", n.points, index));
      c.skip(vertex_size - index_size, "vertex attributes");
      if (keep) keep->push_back(index);
    }
  };

  uint32_t done = 0;
  while (done < n.prims) {
    const std::size_t at = c.offset();
    uint32_t type = c.read<uint32_t>(Endian::big, "a primitive type");
    uint32_t run = 1;
    if (type == prim_run) {
      run = c.read<uint16_t>(Endian::big, "a primitive run length");
      type = c.read<uint32_t>(Endian::big, "the primitive type of a run");
      if (run == 0 || run > n.prims - done)
        c.fail_at(at, fmt::format("expected a primitive run of 1 to {} primitives, found {}", n.prims - done, run));
    }
    if (type != prim_poly && type != prim_part) {
      // Other primitive types (NURBS, volumes, packed …) have layouts we do not parse; the points
      // are complete already, so stop here instead of guessing.
      d.primitives_complete = false;
      break;
    }
    for (uint32_t r = 0; r < run; ++r) {
      const std::size_t prim_at = c.offset();
      const uint32_t count = read_count(c, "primitive vertex count");
      if (type == prim_poly) {
        c.skip(1, "the polygon's closed flag");
        std::vector<uint32_t> indices;
        read_vertex_list(count, want_polygons ? &indices : nullptr);
        if (want_polygons) {
          if (count < 3)
            c.fail_at(prim_at, fmt::format("expected a polygon with at least 3 vertices, found {}", count));
          d.polygons.push_back(std::move(indices));
        }
      } else {
        read_vertex_list(count, nullptr);
      }
      c.skip(prim_attribute_size, "primitive attributes");
    }
    done += run;
  }

  // Detail attributes follow the groups, whose layout partio never parsed either: only read them
  // when nothing stands between them and the primitives.
  if (d.primitives_complete && n.point_groups == 0 && n.prim_groups == 0) {
    const std::vector<DictionaryEntry> detail_dict = read_dictionary(c, n.detail_attributes, "detail");
    c.skip(4 * words(detail_dict), "the detail attribute values");
    // Then the file ends, after the "extra" section's begin and end bytes (00 ff) where the
    // writer adds them. Bytes beyond mean the counts do not describe the file (a point count one
    // too low would otherwise drop the last point silently).
    const std::size_t end_at = c.offset();
    const ByteView rest = source.bytes.subspan(end_at);
    const bool trailer = rest.empty() || (rest.size() == 2 && rest[0] == 0x00 && rest[1] == 0xff);
    if (!trailer)
      c.fail_at(end_at, fmt::format("expected the end of the file after the {} points and {} primitives its header "
                                    "counts, found {} more bytes (do the counts match the data?)",
                                    n.points, n.prims, rest.size()));
  }
  return d;
}

// ---------------------------------------------------------------------------------------------
// Writer

void put_u16(std::vector<uint8_t>& out, uint16_t v) {
  out.push_back(static_cast<uint8_t>(v >> 8));
  out.push_back(static_cast<uint8_t>(v));
}
void put_u32(std::vector<uint8_t>& out, uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8) out.push_back(static_cast<uint8_t>(v >> shift));
}
void put_f32(std::vector<uint8_t>& out, float v) { put_u32(out, std::bit_cast<uint32_t>(v)); }

struct OutputAttribute {
  std::string name;
  uint32_t type;
  uint16_t size;
  float default_value;
  const float* values;  // element-major, `size` per point
  bool integer;
};

std::vector<OutputAttribute> output_attributes(const std::string& path, const TriangleMesh& mesh) {
  const std::size_t nv = mesh.vertices.size();
  std::vector<OutputAttribute> out;
  std::set<std::string> names;
  auto add = [&](OutputAttribute a, const std::string& from) {
    if (a.name.empty() || a.name.size() > 65535)
      throw InvalidParameter(fmt::format("cannot write '{}': attribute name '{}' does not fit bgeo (1 to 65535 bytes)",
                                         path, a.name));
    if (!names.insert(a.name).second)
      throw InvalidParameter(fmt::format("cannot write '{}': attribute '{}' would be written as '{}', which is already "
                                         "used",
                                         path, from, a.name));
    out.push_back(std::move(a));
  };
  if (!mesh.normals.empty()) add({"N", type_vector, 3, 0.0f, &mesh.normals[0].x, false}, "normals");
  for (const Attribute& a : mesh.attributes) {
    if (a.components < 1 || a.components > 65535)
      throw InvalidParameter(fmt::format("cannot write '{}': attribute '{}' has {} components", path, a.name, a.components));
    if (a.values.size() != nv * std::size_t(a.components))
      throw InvalidParameter(fmt::format("cannot write '{}': attribute '{}' has {} values, expected {} ({} vertices × {})",
                                         path, a.name, a.values.size(), nv * std::size_t(a.components), nv,
                                         a.components));
    const uint16_t size = static_cast<uint16_t>(a.components);
    const float* values = a.values.data();
    // Houdini's own names, so its viewport and SOPs use them: Cd is FLOAT 3 with default white,
    // v is a VECTOR (it transforms with the geometry).
    if (a.name == "color" && a.components == 3 && !a.integer)
      add({"Cd", type_float, 3, 1.0f, values, false}, a.name);
    else if (a.name == "velocity" && a.components == 3 && !a.integer)
      add({"v", type_vector, 3, 0.0f, values, false}, a.name);
    else
      add({a.name, a.integer ? uint32_t(type_int) : uint32_t(type_float), size, 0.0f, values, a.integer}, a.name);
  }
  // Integer attributes must survive the int32 conversion; refuse before anything is written.
  for (const OutputAttribute& a : out) {
    if (!a.integer) continue;
    for (std::size_t i = 0; i < nv * a.size; ++i)
      if (!(a.values[i] >= -2147483648.0f && a.values[i] < 2147483648.0f))
        throw InvalidParameter(fmt::format("cannot write '{}': integer attribute '{}' has value {} at vertex {}, "
                                           "outside the int32 range",
                                           path, a.name, a.values[i], i / a.size));
  }
  return out;
}

}  // namespace

bool sniff_bgeo_classic(ByteView bytes) {
  return bytes.size() >= 5 && bytes[0] == 'B' && bytes[1] == 'g' && bytes[2] == 'e' && bytes[3] == 'o' &&
         bytes[4] == 'V';
}

ParticleSet read_bgeo_classic_particles(const Source& source, const ReadOptions& /*options*/, ReadReport* report) {
  Decoded d = decode(source, false);
  if (report) report->format = "bgeo (classic)";
  return std::move(d.points);
}

TriangleMesh read_bgeo_classic_mesh(const Source& source) {
  Decoded d = decode(source, true);
  TriangleMesh mesh;
  mesh.vertices = std::move(d.points.positions);
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    const Vec3f p = mesh.vertices[i];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      throw FormatError(source.path, fmt::format("point {}", i),
                        fmt::format("expected finite coordinates, found ({}, {}, {})", p.x, p.y, p.z));
  }
  for (Attribute& a : d.points.attributes) {
    if (a.name == "N" && a.components == 3 && !a.integer) {
      mesh.normals.resize(mesh.vertices.size());
      for (std::size_t i = 0; i < mesh.normals.size(); ++i)
        mesh.normals[i] = {a.values[3 * i], a.values[3 * i + 1], a.values[3 * i + 2]};
      continue;
    }
    if (a.name == "Cd" && a.components == 3 && !a.integer) a.name = "color";
    else if (a.name == "v" && a.components == 3 && !a.integer) a.name = "velocity";
    mesh.attributes.push_back(std::move(a));
  }
  for (const std::vector<uint32_t>& polygon : d.polygons)
    for (std::size_t k = 1; k + 1 < polygon.size(); ++k)
      mesh.triangles.push_back({polygon[0], polygon[k + 1], polygon[k]});  // clockwise → counter-clockwise
  return mesh;
}

void write_bgeo_mesh(const std::string& path, const TriangleMesh& mesh) {
  const std::size_t nv = mesh.vertices.size();
  constexpr std::size_t int32_max = std::size_t(std::numeric_limits<int32_t>::max());
  if (nv > int32_max || mesh.triangles.size() > int32_max)
    throw InvalidParameter(fmt::format("cannot write '{}': {} vertices and {} triangles do not fit bgeo's int32 counts",
                                       path, nv, mesh.triangles.size()));
  check_mesh_for_writing(path, mesh, "bgeo");
  const std::vector<OutputAttribute> attributes = output_attributes(path, mesh);
  if (attributes.size() > int32_max)
    throw InvalidParameter(fmt::format("cannot write '{}': too many attributes", path));

  std::vector<uint8_t> chunk;
  constexpr std::size_t flush_at = std::size_t(1) << 20;
  chunk.reserve(flush_at + 65536);
  for (const char ch : std::string_view("BgeoV")) chunk.push_back(static_cast<uint8_t>(ch));
  put_u32(chunk, 5);
  put_u32(chunk, static_cast<uint32_t>(nv));
  put_u32(chunk, static_cast<uint32_t>(mesh.triangles.size()));
  put_u32(chunk, 0);  // point groups
  put_u32(chunk, 0);  // primitive groups
  put_u32(chunk, static_cast<uint32_t>(attributes.size()));
  put_u32(chunk, 0);  // vertex attributes
  put_u32(chunk, 0);  // primitive attributes
  put_u32(chunk, 0);  // detail attributes
  for (const OutputAttribute& a : attributes) {
    put_u16(chunk, static_cast<uint16_t>(a.name.size()));
    for (const char ch : a.name) chunk.push_back(static_cast<uint8_t>(ch));
    put_u16(chunk, a.size);
    put_u32(chunk, a.type);
    for (std::size_t k = 0; k < a.size; ++k) {
      if (a.integer) put_u32(chunk, 0);
      else put_f32(chunk, a.default_value);
    }
  }

  AtomicFile file(path);
  auto flush = [&](bool force) {
    if (force || chunk.size() >= flush_at) {
      file.write(chunk);
      chunk.clear();
    }
  };
  for (std::size_t i = 0; i < nv; ++i) {
    put_f32(chunk, mesh.vertices[i].x);
    put_f32(chunk, mesh.vertices[i].y);
    put_f32(chunk, mesh.vertices[i].z);
    put_f32(chunk, 1.0f);
    for (const OutputAttribute& a : attributes) {
      const float* v = a.values + i * a.size;
      for (std::size_t k = 0; k < a.size; ++k) {
        if (a.integer) put_u32(chunk, std::bit_cast<uint32_t>(static_cast<int32_t>(std::lround(v[k]))));
        else put_f32(chunk, v[k]);
      }
    }
    flush(false);
  }
  // Polygons in runs of at most 65535 (the run length is a uint16), as Houdini writes them.
  const bool short_indices = nv < 65536;
  for (std::size_t start = 0; start < mesh.triangles.size(); start += 65535) {
    const std::size_t run = std::min<std::size_t>(65535, mesh.triangles.size() - start);
    put_u32(chunk, prim_run);
    put_u16(chunk, static_cast<uint16_t>(run));
    put_u32(chunk, prim_poly);
    for (std::size_t t = start; t < start + run; ++t) {
      const Triangle& tri = mesh.triangles[t];
      put_u32(chunk, 3);
      chunk.push_back(1);  // closed
      for (const uint32_t v : {tri[0], tri[2], tri[1]}) {  // counter-clockwise → Houdini's clockwise
        if (short_indices) put_u16(chunk, static_cast<uint16_t>(v));
        else put_u32(chunk, v);
      }
      flush(false);
    }
  }
  chunk.push_back(0x00);  // trailer, as partio and Houdini end the file
  chunk.push_back(0xFF);
  flush(true);
  file.commit();
}

}  // namespace meniscus::io
