// meniscus — small fixed-size vector math shared by the CPU and CUDA backends.
#pragma once

#include <cmath>
#include <cstdint>

#if defined(__CUDACC__)
#define MENISCUS_HD __host__ __device__
#else
#define MENISCUS_HD
#endif

namespace meniscus {

/// A 3-vector of float, laid out as three consecutive floats (arrays of Vec3f are
/// arrays of xyz triples, so they can be handed to NumPy and file writers as is).
struct Vec3f {
  float x = 0, y = 0, z = 0;

  MENISCUS_HD constexpr float operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
  MENISCUS_HD constexpr float& operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }
};

MENISCUS_HD constexpr Vec3f operator+(Vec3f a, Vec3f b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
MENISCUS_HD constexpr Vec3f operator-(Vec3f a, Vec3f b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
MENISCUS_HD constexpr Vec3f operator-(Vec3f a) { return {-a.x, -a.y, -a.z}; }
MENISCUS_HD constexpr Vec3f operator*(Vec3f a, float s) { return {a.x * s, a.y * s, a.z * s}; }
MENISCUS_HD constexpr Vec3f operator*(float s, Vec3f a) { return {a.x * s, a.y * s, a.z * s}; }
MENISCUS_HD constexpr Vec3f operator/(Vec3f a, float s) { return {a.x / s, a.y / s, a.z / s}; }
MENISCUS_HD constexpr Vec3f& operator+=(Vec3f& a, Vec3f b) { a = a + b; return a; }
MENISCUS_HD constexpr Vec3f& operator-=(Vec3f& a, Vec3f b) { a = a - b; return a; }
MENISCUS_HD constexpr Vec3f& operator*=(Vec3f& a, float s) { a = a * s; return a; }
MENISCUS_HD constexpr bool operator==(Vec3f a, Vec3f b) { return a.x == b.x && a.y == b.y && a.z == b.z; }

MENISCUS_HD constexpr float dot(Vec3f a, Vec3f b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
MENISCUS_HD constexpr Vec3f cross(Vec3f a, Vec3f b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
MENISCUS_HD constexpr float length2(Vec3f a) { return dot(a, a); }
MENISCUS_HD inline float length(Vec3f a) { return std::sqrt(dot(a, a)); }
MENISCUS_HD inline Vec3f normalized(Vec3f a) {
  const float l = length(a);
  return l > 0 ? a / l : Vec3f{0, 0, 0};
}
MENISCUS_HD constexpr Vec3f min(Vec3f a, Vec3f b) {
  return {a.x < b.x ? a.x : b.x, a.y < b.y ? a.y : b.y, a.z < b.z ? a.z : b.z};
}
MENISCUS_HD constexpr Vec3f max(Vec3f a, Vec3f b) {
  return {a.x > b.x ? a.x : b.x, a.y > b.y ? a.y : b.y, a.z > b.z ? a.z : b.z};
}

/// Integer lattice coordinates (cells of a grid).
struct Vec3i {
  int32_t x = 0, y = 0, z = 0;
  MENISCUS_HD constexpr int32_t operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
};
MENISCUS_HD constexpr Vec3i operator+(Vec3i a, Vec3i b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
MENISCUS_HD constexpr Vec3i operator-(Vec3i a, Vec3i b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
MENISCUS_HD constexpr bool operator==(Vec3i a, Vec3i b) { return a.x == b.x && a.y == b.y && a.z == b.z; }

}  // namespace meniscus
