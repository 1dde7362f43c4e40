// meniscus tests — mesh checksums and their stored values (checksums.hpp).
#include "support/checksums.hpp"

#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <mutex>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "support/test_support.hpp"

namespace meniscus::test {

namespace {

struct Fnv {
  uint64_t h = 1469598103934665603ull;
  void bytes(const void* data, std::size_t n) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 1099511628211ull;
  }
  template <class T>
  void array(const std::vector<T>& v) {
    const uint64_t n = v.size();
    bytes(&n, sizeof n);
    if (!v.empty()) bytes(v.data(), v.size() * sizeof(T));
  }
};

std::string path() { return data_file("checksums.json"); }

/// The stored checksums, read once; written back at exit when recording.
struct Store {
  std::mutex mutex;
  nlohmann::ordered_json json;
  bool dirty = false;
  Store() {
    std::ifstream in(path());
    if (in) json = nlohmann::ordered_json::parse(in);
    if (!json.is_object()) json = nlohmann::ordered_json::object();
  }
  ~Store() {
    if (!dirty) return;
    std::ofstream out(path());
    out << json.dump(2) << "\n";
  }
};

Store& store() {
  static Store s;
  return s;
}

}  // namespace

uint64_t mesh_checksum(const TriangleMesh& mesh) {
  Fnv f;
  f.array(mesh.vertices);
  f.array(mesh.triangles);
  f.array(mesh.normals);
  for (const Attribute& a : mesh.attributes) {
    f.bytes(a.name.data(), a.name.size());
    f.bytes(&a.components, sizeof a.components);
    f.array(a.values);
  }
  return f.h;
}

std::vector<ChecksumVariant> checksum_variants() {
  std::vector<ChecksumVariant> v;
  v.push_back({"default", Params{}, false});
  Params aniso;
  aniso.field = FieldMethod::anisotropic;
  v.push_back({"anisotropic", aniso, false});
  Params cubes;
  cubes.extract = Extractor::cubes;
  cubes.solver = SmoothingSolver::jacobi;
  v.push_back({"cubes-jacobi", cubes, false});
  Params sph;
  sph.field = FieldMethod::sph;
  sph.steps_b = 4;
  v.push_back({"sph", sph, true});
  Params post;
  post.min_particles = 3;
  post.decimate = 0.02;
  post.erode = 0;  // (clip boxes depend on the frame: tests/e2e/test_clip_box.cpp)
  v.push_back({"strays-decimate", post, false});
  return v;
}

uint64_t stored_checksum(const std::string& key) {
  Store& s = store();
  std::lock_guard lock(s.mutex);
  if (!s.json.contains(key)) return 0;
  return std::stoull(s.json[key].get<std::string>(), nullptr, 16);
}

void record_checksum(const std::string& key, uint64_t value) {
  Store& s = store();
  std::lock_guard lock(s.mutex);
  s.json[key] = fmt::format("{:016x}", value);
  s.dirty = true;
}

bool writing_checksums() {
  const char* w = std::getenv("MENISCUS_WRITE_CHECKSUMS");
  return w && std::strcmp(w, "1") == 0;
}

void expect_stored_checksum(const std::string& key, const TriangleMesh& mesh) {
  const uint64_t sum = mesh_checksum(mesh);
  if (writing_checksums()) {
    record_checksum(key, sum);
    return;
  }
  const uint64_t stored = stored_checksum(key);
  ASSERT_NE(stored, 0u) << "no stored checksum for " << key;
  EXPECT_EQ(fmt::format("{:016x}", sum), fmt::format("{:016x}", stored))
      << key << ": the mesh is not the stored one (" << mesh.vertices.size() << " vertices, " << mesh.triangles.size()
      << " triangles)";
}

}  // namespace meniscus::test
