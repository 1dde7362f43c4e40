#include "support/test_support.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iterator>

namespace meniscus::test {

ParticleSet lattice_block(int nx, int ny, int nz, float d, float jitter, uint32_t seed, Vec3f origin) {
  ParticleSet ps;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-jitter * d, jitter * d);
  ps.positions.reserve(std::size_t(nx) * ny * nz);
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        Vec3f p{origin.x + float(i) * d, origin.y + float(j) * d, origin.z + float(k) * d};
        if (jitter > 0) p += Vec3f{u(rng), u(rng), u(rng)};
        ps.positions.push_back(p);
      }
  return ps;
}

ParticleSet wide_splash(std::size_t count, float d) {
  const int depth = std::max(2, int(std::lround(std::cbrt(double(count) * 0.8 / 64.0))));
  ParticleSet ps = lattice_block(16 * depth, 4 * depth, depth, d, 0.1f, 7);
  std::mt19937 rng(11);
  const float top = float(depth - 1) * d;
  std::uniform_real_distribution<float> ux(2 * d, float(16 * depth - 3) * d), uy(2 * d, float(4 * depth - 3) * d),
      uz(top + 3 * d, top + float(4 * depth) * d);
  std::uniform_int_distribution<int> size(1, 30);
  std::normal_distribution<float> jitter(0.0f, 0.05f * d);
  while (ps.positions.size() < count) {
    const Vec3f c{ux(rng), uy(rng), uz(rng)};
    const int m = std::min<int>(size(rng), int(count - ps.positions.size()));
    const int r = int(std::ceil(std::cbrt(3.0 * m / (4.0 * 3.14159265358979)) + 0.5));
    int placed = 0;
    for (int k = -r; k <= r && placed < m; ++k)
      for (int j = -r; j <= r && placed < m; ++j)
        for (int i = -r; i <= r && placed < m; ++i, ++placed)
          ps.positions.push_back(c + Vec3f{float(i) * d + jitter(rng), float(j) * d + jitter(rng), float(k) * d + jitter(rng)});
  }
  return ps;
}

ParticleSet thin_sheet(int n, float gap, float d, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> jitter(-0.2f * d, 0.2f * d);
  std::vector<float> at(std::size_t(n), 0.0f);
  for (int i = 1; i < n; ++i) at[std::size_t(i)] = at[std::size_t(i - 1)] + (i % 4 == 0 ? gap : d);
  ParticleSet ps;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) ps.positions.push_back({at[std::size_t(i)] + jitter(rng), at[std::size_t(j)] + jitter(rng), 0});
  return ps;
}

ParticleSet lattice_ball(float R, float d, Vec3f center) {
  ParticleSet ps;
  const int n = int(R / d) + 1;
  for (int k = -n; k <= n; ++k)
    for (int j = -n; j <= n; ++j)
      for (int i = -n; i <= n; ++i) {
        const Vec3f q{float(i) * d, float(j) * d, float(k) * d};
        if (length(q) <= R) ps.positions.push_back(center + q);
      }
  return ps;
}

TriangleMesh icosphere(int subdivisions, float radius, Vec3f center) {
  const float phi = (1.0f + std::sqrt(5.0f)) / 2.0f;
  std::vector<Vec3f> unit = {{-1, phi, 0},  {1, phi, 0},  {-1, -phi, 0}, {1, -phi, 0}, {0, -1, phi},  {0, 1, phi},
                             {0, -1, -phi}, {0, 1, -phi}, {phi, 0, -1},  {phi, 0, 1},  {-phi, 0, -1}, {-phi, 0, 1}};
  for (Vec3f& v : unit) v = normalized(v);
  std::vector<Triangle> faces = {{0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                                 {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
                                 {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  for (int level = 0; level < subdivisions; ++level) {
    std::map<std::pair<uint32_t, uint32_t>, uint32_t> midpoints;
    const auto midpoint = [&](uint32_t a, uint32_t b) {
      const auto key = std::minmax(a, b);
      const auto [it, inserted] = midpoints.try_emplace({key.first, key.second}, uint32_t(unit.size()));
      if (inserted) unit.push_back(normalized(unit[a] + unit[b]));
      return it->second;
    };
    std::vector<Triangle> finer;
    finer.reserve(faces.size() * 4);
    for (const Triangle& t : faces) {
      const uint32_t ab = midpoint(t[0], t[1]), bc = midpoint(t[1], t[2]), ca = midpoint(t[2], t[0]);
      finer.push_back({t[0], ab, ca});
      finer.push_back({t[1], bc, ab});
      finer.push_back({t[2], ca, bc});
      finer.push_back({ab, bc, ca});
    }
    faces = std::move(finer);
  }
  // Make the winding outward-facing whatever the table's convention.
  for (Triangle& t : faces)
    if (dot(cross(unit[t[1]] - unit[t[0]], unit[t[2]] - unit[t[0]]), unit[t[0]] + unit[t[1]] + unit[t[2]]) < 0)
      std::swap(t[1], t[2]);
  TriangleMesh mesh;
  for (const Vec3f& u : unit) mesh.vertices.push_back(center + u * radius);
  mesh.normals = unit;
  mesh.triangles = std::move(faces);
  return mesh;
}

TriangleMesh grid_mesh(uint32_t nx, uint32_t ny, const std::function<float(uint32_t, uint32_t)>& height) {
  TriangleMesh m;
  for (uint32_t y = 0; y < ny; ++y)
    for (uint32_t x = 0; x < nx; ++x) m.vertices.push_back({float(x), float(y), height(x, y)});
  for (uint32_t y = 0; y + 1 < ny; ++y)
    for (uint32_t x = 0; x + 1 < nx; ++x) {
      const uint32_t v = y * nx + x;
      m.triangles.push_back({v, v + 1, v + nx + 1});
      m.triangles.push_back({v, v + nx + 1, v + nx});
    }
  return m;
}

ParticleSet shell_ball(float R, float d, Vec3f center) {
  ParticleSet ps;
  ps.positions.push_back(center);
  const double golden = 3.14159265358979323846 * (3.0 - std::sqrt(5.0));
  for (float r = R; r > 0.5f * d; r -= d) {
    // Hexagonal packing density: one particle per (√3/2)·d² of area.
    const int n = std::max(4, int(std::lround(4.0 * 3.14159265358979323846 * r * r / (0.8660254 * d * d))));
    for (int i = 0; i < n; ++i) {
      const double z = 1.0 - 2.0 * (i + 0.5) / n, rho = std::sqrt(1.0 - z * z), phi = golden * i;
      ps.positions.push_back(center + Vec3f{float(rho * std::cos(phi)), float(rho * std::sin(phi)), float(z)} * r);
    }
  }
  return ps;
}

TempDir::TempDir() {
  static std::mt19937_64 rng{std::random_device{}()};
  for (;;) {
    path = std::filesystem::temp_directory_path() / ("meniscus-test-" + std::to_string(rng()));
    if (std::filesystem::create_directory(path)) break;
  }
}
TempDir::~TempDir() {
  std::error_code ec;
  std::filesystem::remove_all(path, ec);
}

int run_command(const std::string& command, std::string* output) {
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  if (!pipe) return -1;
  std::array<char, 4096> buffer;
  std::string text;
  std::size_t n;
  while ((n = fread(buffer.data(), 1, buffer.size(), pipe)) > 0) text.append(buffer.data(), n);
  const int status = pclose(pipe);
  if (output) *output = text;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

Measured run_measured(const std::string& command) {
  Measured m;
  char out_name[] = "/tmp/meniscus-run-XXXXXX";
  const int out = mkstemp(out_name);
  if (out < 0) return m;
  const auto t0 = std::chrono::steady_clock::now();
  const pid_t pid = fork();
  if (pid == 0) {
    dup2(out, 1);
    dup2(out, 2);
    execl("/bin/sh", "sh", "-c", command.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  int status = 0;
  rusage usage{};
  while (pid > 0 && wait4(pid, &status, 0, &usage) < 0 && errno == EINTR) {
  }
  m.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  m.peak_bytes = double(usage.ru_maxrss) * 1024;
  m.status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  m.signal = WIFSIGNALED(status) ? WTERMSIG(status) : 0;
  std::ifstream in(out_name, std::ios::binary);
  m.output.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  close(out);
  unlink(out_name);
  return m;
}

std::size_t count_before(std::string_view name, std::string_view suffix) {
  for (std::size_t at = name.find(suffix); at != std::string_view::npos; at = name.find(suffix, at + 1)) {
    std::size_t begin = at;
    while (begin > 0 && name[begin - 1] >= '0' && name[begin - 1] <= '9') --begin;
    if (begin == at || begin == 0 || name[begin - 1] != '_') continue;
    std::size_t n = 0;
    for (std::size_t k = begin; k < at; ++k) n = n * 10 + std::size_t(name[k] - '0');
    return n;
  }
  return 0;
}

bool large_for_sanitizers(std::string_view frame_name) {
  return kSanitized && count_before(frame_name, "_particles") >= 5000;
}

std::string data_file(const std::string& name) { return std::string(MENISCUS_TEST_DATA) + "/" + name; }
std::string cli() { return MENISCUS_CLI; }

std::vector<std::string> real_frames() {
  std::vector<std::string> out;
  for (const auto& e : std::filesystem::directory_iterator(data_file("ply")))
    if (e.path().extension() == ".ply") out.push_back(e.path().filename().string());
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace meniscus::test
