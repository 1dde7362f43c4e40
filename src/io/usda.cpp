// meniscus io — USDA mesh writer (Pixar OpenUSD text format; UsdGeomMesh / UsdGeomPrimvar schemas, openusd.org).
#include "io/usda.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <set>

#include <fmt/format.h>

#include "io/atomic_file.hpp"
#include "io/obj.hpp"
#include "meniscus/errors.hpp"

namespace meniscus::io {

namespace {

// USD property names are identifiers (letters, digits, '_', not starting with a digit); the
// attribute names of particle files are free text, so anything else becomes '_'.
std::string identifier(const std::string& name) {
  std::string out = name.empty() ? std::string("_") : name;
  for (char& c : out)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_')) c = '_';
  if (std::isdigit(static_cast<unsigned char>(out[0]))) out.insert(out.begin(), '_');
  return out;
}

class UsdaText {
 public:
  explicit UsdaText(AtomicFile& file) : file_(file) {}
  template <class... Args>
  void put(fmt::format_string<Args...> format, Args&&... args) {
    fmt::format_to(std::back_inserter(out_), format, std::forward<Args>(args)...);
    if (out_.size() >= (std::size_t(1) << 20)) flush();
  }
  void flush() {
    file_.write(out_.data(), out_.size());
    out_.clear();
  }

  // `[(x, y, z), …]`, eight tuples to a line so the text stays diffable and editor-friendly.
  void vec3_array(const std::vector<Vec3f>& values) {
    put("[");
    for (std::size_t i = 0; i < values.size(); ++i)
      put("{}({}, {}, {})", i == 0 ? "" : (i % 8 == 0 ? ",\n            " : ", "), values[i].x, values[i].y, values[i].z);
    put("]");
  }
  void float_array(const Attribute& a, bool tuples) {
    put("[");
    const std::size_t c = std::size_t(a.components);
    const std::size_t n = tuples ? a.values.size() / c : a.values.size();
    for (std::size_t i = 0; i < n; ++i) {
      put("{}", i == 0 ? "" : (i % 8 == 0 ? ",\n            " : ", "));
      if (tuples) put("({}, {}, {})", a.values[3 * i], a.values[3 * i + 1], a.values[3 * i + 2]);
      else if (a.integer) put("{}", int64_t(std::clamp(std::round(double(a.values[i])), -2147483648.0, 2147483647.0)));
      else put("{}", a.values[i]);
    }
    put("]");
  }

 private:
  AtomicFile& file_;
  fmt::memory_buffer out_;
};

}  // namespace

void write_usda_mesh(const std::string& path, const TriangleMesh& mesh) {
  check_mesh_for_writing(path, mesh, "USDA");
  std::set<std::string> used{"displayColor"};
  std::vector<std::pair<std::string, const Attribute*>> primvars;
  const Attribute* color = nullptr;
  for (const Attribute& a : mesh.attributes) {
    if (a.name == "color" && a.components == 3 && !color) {
      color = &a;
      continue;
    }
    std::string name = identifier(a.name);
    if (!used.insert(name).second)
      throw InvalidParameter(fmt::format("cannot write USDA '{}': attribute '{}' would be primvars:{}, which is "
                                         "already used",
                                         path, a.name, name));
    primvars.emplace_back(std::move(name), &a);
  }

  AtomicFile file(path);
  UsdaText out(file);
  // Y up: the simulators meniscus reads (SPlisHSPlasH, DualSPHysics, Houdini) put gravity along -Y.
  out.put("#usda 1.0\n(\n    defaultPrim = \"meniscus\"\n    doc = \"written by meniscus\"\n"
          "    metersPerUnit = 1\n    upAxis = \"Y\"\n)\n\n");
  out.put("def Xform \"meniscus\"\n{{\n    def Mesh \"surface\"\n    {{\n");
  if (!mesh.vertices.empty()) {
    Vec3f lo = mesh.vertices[0], hi = mesh.vertices[0];
    for (const Vec3f& p : mesh.vertices) {
      lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
      hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
    }
    out.put("        float3[] extent = [({}, {}, {}), ({}, {}, {})]\n", lo.x, lo.y, lo.z, hi.x, hi.y, hi.z);
  }
  out.put("        int[] faceVertexCounts = [");
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) out.put("{}", t == 0 ? "3" : (t % 32 == 0 ? ",\n            3" : ", 3"));
  out.put("]\n        int[] faceVertexIndices = [");
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
    out.put("{}{}, {}, {}", t == 0 ? "" : (t % 8 == 0 ? ",\n            " : ", "), mesh.triangles[t][0],
            mesh.triangles[t][1], mesh.triangles[t][2]);
  out.put("]\n");
  if (!mesh.normals.empty()) {
    out.put("        normal3f[] normals = ");
    out.vec3_array(mesh.normals);
    out.put(" (\n            interpolation = \"vertex\"\n        )\n");
  }
  out.put("        uniform token orientation = \"rightHanded\"\n        point3f[] points = ");
  out.vec3_array(mesh.vertices);
  out.put("\n");
  if (color) {
    out.put("        color3f[] primvars:displayColor = ");
    out.float_array(*color, true);
    out.put(" (\n            interpolation = \"vertex\"\n        )\n");
  }
  for (const auto& [name, a] : primvars) {
    if (a->components == 3 && !a->integer) {
      out.put("        float3[] primvars:{} = ", name);
      out.float_array(*a, true);
      out.put(" (\n            interpolation = \"vertex\"\n        )\n");
    } else {
      out.put("        {}[] primvars:{} = ", a->integer ? "int" : "float", name);
      out.float_array(*a, false);
      // elementSize: how many consecutive values belong to one vertex (USD's primvar layout).
      if (a->components == 1) out.put(" (\n            interpolation = \"vertex\"\n        )\n");
      else out.put(" (\n            elementSize = {}\n            interpolation = \"vertex\"\n        )\n", a->components);
    }
  }
  out.put("        uniform token subdivisionScheme = \"none\"\n    }}\n}}\n");
  out.flush();
  file.commit();
}

}  // namespace meniscus::io
