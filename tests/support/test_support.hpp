// meniscus tests — synthetic particle sets and small helpers shared by the tests.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "meniscus/mesh.hpp"
#include "meniscus/particles.hpp"

namespace meniscus::test {

/// True in the AddressSanitizer build (gcc's or clang's). There the code runs several times slower,
/// so the tests that repeat one path over every real frame or a large scene run a subset of their
/// inputs there (large_for_sanitizers; each test names its subset); the Release run covers all.
#if defined(__SANITIZE_ADDRESS__)
inline constexpr bool kSanitized = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
inline constexpr bool kSanitized = true;
#else
inline constexpr bool kSanitized = false;
#endif
#else
inline constexpr bool kSanitized = false;
#endif

/// nx × ny × nz particles on a cubic lattice of spacing d starting at `origin`; each coordinate
/// displaced uniformly in [-jitter·d, +jitter·d] (deterministic for a given seed).
ParticleSet lattice_block(int nx, int ny, int nz, float d, float jitter = 0, uint32_t seed = 1,
                          Vec3f origin = {0, 0, 0});

/// Particles of a lattice of spacing d that lie inside a ball of radius R around `center`.
ParticleSet lattice_ball(float R, float d, Vec3f center = {0, 0, 0});
/// A sheet one particle thick in the plane z = 0: n × n particles, in-plane spacing d with every
/// fourth gap widened to `gap`, each coordinate in the plane jittered by ±0.2 d (thin water: the
/// pinholes' and the handles' tests).
ParticleSet thin_sheet(int n, float gap, float d, uint32_t seed = 7);

/// A wide, shallow splash of about `count` particles, as shots are: a pool 16 : 4 : 1 (x long)
/// on a jittered lattice with 80 % of the particles, droplets of 1-30 particles over it up to
/// four pool depths high. Same count + d → same particles.
ParticleSet wide_splash(std::size_t count, float d = 0.01f);

/// A ball of concentric spherical shells of particles, the outermost at exactly radius R, each
/// shell a Fibonacci lattice with neighbour distance ≈ d, shells d apart.
ParticleSet shell_ball(float R, float d, Vec3f center = {0, 0, 0});

/// A height field of nx × ny vertices (x, y, height(x, y)) in row order, two triangles per quad
/// in row order, split on the same diagonal: a mesh of known size in spatial order.
TriangleMesh grid_mesh(uint32_t nx, uint32_t ny, const std::function<float(uint32_t, uint32_t)>& height);

/// A closed icosphere: the icosahedron subdivided `subdivisions` times (20·4^subdivisions
/// triangles) on the sphere of `radius` around `center`, triangles counter-clockwise from
/// outside, with exact sphere normals.
TriangleMesh icosphere(int subdivisions, float radius = 1.0f, Vec3f center = {0, 0, 0});

/// A fresh empty directory under the system temp dir, removed by the destructor.
struct TempDir {
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  std::filesystem::path path;
  std::string file(const std::string& name) const { return (path / name).string(); }
};

/// Runs a shell command, returns its exit status; stdout+stderr are captured into `output`.
int run_command(const std::string& command, std::string* output = nullptr);

/// What a command did: its exit status (-1 killed by a signal, whose number is `signal`), its
/// stdout+stderr, its peak resident memory (the process that `exec`s last in the command) and
/// its wall time.
struct Measured {
  int status = -1, signal = 0;
  std::string output;
  double peak_bytes = 0, seconds = 0;
};
/// Runs `command` through /bin/sh -c, waits for it with wait4 and reads its rusage: a command
/// that ends with `exec prog …` measures prog.
Measured run_measured(const std::string& command);

/// N where `name` holds "_<N>" + `suffix` (the bundled frames carry their particle count in their
/// names: "dam_break_frame_23_24389_particles.ply"); 0 when it holds none.
std::size_t count_before(std::string_view name, std::string_view suffix);

/// Under the sanitizers (kSanitized), whether a bundled real frame is one of the large ones (5,000
/// particles or more, by its name) that the tests looping over frames leave to the Release run:
/// the frames under it (4,732 particles of a double dam break down to 250) take the same paths.
bool large_for_sanitizers(std::string_view frame_name);

/// Path of a bundled test data file (tests/data/NAME).
std::string data_file(const std::string& name);
/// The names of the bundled real frames (tests/data/ply/*.ply), sorted.
std::vector<std::string> real_frames();
/// Path of the meniscus CLI built with the tests.
std::string cli();

}  // namespace meniscus::test
