// meniscus tests — OBJ, legacy VTK and USDA mesh writers: round trips through our readers and meshio, USDA structure.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "meniscus/errors.hpp"
#include "meniscus/io.hpp"
#include "support/io_helpers.hpp"
#include "support/test_support.hpp"

namespace meniscus {
namespace {

using test::write_file;
using test::read_file;
using test::expect_format_error;
using test::same_bits;

using test::TempDir;

// A small closed mesh (tetrahedron + one extra vertex on a quad-split face) whose coordinates
// would lose bits through any lossy text or double detour.
TriangleMesh sample_mesh() {
  TriangleMesh mesh;
  mesh.vertices = {{0.1f, -0.2f, 0.3f},
                   {1e-30f, -0.0f, 3.4e30f},
                   {std::nextafter(1.0f, 2.0f), 123456.789f, -7.0f},
                   {0.333333343f, 2.5f, -1e-5f},
                   {-1.5f, 0.0625f, 9.75f}};
  mesh.normals = {{0, 0, 1}, {0, 1, 0}, {1, 0, 0}, {0.6f, 0.8f, 0}, {0, -0.6f, 0.8f}};
  mesh.triangles = {{0, 1, 2}, {0, 2, 3}, {3, 2, 1}, {0, 3, 4}, {4, 3, 1}};
  Attribute color{"color", 3, false, {}};
  for (int i = 0; i < 15; ++i) color.values.push_back(float(i * 17) / 255.0f);
  Attribute velocity{"velocity", 3, false, {1.5f, -2.25f, 0.1f, 0, 0, 0, 1e-7f, 3, 4, -1, -2, -3, 0.5f, 0.25f, 0.125f}};
  Attribute id{"id", 1, true, {0, 7, -3, 1000000, 42}};
  Attribute uv{"uv", 2, false, {0, 1, 0.5f, 0.25f, 1, 0, 0.75f, 0.125f, 0.3f, 0.7f}};
  mesh.attributes = {color, velocity, id, uv};
  return mesh;
}

void expect_same_geometry(const TriangleMesh& expected, const TriangleMesh& actual, bool normals) {
  ASSERT_EQ(actual.vertices.size(), expected.vertices.size());
  for (std::size_t i = 0; i < expected.vertices.size(); ++i)
    for (int c = 0; c < 3; ++c)
      EXPECT_TRUE(same_bits(actual.vertices[i][c], expected.vertices[i][c]))
          << i << "," << c << ": " << actual.vertices[i][c] << " vs " << expected.vertices[i][c];
  EXPECT_EQ(actual.triangles, expected.triangles);
  if (normals) {
    ASSERT_EQ(actual.normals.size(), expected.normals.size());
    for (std::size_t i = 0; i < expected.normals.size(); ++i) EXPECT_EQ(actual.normals[i], expected.normals[i]) << i;
  }
}

std::size_t count_lines_starting(const std::string& text, const std::string& prefix) {
  std::size_t n = 0;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) n += line.rfind(prefix, 0) == 0;
  return n;
}

// ------------------------------------------------------------------------------------------------
// OBJ

TEST(ObjWriter, RoundTripIsBitExactWithNormals) {
  TempDir dir;
  const TriangleMesh mesh = sample_mesh();
  const std::string path = dir.file("mesh.obj");
  write_mesh(path, mesh);
  const std::string text = read_file(path);
  EXPECT_EQ(count_lines_starting(text, "v "), 5u);
  EXPECT_EQ(count_lines_starting(text, "vn "), 5u);
  EXPECT_EQ(count_lines_starting(text, "f "), 5u);
  EXPECT_NE(text.find("f 1//1 2//2 3//3\n"), std::string::npos);
  const TriangleMesh back = read_mesh(path);
  expect_same_geometry(mesh, back, true);
  EXPECT_TRUE(back.attributes.empty());  // OBJ has no attribute channel: documented, not written
}

TEST(ObjWriter, WithoutNormalsWritesPlainFaces) {
  TempDir dir;
  TriangleMesh mesh = sample_mesh();
  mesh.normals.clear();
  const std::string path = dir.file("plain.obj");
  write_mesh(path, mesh);
  const std::string text = read_file(path);
  EXPECT_EQ(count_lines_starting(text, "vn "), 0u);
  EXPECT_NE(text.find("f 1 2 3\n"), std::string::npos);
  const TriangleMesh back = read_mesh(path);
  expect_same_geometry(mesh, back, false);
  EXPECT_TRUE(back.normals.empty());
}

TEST(ObjReader, PolygonsNegativeIndicesTexturesAndColors) {
  TempDir dir;
  const std::string path = dir.file("poly.obj");
  write_file(path,
             "# comment\nmtllib x.mtl\no thing\nv 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 1 1 0 0 0 1\nv 0 1 0 1 1 1\n"
             "vt 0 0\nvn 0 0 1\ng group\ns off\nusemtl m\nf 1/1/1 2/1/1 3/1/1 4/1/1\nf -4//1 -2//1 -1//1\n");
  const TriangleMesh mesh = read_mesh(path);
  ASSERT_EQ(mesh.vertices.size(), 4u);
  EXPECT_EQ(mesh.triangles, (std::vector<Triangle>{{0, 1, 2}, {0, 2, 3}, {0, 2, 3}}));
  ASSERT_EQ(mesh.normals.size(), 4u);
  EXPECT_EQ(mesh.normals[3], (Vec3f{0, 0, 1}));
  ASSERT_EQ(mesh.attributes.size(), 1u);
  EXPECT_EQ(mesh.attributes[0].name, "color");
  EXPECT_EQ(mesh.attributes[0].values[3], 0.0f);
}

TEST(ObjReader, BadInputNamesTheLine) {
  TempDir dir;
  const std::string a = dir.file("a.obj");
  write_file(a, "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 4\n");
  expect_format_error([&] { read_mesh(a); }, {a, "line 4", "vertex index 4"});
  const std::string b = dir.file("b.obj");
  write_file(b, "v 0 0 0\nv 1 x 0\n");
  expect_format_error([&] { read_mesh(b); }, {b, "line 2", "'x'"});
  const std::string c = dir.file("c.obj");
  write_file(c, "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1//1 2//1 3//1\n");
  expect_format_error([&] { read_mesh(c); }, {c, "line 4", "normal index 1"});
  const std::string d = dir.file("d.obj");
  write_file(d, "v 0 0 nan\n");
  expect_format_error([&] { read_mesh(d); }, {d, "line 1", "finite"});
}

/// Every attribute of `mesh` is in `back` with its components and bit-exact values (and its
/// integer flag, where the format keeps it).
void expect_same_attributes(const TriangleMesh& mesh, const TriangleMesh& back, bool integer_kept) {
  ASSERT_EQ(back.attributes.size(), mesh.attributes.size());
  for (const Attribute& a : mesh.attributes) {
    SCOPED_TRACE(a.name);
    const Attribute* b = back.find(a.name);
    ASSERT_NE(b, nullptr);
    EXPECT_EQ(b->components, a.components);
    if (integer_kept) {
      EXPECT_EQ(b->integer, a.integer);
    }
    ASSERT_EQ(b->values.size(), a.values.size());
    for (std::size_t k = 0; k < a.values.size(); ++k) EXPECT_TRUE(same_bits(b->values[k], a.values[k])) << k;
  }
}

// ------------------------------------------------------------------------------------------------
// Legacy VTK

TEST(VtkMeshWriter, RoundTripIsBitExactWithAttributes) {
  TempDir dir;
  const TriangleMesh mesh = sample_mesh();
  const std::string path = dir.file("mesh.vtk");
  write_mesh(path, mesh);
  const std::string text = read_file(path);
  EXPECT_EQ(text.rfind("# vtk DataFile Version 4.2\n", 0), 0u);
  EXPECT_NE(text.find("BINARY\nDATASET POLYDATA\nPOINTS 5 float\n"), std::string::npos);
  EXPECT_NE(text.find("POLYGONS 5 20\n"), std::string::npos);
  EXPECT_NE(text.find("NORMALS normals float\n"), std::string::npos);
  EXPECT_NE(text.find("VECTORS velocity float\n"), std::string::npos);
  EXPECT_NE(text.find("SCALARS id int 1\n"), std::string::npos);
  EXPECT_NE(text.find("FIELD FieldData 1\nuv 2 5 float\n"), std::string::npos);

  const TriangleMesh back = read_mesh(path);
  expect_same_geometry(mesh, back, true);
  expect_same_attributes(mesh, back, /*integer_kept=*/true);
  // The same file is a particle file too (normals become an attribute there).
  const ParticleSet particles = read_particles(path);
  EXPECT_EQ(particles.size(), 5u);
  EXPECT_NE(particles.find("normals"), nullptr);
}

// Any format gzip-compressed (Houdini reads .bgeo.gz): the same mesh back from our readers, which
// inflate by content; the stream is gzip; nothing left beside it; the same layout checks as the
// plain file once inflated.
TEST(GzipMeshWriter, BgeoGzAndPlyGzReadBackAsThePlainFiles) {
  TempDir dir;
  const TriangleMesh mesh = sample_mesh();
  for (const char* ext : {".bgeo", ".ply", ".obj"}) {
    const std::string plain = dir.file(std::string("mesh") + ext), packed = plain + ".gz";
    write_mesh(plain, mesh);
    write_mesh(packed, mesh);
    const std::string bytes = read_file(packed);
    ASSERT_GE(bytes.size(), 2u);
    EXPECT_EQ(uint8_t(bytes[0]), 0x1f) << ext;
    EXPECT_EQ(uint8_t(bytes[1]), 0x8b) << ext;
    const TriangleMesh a = read_mesh(plain), b = read_mesh(packed);
    expect_same_geometry(a, b, !a.normals.empty());
    EXPECT_EQ(a.attributes.size(), b.attributes.size()) << ext;
    for (std::size_t i = 0; i < a.attributes.size() && i < b.attributes.size(); ++i)
      EXPECT_TRUE(a.attributes[i].values == b.attributes[i].values) << ext << " " << a.attributes[i].name;
  }
  std::size_t files = 0;
  for ([[maybe_unused]] const auto& entry : std::filesystem::directory_iterator(dir.path)) ++files;
  EXPECT_EQ(files, 6u) << "three plain files and three .gz, no temporary left";
  EXPECT_THROW(write_mesh(dir.file("mesh.xyz.gz"), mesh), InvalidParameter);
}

TEST(VtkMeshReader, AsciiV51PolygonsAndUnstructuredCells) {
  TempDir dir;
  const std::string a = dir.file("quad.vtk");
  write_file(a, "# vtk DataFile Version 5.1\nq\nASCII\nDATASET POLYDATA\nPOINTS 4 float\n0 0 0 1 0 0 1 1 0 0 1 0\n"
                "POLYGONS 2 4\nOFFSETS vtktypeint64\n0 4\nCONNECTIVITY vtktypeint64\n0 1 2 3\n");
  EXPECT_EQ(read_mesh(a).triangles, (std::vector<Triangle>{{0, 1, 2}, {0, 2, 3}}));
  const std::string b = dir.file("ugrid.vtk");
  write_file(b, "# vtk DataFile Version 4.2\nu\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 float\n"
                "0 0 0 1 0 0 1 1 0 0 1 0\nCELLS 3 11\n3 0 1 2\n1 3\n4 0 1 2 3\nCELL_TYPES 3\n5 1 10\n");
  EXPECT_EQ(read_mesh(b).triangles, (std::vector<Triangle>{{0, 1, 2}}));  // the vertex and the tetra are not surface
  const std::string c = dir.file("bad.vtk");
  write_file(c, "# vtk DataFile Version 4.2\nu\nASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 0 1 0 0 1 1 0\n"
                "POLYGONS 1 4\n3 0 1 7\n");
  expect_format_error([&] { read_mesh(c); }, {c, "cell 0", "below 3", "7"});
  const std::string d = dir.file("count.vtk");
  write_file(d, "# vtk DataFile Version 4.2\nu\nASCII\nDATASET POLYDATA\nPOINTS 3 float\n0 0 0 1 0 0 1 1 0\n"
                "POLYGONS 1 4\n9 0 1 2\n");
  expect_format_error([&] { read_mesh(d); }, {d, "line 7", "vertex count for cell 0"});
}

// ------------------------------------------------------------------------------------------------
// USDA

// The text between `<key> = [` and the matching `]`.
std::string usda_array(const std::string& text, const std::string& key) {
  const std::size_t at = text.find(key + " = [");
  if (at == std::string::npos) return {};
  const std::size_t begin = at + key.size() + 4;
  return text.substr(begin, text.find(']', begin) - begin);
}

std::vector<float> numbers(const std::string& text) {
  std::vector<float> out;
  std::string token;
  for (const char c : text + ",") {
    if (c == '(' || c == ')' || c == ' ' || c == '\n') continue;
    if (c == ',') {
      if (!token.empty()) out.push_back(std::strtof(token.c_str(), nullptr));
      token.clear();
    } else {
      token.push_back(c);
    }
  }
  return out;
}

TEST(UsdaWriter, TextStructureIsAUsdGeomMesh) {
  TempDir dir;
  TriangleMesh mesh = sample_mesh();
  mesh.attributes.push_back(Attribute{"2 weird-name", 1, false, {1, 2, 3, 4, 5}});
  const std::string path = dir.file("mesh.usda");
  write_mesh(path, mesh);
  const std::string text = read_file(path);
  EXPECT_EQ(text.rfind("#usda 1.0\n", 0), 0u);
  EXPECT_EQ(std::count(text.begin(), text.end(), '{'), std::count(text.begin(), text.end(), '}'));
  EXPECT_EQ(std::count(text.begin(), text.end(), '['), std::count(text.begin(), text.end(), ']'));
  EXPECT_EQ(std::count(text.begin(), text.end(), '('), std::count(text.begin(), text.end(), ')'));
  for (const char* required :
       {"upAxis = \"Y\"", "def Xform \"meniscus\"", "def Mesh \"surface\"", "int[] faceVertexCounts = [",
        "int[] faceVertexIndices = [", "point3f[] points = [", "normal3f[] normals = [",
        "color3f[] primvars:displayColor = [", "float3[] primvars:velocity = [", "int[] primvars:id = [",
        "float[] primvars:uv = [", "elementSize = 2", "float[] primvars:_2_weird_name = [",
        "uniform token orientation = \"rightHanded\"", "uniform token subdivisionScheme = \"none\"",
        "float3[] extent = [(-1.5, -0.2, -7), (1.0000001, 123456.79, 3.4e+30)]"})
    EXPECT_NE(text.find(required), std::string::npos) << required;
  EXPECT_EQ(count_lines_starting(text, "            interpolation = \"vertex\""), 6u);  // normals + 5 primvars

  const std::vector<float> counts = numbers(usda_array(text, "faceVertexCounts"));
  EXPECT_EQ(counts, std::vector<float>(mesh.triangles.size(), 3.0f));
  const std::vector<float> indices = numbers(usda_array(text, "faceVertexIndices"));
  ASSERT_EQ(indices.size(), 3 * mesh.triangles.size());
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
    for (std::size_t k = 0; k < 3; ++k) EXPECT_EQ(indices[3 * t + k], float(mesh.triangles[t][k]));
  const std::vector<float> points = numbers(usda_array(text, "point3f[] points"));
  ASSERT_EQ(points.size(), 3 * mesh.vertices.size());
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i)
    for (int c = 0; c < 3; ++c) EXPECT_TRUE(same_bits(points[3 * i + std::size_t(c)], mesh.vertices[i][c])) << i;
  EXPECT_EQ(numbers(usda_array(text, "normal3f[] normals")).size(), 3 * mesh.normals.size());
  EXPECT_EQ(numbers(usda_array(text, "primvars:displayColor")).size(), 15u);
  EXPECT_EQ(numbers(usda_array(text, "int[] primvars:id")), (std::vector<float>{0, 7, -3, 1000000, 42}));
}

TEST(UsdaWriter, CollidingNamesAndEmptyMesh) {
  TempDir dir;
  TriangleMesh mesh = sample_mesh();
  mesh.attributes.push_back(Attribute{"u-v", 1, false, {1, 2, 3, 4, 5}});
  mesh.attributes.push_back(Attribute{"u_v", 1, false, {1, 2, 3, 4, 5}});
  const std::string path = dir.file("collide.usda");
  EXPECT_THROW(write_mesh(path, mesh), InvalidParameter);
  EXPECT_FALSE(std::filesystem::exists(path));
  const std::string empty = dir.file("empty.usda");
  write_mesh(empty, TriangleMesh{});
  const std::string text = read_file(empty);
  EXPECT_NE(text.find("int[] faceVertexCounts = []"), std::string::npos);
  EXPECT_NE(text.find("point3f[] points = []"), std::string::npos);
  EXPECT_EQ(text.find("extent"), std::string::npos);
}

TEST(MeshRoundTrip, WritersRefuseInconsistentMeshesBeforeCreatingTheFile) {
  TempDir dir;
  for (const char* ext : {".obj", ".vtk", ".usda"}) {
    SCOPED_TRACE(ext);
    TriangleMesh bad_index = sample_mesh();
    bad_index.triangles.push_back({0, 1, 5});
    TriangleMesh bad_normals = sample_mesh();
    bad_normals.normals.pop_back();
    TriangleMesh bad_attribute = sample_mesh();
    bad_attribute.attributes[1].values.pop_back();
    for (const TriangleMesh* m : {&bad_index, &bad_normals, &bad_attribute}) {
      const std::string path = dir.file(std::string("bad") + ext);
      EXPECT_THROW(write_mesh(path, *m), InvalidParameter);
      EXPECT_FALSE(std::filesystem::exists(path));
    }
  }
  TriangleMesh spaced = sample_mesh();
  spaced.attributes[2].name = "my id";
  EXPECT_THROW(write_mesh(dir.file("spaced.vtk"), spaced), InvalidParameter);
}

TEST(MeshRoundTrip, TruncatedVtkMeshIsAFormatError) {
  TempDir dir;
  const std::string path = dir.file("m.vtk");
  write_mesh(path, sample_mesh());
  const std::string full = read_file(path);
  for (std::size_t n = 0; n < full.size(); n += 3) {
    write_file(path, full.substr(0, n));
    try {
      const TriangleMesh m = read_mesh(path);
      EXPECT_EQ(m.vertices.size(), 5u) << n;  // only a cut inside the trailing point data can still parse
    } catch (const FormatError&) {
    }
  }
}

// ------------------------------------------------------------------------------------------------
// meshio (Debian python3-meshio), an independent reader of every format we write

bool have_meshio() { return std::system("/usr/bin/python3 -c 'import meshio' >/dev/null 2>&1") == 0; }

// Writes the sample mesh as `ext`, reads it with meshio, compares counts, positions (bit for bit:
// our text formats print the shortest round-trip decimal) and triangles. Returns false when
// meshio refuses legacy POLYDATA (meshio < 5.1), so the caller can skip visibly.
const char* const kMeshioScript =
    "import sys, meshio\n"
    "m = meshio.read(sys.argv[1])\n"
    "tris = sum(len(c.data) for c in m.cells if c.type == 'triangle')\n"
    "print(len(m.points), tris)\n"
    "for p in m.points: print(' '.join(repr(float(v)) for v in p[:3]))\n"
    "for c in m.cells:\n"
    "    if c.type == 'triangle':\n"
    "        for t in c.data: print('t', ' '.join(str(int(i)) for i in t))\n";

// The same listing from VTK's own legacy reader (Debian's python3-vtk9).
const char* const kVtkScript =
    "import sys, vtk\n"
    "r = vtk.vtkPolyDataReader(); r.SetFileName(sys.argv[1]); r.Update()\n"
    "pd = r.GetOutput(); polys = pd.GetPolys()\n"
    "print(pd.GetNumberOfPoints(), polys.GetNumberOfCells())\n"
    "for i in range(pd.GetNumberOfPoints()): print(' '.join(repr(float(v)) for v in pd.GetPoint(i)))\n"
    "ids = vtk.vtkIdList(); polys.InitTraversal()\n"
    "while polys.GetNextCell(ids): print('t', ' '.join(str(ids.GetId(k)) for k in range(ids.GetNumberOfIds())))\n"
    "n = pd.GetPointData().GetNormals()\n"
    "print('normals', 0 if n is None else n.GetNumberOfTuples())\n";

/// Writes the sample mesh as `ext`, lists it with an independent Python reader (`script`) and
/// compares counts, positions (bit-exact) and triangles. False when the reader refuses POLYDATA.
bool check_with_python(const std::string& ext, const char* script_text) {
  TempDir dir;
  const TriangleMesh mesh = sample_mesh();
  const std::string script = dir.file("count.py");
  write_file(script, script_text);
  const std::string path = dir.file("mesh" + ext);
  write_mesh(path, mesh);
  std::string output;
  const int status = test::run_command("/usr/bin/python3 " + script + " " + path + " 2>&1", &output);
  if (status != 0 && output.find("not POLYDATA") != std::string::npos) return false;
  EXPECT_EQ(status, 0) << output;
  std::istringstream in(output);
  std::size_t points = 0, triangles = 0;
  in >> points >> triangles;
  EXPECT_EQ(points, mesh.vertices.size()) << output;
  EXPECT_EQ(triangles, mesh.triangles.size()) << output;
  if (points != mesh.vertices.size() || triangles != mesh.triangles.size()) return true;
  for (std::size_t i = 0; i < points; ++i)
    for (int c = 0; c < 3; ++c) {
      double v = 0;
      in >> v;
      EXPECT_TRUE(same_bits(float(v), mesh.vertices[i][c])) << i << "," << c << ": " << v;
    }
  for (std::size_t t = 0; t < triangles; ++t) {
    std::string tag;
    uint32_t a = 0, b = 0, c = 0;
    in >> tag >> a >> b >> c;
    EXPECT_EQ((Triangle{a, b, c}), mesh.triangles[t]) << t;
  }
  return true;
}

bool check_with_meshio(const std::string& ext) { return check_with_python(ext, kMeshioScript); }

// ------------------------------------------------------------------------------------------------
// VTK XML PolyData (.vtp) and the .pvtp index of pieces

TEST(VtpMeshWriter, RoundTripIsBitExactWithAttributes) {
  TempDir dir;
  const TriangleMesh mesh = sample_mesh();
  const std::string path = dir.file("mesh.vtp");
  write_mesh(path, mesh);
  const std::string text = read_file(path);
  EXPECT_EQ(text.rfind("<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\"", 0), 0u);
  EXPECT_NE(text.find("<Piece NumberOfPoints=\"5\" NumberOfPolys=\"5\">"), std::string::npos);
  EXPECT_NE(text.find("<PointData Normals=\"Normals\">"), std::string::npos);
  const TriangleMesh back = read_mesh(path);
  expect_same_geometry(mesh, back, true);
  expect_same_attributes(mesh, back, /*integer_kept=*/false);  // .vtp writes every attribute as Float32
  // A cut file is refused.
  write_file(dir.file("cut.vtp"), text.substr(0, text.size() - 200));
  EXPECT_THROW(read_mesh(dir.file("cut.vtp")), FormatError);
}

#define MENISCUS_REQUIRE_MESHIO()                                                                          \
  if (!have_meshio())                                                                                      \
  GTEST_SKIP() << "SKIPPED: /usr/bin/python3 cannot import meshio (apt-get install python3-meshio, see " \
                  "tools/install-deps.sh)"

TEST(MeshRoundTrip, MeshioReadsPly) {
  MENISCUS_REQUIRE_MESHIO();
  EXPECT_TRUE(check_with_meshio(".ply"));
}

TEST(MeshRoundTrip, MeshioReadsObj) {
  MENISCUS_REQUIRE_MESHIO();
  EXPECT_TRUE(check_with_meshio(".obj"));
}

bool have_vtk_python() { return test::run_command("/usr/bin/python3 -c 'import vtk' 2>/dev/null") == 0; }

TEST(MeshRoundTrip, VtkItselfReadsOurVtk) {
  if (!have_vtk_python())
    GTEST_SKIP() << "SKIPPED: /usr/bin/python3 cannot import vtk (apt-get install python3-vtk9, see tools/install-deps.sh)";
  EXPECT_TRUE(check_with_python(".vtk", kVtkScript));
}

const char* const kVtpScript =
    "import sys, vtk\n"
    "r = vtk.vtkXMLPolyDataReader(); r.SetFileName(sys.argv[1]); r.Update()\n"
    "pd = r.GetOutput(); polys = pd.GetPolys()\n"
    "print(pd.GetNumberOfPoints(), polys.GetNumberOfCells())\n"
    "for i in range(pd.GetNumberOfPoints()): print(' '.join(repr(float(v)) for v in pd.GetPoint(i)))\n"
    "ids = vtk.vtkIdList(); polys.InitTraversal()\n"
    "while polys.GetNextCell(ids): print('t', ' '.join(str(ids.GetId(k)) for k in range(ids.GetNumberOfIds())))\n"
    "n = pd.GetPointData().GetNormals()\n"
    "print('normals', 0 if n is None else n.GetNumberOfTuples())\n";

TEST(MeshRoundTrip, VtkItselfReadsOurVtp) {
  if (!have_vtk_python())
    GTEST_SKIP() << "SKIPPED: /usr/bin/python3 cannot import vtk (apt-get install python3-vtk9, see tools/install-deps.sh)";
  EXPECT_TRUE(check_with_python(".vtp", kVtpScript));
}

}  // namespace
}  // namespace meniscus
