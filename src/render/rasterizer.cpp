// meniscus — tile-binned, z-buffered software rasterizer for mesh previews: integer edge functions
// (Pineda 1988, "A Parallel Algorithm for Polygon Rasterization") with the Direct3D top-left
// fill rule, a visibility buffer shaded once per sample (Burns & Hunt 2013), 2×2 supersampling.
#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include "common/for_each.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/render.hpp"

namespace meniscus {

namespace {

constexpr int kSupersample = 2;  // 2×2 samples per output pixel, box-filtered in linear light
// Tiles are small enough to balance the load over threads and large enough that most triangles
// of a dense mesh touch exactly one, so binning costs about one list entry per triangle.
constexpr int kTileSize = 64;
// Vertices are snapped to 1/256 of a sample so that edge functions are exact integers: two
// triangles sharing an edge then agree bit for bit on which samples are inside, so the
// top-left rule leaves neither cracks nor double hits.
constexpr int64_t kSubpixel = 256;
constexpr int64_t kHalfSample = kSubpixel / 2;
// Vertices projecting farther than this (in samples) are dropped with their triangles. It keeps
// snapped coordinates in int32 and edge products (< 2^58) in int64; auto-framing never puts a
// vertex of the mesh outside the image, so only stray particles ever reach it.
constexpr float kGuardBand = float(1 << 20);
constexpr uint32_t kNoPrimitive = 0xFFFFFFFFu;
constexpr uint32_t kParticleBit = 0x80000000u;  // visibility-buffer ids: particles vs triangles
constexpr int kMaxImageSide = 8192;

// ---------------------------------------------------------------------------------------------
// Colour helpers. Lighting happens in linear light; inputs and output are sRGB.

float clamp01(float c) { return c >= 0.0f ? (c <= 1.0f ? c : 1.0f) : 0.0f; }  // NaN → 0

float srgb_to_linear(float c) {
  c = clamp01(c);
  return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
}

Vec3f srgb_to_linear(Vec3f c) { return {srgb_to_linear(c.x), srgb_to_linear(c.y), srgb_to_linear(c.z)}; }

/// The 8-bit sRGB code of a linear value, rounded to nearest: a binary search over the linear
/// values where the code steps up, exact and much cheaper than a pow() per channel.
uint8_t to_byte(float linear) {
  static const std::array<float, 255> steps = [] {
    std::array<float, 255> s{};
    for (std::size_t k = 0; k < s.size(); ++k) s[k] = srgb_to_linear((float(k) + 0.5f) / 255.0f);
    return s;
  }();
  return static_cast<uint8_t>(std::upper_bound(steps.begin(), steps.end(), linear) - steps.begin());
}

/// x^N by repeated squaring: the highlight exponents are fixed, and this is several times
/// cheaper than std::pow in the per-sample shading loop.
template <unsigned N>
float power(float x) {
  if constexpr (N == 0) {
    return 1.0f;
  } else {
    const float half = power<N / 2>(x);
    return N % 2 ? half * half * x : half * half;
  }
}

Vec3f mul(Vec3f a, Vec3f b) { return {a.x * b.x, a.y * b.y, a.z * b.z}; }
Vec3f lerp(Vec3f a, Vec3f b, float t) { return a + (b - a) * t; }

// A soft shoulder instead of a hard clip, so highlights roll off to white instead of banding.
float tone(float c) { return c <= 0.8f ? c : 0.8f + 0.2f * (1.0f - std::exp(-(c - 0.8f) / 0.2f)); }
Vec3f tone(Vec3f c) { return {tone(c.x), tone(c.y), tone(c.z)}; }

// Viridis (van der Walt & Smith 2015, CC0) sampled at 9 points: perceptually uniform and
// readable by colour-blind viewers. sRGB bytes.
Vec3f viridis(float t) {
  static constexpr std::array<std::array<float, 3>, 9> kStops = {{{68, 1, 84},
                                                                  {71, 45, 123},
                                                                  {59, 82, 139},
                                                                  {44, 114, 142},
                                                                  {33, 145, 140},
                                                                  {40, 174, 128},
                                                                  {93, 200, 99},
                                                                  {170, 220, 50},
                                                                  {253, 231, 37}}};
  const float s = clamp01(t) * float(kStops.size() - 1);
  const auto i = std::min(static_cast<std::size_t>(s), kStops.size() - 2);
  const float f = s - float(i);
  const Vec3f a{kStops[i][0], kStops[i][1], kStops[i][2]};
  const Vec3f b{kStops[i + 1][0], kStops[i + 1][1], kStops[i + 1][2]};
  return lerp(a, b, f) / 255.0f;
}

// ---------------------------------------------------------------------------------------------
// Geometry helpers.

bool is_finite(Vec3f p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z); }

Vec3f safe_normalized(Vec3f v, Vec3f fallback) {
  const float l = length(v);
  return l > 0.0f && std::isfinite(l) ? v / l : fallback;
}

struct Box {
  Vec3f lo{std::numeric_limits<float>::infinity(), std::numeric_limits<float>::infinity(),
           std::numeric_limits<float>::infinity()};
  Vec3f hi = -lo;
  bool empty() const { return !(lo.x <= hi.x); }
};

Box finite_bounds(const std::vector<Vec3f>& points) {
  Box box;
  for (const Vec3f& p : points)
    if (is_finite(p)) {
      box.lo = min(box.lo, p);
      box.hi = max(box.hi, p);
    }
  return box;
}

std::string format_vec(Vec3f v) { return fmt::format("{{{}, {}, {}}}", v.x, v.y, v.z); }

int64_t floor_div(int64_t a, int64_t b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

// ---------------------------------------------------------------------------------------------
// Screen-space primitives.

/// A vertex projected to the supersampled image: snapped position in 1/kSubpixel samples and
/// inverse view depth (which, unlike depth, interpolates linearly in screen space).
/// inv_depth == 0 marks a vertex that must not be drawn (not finite, behind, outside guard band).
struct ScreenVertex {
  int32_t x = 0, y = 0;
  float inv_depth = 0;
};

/// A particle projected to the supersampled image: centre in samples and view depth (> 0 if drawn).
struct ScreenParticle {
  float x = 0, y = 0, depth = 0;
};

/// Inclusive range of samples; empty when x0 > x1 or y0 > y1.
struct SampleRect {
  int x0 = 0, y0 = 0, x1 = -1, y1 = -1;
  bool empty() const { return x0 > x1 || y0 > y1; }
};

SampleRect intersect(SampleRect a, SampleRect b) {
  return {std::max(a.x0, b.x0), std::max(a.y0, b.y0), std::min(a.x1, b.x1), std::min(a.y1, b.y1)};
}

// Samples sit at the centres of the integer grid: sample i has x = i·kSubpixel + kHalfSample.
// First sample at or after the fixed-point coordinate v, last sample at or before it.
int first_sample_from(int64_t v) { return static_cast<int>(floor_div(v - kHalfSample + kSubpixel - 1, kSubpixel)); }
int last_sample_to(int64_t v) { return static_cast<int>(floor_div(v - kHalfSample, kSubpixel)); }

/// E_ab(p): twice the signed area of (a, b, p); positive on the inside of a triangle whose
/// vertices make edge_function(a, b, c) positive.
int64_t edge_function(int64_t ax, int64_t ay, int64_t bx, int64_t by, int64_t px, int64_t py) {
  return (bx - ax) * (py - ay) - (by - ay) * (px - ax);
}

SampleRect triangle_samples(const ScreenVertex& a, const ScreenVertex& b, const ScreenVertex& c, int width,
                            int height) {
  if (a.inv_depth <= 0 || b.inv_depth <= 0 || c.inv_depth <= 0) return {};
  if (edge_function(a.x, a.y, b.x, b.y, c.x, c.y) == 0) return {};
  const SampleRect bounds{first_sample_from(std::min({a.x, b.x, c.x})), first_sample_from(std::min({a.y, b.y, c.y})),
                          last_sample_to(std::max({a.x, b.x, c.x})), last_sample_to(std::max({a.y, b.y, c.y}))};
  return intersect(bounds, {0, 0, width - 1, height - 1});
}

SampleRect particle_samples(const ScreenParticle& p, float radius, int width, int height) {
  if (!(p.depth > 0)) return {};
  // Sample centres within the radius: i + 0.5 ∈ [x − r, x + r].
  const SampleRect bounds{
      static_cast<int>(std::ceil(p.x - radius - 0.5f)), static_cast<int>(std::ceil(p.y - radius - 0.5f)),
      static_cast<int>(std::floor(p.x + radius - 0.5f)), static_cast<int>(std::floor(p.y + radius - 0.5f))};
  return intersect(bounds, {0, 0, width - 1, height - 1});
}

// ---------------------------------------------------------------------------------------------
// Binning primitives into tiles.

struct TileGrid {
  int tiles_x = 0, tiles_y = 0;
  std::size_t count() const { return std::size_t(tiles_x) * std::size_t(tiles_y); }
  SampleRect samples_of(std::size_t tile, int width, int height) const {
    const int tx = int(tile % std::size_t(tiles_x)), ty = int(tile / std::size_t(tiles_x));
    return {tx * kTileSize, ty * kTileSize, std::min(width, (tx + 1) * kTileSize) - 1,
            std::min(height, (ty + 1) * kTileSize) - 1};
  }
};

/// Tile t's primitives are items[begin[t] .. begin[t+1]), in increasing primitive index.
struct TileBins {
  std::vector<std::size_t> begin;
  std::vector<uint32_t> items;
};

/// Inclusive tile range of a primitive; empty when x0 > x1.
struct TileRect {
  uint16_t x0 = 1, y0 = 1, x1 = 0, y1 = 0;
};

template <class SampleRectOf>
TileBins bin_to_tiles(std::size_t count, const TileGrid& grid, const SampleRectOf& sample_rect_of) {
  const std::size_t tiles = grid.count();
  TileBins bins;
  bins.begin.assign(tiles + 1, 0);
  if (count == 0) return bins;

  // A fixed chunking (independent of the thread count) fills every tile's list in primitive
  // order, so equal-depth ties resolve the same way on every run. Capped so the per-chunk
  // counters stay small for huge images.
  std::size_t chunks = std::clamp<std::size_t>(count / 8192, 1, 256);
  chunks = std::max<std::size_t>(1, std::min(chunks, (std::size_t{1} << 20) / tiles));
  const std::size_t chunk_size = (count + chunks - 1) / chunks;
  chunks = (count + chunk_size - 1) / chunk_size;

  std::vector<TileRect> rects(count);
  std::vector<std::size_t> cursors(chunks * tiles, 0);
  for_each_index(chunks, [&](std::size_t k) {
    std::size_t* counts = &cursors[k * tiles];
    for (std::size_t i = k * chunk_size, end = std::min(count, i + chunk_size); i < end; ++i) {
      const SampleRect s = sample_rect_of(i);
      if (s.empty()) continue;
      const TileRect r{static_cast<uint16_t>(s.x0 / kTileSize), static_cast<uint16_t>(s.y0 / kTileSize),
                       static_cast<uint16_t>(s.x1 / kTileSize), static_cast<uint16_t>(s.y1 / kTileSize)};
      rects[i] = r;
      for (int ty = r.y0; ty <= r.y1; ++ty)
        for (int tx = r.x0; tx <= r.x1; ++tx) ++counts[std::size_t(ty) * std::size_t(grid.tiles_x) + std::size_t(tx)];
    }
  });

  // Exclusive prefix sum in (tile, chunk) order turns the counts into write cursors.
  std::size_t total = 0;
  for (std::size_t t = 0; t < tiles; ++t) {
    bins.begin[t] = total;
    for (std::size_t k = 0; k < chunks; ++k) {
      const std::size_t n = cursors[k * tiles + t];
      cursors[k * tiles + t] = total;
      total += n;
    }
  }
  bins.begin[tiles] = total;
  bins.items.resize(total);

  for_each_index(chunks, [&](std::size_t k) {
    std::size_t* cursor = &cursors[k * tiles];
    for (std::size_t i = k * chunk_size, end = std::min(count, i + chunk_size); i < end; ++i) {
      const TileRect r = rects[i];
      for (int ty = r.y0; ty <= r.y1; ++ty)
        for (int tx = r.x0; tx <= r.x1; ++tx)
          bins.items[cursor[std::size_t(ty) * std::size_t(grid.tiles_x) + std::size_t(tx)]++] =
              static_cast<uint32_t>(i);
    }
  });
  return bins;
}

// ---------------------------------------------------------------------------------------------
// Visibility buffer: per sample the nearest primitive and its inverse depth (larger = nearer).

struct VisibilityBuffer {
  int width = 0, height = 0;
  std::unique_ptr<float[]> inv_depth;
  std::unique_ptr<uint32_t[]> primitive;

  VisibilityBuffer(int w, int h)
      : width(w),
        height(h),
        // Left uninitialized here: each tile clears its own part in parallel.
        inv_depth(std::make_unique_for_overwrite<float[]>(std::size_t(w) * std::size_t(h))),
        primitive(std::make_unique_for_overwrite<uint32_t[]>(std::size_t(w) * std::size_t(h))) {}

  std::size_t index(int x, int y) const { return std::size_t(y) * std::size_t(width) + std::size_t(x); }

  void clear(SampleRect r) {
    for (int y = r.y0; y <= r.y1; ++y) {
      std::fill_n(&inv_depth[index(r.x0, y)], r.x1 - r.x0 + 1, 0.0f);
      std::fill_n(&primitive[index(r.x0, y)], r.x1 - r.x0 + 1, kNoPrimitive);
    }
  }

  void test_and_set(std::size_t i, float w, uint32_t id) {
    // Strictly nearer wins, so among equal depths the first primitive in order stays.
    if (w > inv_depth[i]) {
      inv_depth[i] = w;
      primitive[i] = id;
    }
  }
};

void rasterize_triangle(ScreenVertex a, ScreenVertex b, ScreenVertex c, uint32_t id, SampleRect tile,
                        VisibilityBuffer& buffer) {
  int64_t area = edge_function(a.x, a.y, b.x, b.y, c.x, c.y);
  if (area == 0) return;
  // Both windings are drawn (back faces are shaded, not culled); make the area positive so one
  // inside test and one top-left rule serve both.
  if (area < 0) {
    std::swap(b, c);
    area = -area;
  }
  const SampleRect r = intersect(triangle_samples(a, b, c, buffer.width, buffer.height), tile);
  if (r.empty()) return;

  // With positive area in y-down coordinates, an edge a→b is a top edge when horizontal and
  // going right, a left edge when going up. Samples exactly on other edges belong to the
  // neighbour: the -1 bias turns "E >= 0" into "E > 0" for them.
  struct Edge {
    int64_t step_x, step_y, row;
  };
  const int64_t px = int64_t(r.x0) * kSubpixel + kHalfSample, py = int64_t(r.y0) * kSubpixel + kHalfSample;
  const auto make_edge = [&](const ScreenVertex& from, const ScreenVertex& to) {
    const int64_t dx = int64_t(to.x) - from.x, dy = int64_t(to.y) - from.y;
    const bool top_left = (dy == 0 && dx > 0) || dy < 0;
    return Edge{-dy * kSubpixel, dx * kSubpixel,
                edge_function(from.x, from.y, to.x, to.y, px, py) - (top_left ? 0 : 1)};
  };
  Edge e_bc = make_edge(b, c), e_ca = make_edge(c, a), e_ab = make_edge(a, b);  // weights of a, b, c
  const float inv_area = 1.0f / float(area);
  const float wa = a.inv_depth * inv_area, wb = b.inv_depth * inv_area, wc = c.inv_depth * inv_area;

  for (int y = r.y0; y <= r.y1; ++y) {
    int64_t ea = e_bc.row, eb = e_ca.row, ec = e_ab.row;
    std::size_t i = buffer.index(r.x0, y);
    for (int x = r.x0; x <= r.x1; ++x, ++i) {
      if ((ea | eb | ec) >= 0)  // all three non-negative
        buffer.test_and_set(i, float(ea) * wa + float(eb) * wb + float(ec) * wc, id);
      ea += e_bc.step_x;
      eb += e_ca.step_x;
      ec += e_ab.step_x;
    }
    e_bc.row += e_bc.step_y;
    e_ca.row += e_ca.step_y;
    e_ab.row += e_ab.step_y;
  }
}

/// Draws a particle as a sphere impostor: its depth bulges towards the camera by the sphere's
/// height at each sample, so dots half-sunk into the surface show as caps, not as flat discs.
void rasterize_particle(const ScreenParticle& p, uint32_t id, float radius, float world_per_sample, SampleRect tile,
                        VisibilityBuffer& buffer) {
  const SampleRect r = intersect(particle_samples(p, radius, buffer.width, buffer.height), tile);
  const float world_radius = radius * world_per_sample * p.depth;
  for (int y = r.y0; y <= r.y1; ++y)
    for (int x = r.x0; x <= r.x1; ++x) {
      const float dx = (float(x) + 0.5f - p.x) / radius, dy = (float(y) + 0.5f - p.y) / radius;
      const float d2 = dx * dx + dy * dy;
      if (d2 > 1.0f) continue;
      const float depth = p.depth - std::sqrt(1.0f - d2) * world_radius;
      if (depth > 0) buffer.test_and_set(buffer.index(x, y), 1.0f / depth, id);
    }
}

// ---------------------------------------------------------------------------------------------
// Shading.

struct Lights {
  Vec3f key_dir, fill_dir, world_up;  // unit vectors towards the lights / up
  Vec3f key{1.00f, 0.95f, 0.88f}, fill{0.26f, 0.30f, 0.36f};
  Vec3f sky_ambient{0.26f, 0.30f, 0.36f}, ground_ambient{0.09f, 0.08f, 0.07f};
  Vec3f horizon{0.80f, 0.85f, 0.90f}, zenith{0.35f, 0.50f, 0.78f};
};

Lights make_lights(const Camera& camera, Vec3f up) {
  Lights lights;
  // Fixed relative to the viewer, so every view angle shows a lit upper left and a shaded lower
  // right, which is what makes the shape readable.
  const Vec3f back = -camera.forward;
  lights.key_dir = normalized(camera.right * -0.55f + camera.up * 0.75f + back * 0.55f);
  lights.fill_dir = normalized(camera.right * 0.85f + camera.up * -0.10f + back * 0.50f);
  lights.world_up = normalized(up);
  return lights;
}

Vec3f shade(Vec3f n, Vec3f v, Vec3f albedo, bool front, const Lights& lights) {
  const float hemisphere = 0.5f + 0.5f * dot(n, lights.world_up);
  const Vec3f irradiance = lerp(lights.ground_ambient, lights.sky_ambient, hemisphere) +
                           lights.key * std::max(0.0f, dot(n, lights.key_dir)) +
                           lights.fill * std::max(0.0f, dot(n, lights.fill_dir));
  Vec3f color = mul(albedo, irradiance);
  // Back faces are seen only through holes of open meshes: dim and matte, so they read as inside.
  if (!front) return color * 0.55f;

  // Schlick's Fresnel with water's F0 ≈ 0.02: surfaces turn sky-coloured towards the silhouette,
  // the cue that makes a blue blob read as water. Scaled down to stay subtle.
  const float n_dot_v = std::clamp(dot(n, v), 0.0f, 1.0f);
  const float m = 1.0f - n_dot_v, m2 = m * m;
  const float fresnel = 0.6f * (0.02f + 0.98f * m2 * m2 * m);
  const Vec3f reflected = n * (2.0f * dot(n, v)) - v;
  const Vec3f sky = lerp(lights.horizon, lights.zenith, std::clamp(dot(reflected, lights.world_up), 0.0f, 1.0f));
  color = color * (1.0f - fresnel) + sky * fresnel;
  // A soft rim of sky light along silhouettes separates overlapping sheets of liquid.
  color += sky * (0.12f * m2 * m);

  // Blinn-Phong highlights: a tight one from the key light (the wet look), a broad faint one from the fill.
  const Vec3f h_key = safe_normalized(lights.key_dir + v, n), h_fill = safe_normalized(lights.fill_dir + v, n);
  color += lights.key * (0.45f * power<90>(std::max(0.0f, dot(n, h_key))));
  color += lights.fill * (0.10f * power<16>(std::max(0.0f, dot(n, h_fill))));
  return color;
}

struct Scene {
  const TriangleMesh& mesh;
  const std::vector<ScreenVertex>& screen;
  const std::vector<Vec3f>& vertex_colors;  // linear; empty: base colour
  const std::vector<ScreenParticle>& particles;
  Camera camera;  // supersampled
  Lights lights;
  Vec3f base_color, particle_color;  // linear
  float particle_radius = 0;         // samples
  bool smooth = false;
};

/// Shades triangle `id` at position (px, py), in the rasterizer's fixed-point sample units.
Vec3f shade_triangle(const Scene& scene, uint32_t id, int64_t px, int64_t py) {
  const Triangle& t = scene.mesh.triangles[id];
  const ScreenVertex& a = scene.screen[t[0]];
  const ScreenVertex& b = scene.screen[t[1]];
  const ScreenVertex& c = scene.screen[t[2]];
  // Barycentrics from the same snapped integers the rasterizer used, then made
  // perspective-correct with the inverse depths (cheap here, since it runs once per sample).
  const int64_t ea = edge_function(b.x, b.y, c.x, c.y, px, py);
  const int64_t eb = edge_function(c.x, c.y, a.x, a.y, px, py);
  const int64_t ec = edge_function(a.x, a.y, b.x, b.y, px, py);
  const float area = float(ea + eb + ec);
  float wa = std::max(0.0f, float(ea) / area) * a.inv_depth;
  float wb = std::max(0.0f, float(eb) / area) * b.inv_depth;
  float wc = std::max(0.0f, float(ec) / area) * c.inv_depth;
  const float sum = wa + wb + wc;
  if (sum > 0) {
    wa /= sum;
    wb /= sum;
    wc /= sum;
  } else {
    wa = wb = wc = 1.0f / 3.0f;
  }

  const Vec3f& va = scene.mesh.vertices[t[0]];
  const Vec3f& vb = scene.mesh.vertices[t[1]];
  const Vec3f& vc = scene.mesh.vertices[t[2]];
  const Vec3f point = va * wa + vb * wb + vc * wc;
  const Vec3f view = safe_normalized(scene.camera.eye - point, -scene.camera.forward);
  const Vec3f face = cross(vb - va, vc - va);
  // Decided per triangle from the true geometry, not the interpolated normal, so a triangle is
  // front or back as a whole.
  const bool front = dot(face, scene.camera.eye - va) >= 0;
  const Vec3f face_normal = safe_normalized(face, view);
  Vec3f normal = face_normal;
  if (scene.smooth) {
    const std::vector<Vec3f>& n = scene.mesh.normals;
    normal = safe_normalized(n[t[0]] * wa + n[t[1]] * wb + n[t[2]] * wc, face_normal);
  }
  if (!front) normal = -normal;
  const Vec3f albedo = scene.vertex_colors.empty() ? scene.base_color
                                                   : scene.vertex_colors[t[0]] * wa + scene.vertex_colors[t[1]] * wb +
                                                         scene.vertex_colors[t[2]] * wc;
  return shade(normal, view, albedo, front, scene.lights);
}

/// Shades particle `id` at position (x, y) in samples.
Vec3f shade_particle(const Scene& scene, uint32_t id, float x, float y) {
  const ScreenParticle& p = scene.particles[id];
  const float dx = (x - p.x) / scene.particle_radius, dy = (y - p.y) / scene.particle_radius;
  const float dz = std::sqrt(std::max(0.0f, 1.0f - dx * dx - dy * dy));
  const Camera& camera = scene.camera;
  const Vec3f normal = safe_normalized(camera.right * dx - camera.up * dy - camera.forward * dz, -camera.forward);
  return shade(normal, -camera.forward, scene.particle_color, true, scene.lights);
}

/// Shades visibility-buffer entry `id` (not kNoPrimitive) at a fixed-point position, tone-mapped.
Vec3f shade_primitive(const Scene& scene, uint32_t id, int64_t px, int64_t py) {
  if (id & kParticleBit)
    return tone(shade_particle(scene, id & ~kParticleBit, float(px) / float(kSubpixel), float(py) / float(kSubpixel)));
  return tone(shade_triangle(scene, id, px, py));
}

// ---------------------------------------------------------------------------------------------
// Input checks and per-vertex colours.

void check_mesh(const TriangleMesh& mesh) {
  if (mesh.triangles.size() >= kParticleBit)
    throw ResourceError(fmt::format("render_mesh: {} triangles exceed the renderer's limit of {}",
                                    mesh.triangles.size(), kParticleBit - 1));
  const std::size_t n = mesh.vertices.size();
  if (!mesh.normals.empty() && mesh.normals.size() != n)
    throw InvalidParameter(fmt::format("render_mesh: mesh has {} normals for {} vertices", mesh.normals.size(), n));
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i)
    for (const uint32_t v : mesh.triangles[i])
      if (v >= n)
        throw InvalidParameter(
            fmt::format("render_mesh: triangle {} references vertex {} but the mesh has {} vertices", i, v, n));
}

std::string lowercase(std::string_view text) {
  std::string out(text);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

/// The value the colormap shows for vertex i: the scalar, or the vector's length.
float mapped_value(const Attribute& attribute, std::size_t i) {
  if (attribute.components == 1) return attribute.values[i];
  const float* v = &attribute.values[3 * i];
  return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
}

/// Linear per-vertex colours from options.color_attribute, or empty to use the base colour.
std::vector<Vec3f> vertex_colors(const TriangleMesh& mesh, const RenderOptions& options) {
  if (options.color_attribute.empty()) return {};
  const Attribute* attribute = mesh.find(options.color_attribute);
  if (attribute == nullptr) {
    std::string available;
    for (const Attribute& a : mesh.attributes)
      if (a.components == 1 || a.components == 3)
        available += fmt::format("{}{} ({})", available.empty() ? "" : ", ", a.name,
                                 a.components == 1 ? "scalar" : "3 components");
    throw InvalidParameter(fmt::format("colour attribute '{}': the mesh has no such vertex attribute (it has: {})",
                                       options.color_attribute, available.empty() ? "none" : available));
  }
  const ColorMapping mapping = color_mapping(*attribute);
  const std::size_t n = mesh.vertices.size();
  const auto components = std::size_t(attribute->components);
  if (attribute->values.size() != n * components)
    throw InvalidParameter(
        fmt::format("render_mesh: colour attribute '{}' has {} values, expected {} ({} vertices × {})", attribute->name,
                    attribute->values.size(), n * components, n, components));
  const std::vector<float>& values = attribute->values;
  std::vector<Vec3f> colors(n);
  if (mapping == ColorMapping::rgb) {
    for_each_chunk(n, 4096, [&](std::size_t begin, std::size_t end) {
      for (std::size_t i = begin; i < end; ++i)
        colors[i] = srgb_to_linear(Vec3f{values[3 * i], values[3 * i + 1], values[3 * i + 2]});
    });
    return colors;
  }
  const std::array<float, 2> range = options.color_range ? *options.color_range
                                                         : color_value_range(*attribute).value_or(std::array{0.0f, 0.0f});
  const float lo = range[0], hi = range[1];
  const float scale = hi > lo ? 1.0f / (hi - lo) : 0.0f;  // constant attribute: middle of the map
  for_each_chunk(n, 4096, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      const float v = mapped_value(*attribute, i);
      const float t = !std::isfinite(v) ? 0.0f : (scale > 0 ? (v - lo) * scale : 0.5f);
      colors[i] = srgb_to_linear(viridis(t));
    }
  });
  return colors;
}

}  // namespace

// ---------------------------------------------------------------------------------------------

void RenderOptions::validate() const {
  const auto out_of_range = [](const char* name, const std::string& value, const char* expected) {
    return InvalidParameter(fmt::format("render option {} = {} is out of range (expected {})", name, value, expected));
  };
  const auto check_range = [&](const char* name, float value, float lo, float hi, const char* expected) {
    if (!(value >= lo && value <= hi)) throw out_of_range(name, fmt::format("{}", value), expected);
  };
  const auto check_color = [&](const char* name, Vec3f c) {
    for (int i = 0; i < 3; ++i)
      if (!(c[i] >= 0.0f && c[i] <= 1.0f)) throw out_of_range(name, format_vec(c), "components in [0, 1]");
  };
  if (width < 1 || width > kMaxImageSide) throw out_of_range("width", std::to_string(width), "1 ..= 8192");
  if (height < 1 || height > kMaxImageSide) throw out_of_range("height", std::to_string(height), "1 ..= 8192");
  check_range("yaw_degrees", yaw_degrees, -1e6f, 1e6f, "a finite angle");
  check_range("pitch_degrees", pitch_degrees, -89.0f, 89.0f, "-89 ..= 89");
  if (!is_finite(up) || !(length(up) > 1e-20f)) throw out_of_range("up", format_vec(up), "a finite non-zero vector");
  check_range("field_of_view_degrees", field_of_view_degrees, 1.0f, 120.0f, "1 ..= 120");
  if (!(frame_fill > 0.0f && frame_fill <= 1.0f))
    throw out_of_range("frame_fill", fmt::format("{}", frame_fill), "(0, 1]");
  check_color("base_color", base_color);
  check_color("particle_color", particle_color);
  check_range("particle_radius_pixels", particle_radius_pixels, 0.25f, 64.0f, "0.25 ..= 64");
  check_color("background_top", background_top);
  check_color("background_bottom", background_bottom);
  if (color_range) {
    const auto [lo, hi] = *color_range;
    if (!(std::isfinite(lo) && std::isfinite(hi) && lo < hi))
      throw out_of_range("color_range", fmt::format("{}, {}", lo, hi), "finite lo < hi");
  }
  if (frame_bounds) {
    const Bounds& b = *frame_bounds;
    if (!is_finite(b.lo) || !is_finite(b.hi) || !(b.lo.x <= b.hi.x && b.lo.y <= b.hi.y && b.lo.z <= b.hi.z))
      throw out_of_range("frame_bounds", format_vec(b.lo) + " .. " + format_vec(b.hi), "finite, lo ≤ hi");
  }
}

Camera frame_camera(const TriangleMesh& mesh, const RenderOptions& options) {
  options.validate();
  Box box = finite_bounds(mesh.vertices);
  if (options.frame_bounds) box = {options.frame_bounds->lo, options.frame_bounds->hi};
  if (box.empty() && options.particles != nullptr) box = finite_bounds(options.particles->positions);
  if (box.empty()) box.lo = box.hi = Vec3f{0, 0, 0};

  const Vec3f center = (box.lo + box.hi) * 0.5f;
  float radius = 0.5f * length(box.hi - box.lo);  // of the bounding sphere of the box
  // A single point: frame a unit-sized neighbourhood rather than dividing by zero.
  if (!(radius > 1e-6f * std::max({1.0f, std::abs(center.x), std::abs(center.y), std::abs(center.z)}))) radius = 1.0f;

  // Horizontal axes: the world axis least aligned with up (x for z-up), made perpendicular, and
  // up × it, so yaw 0 looks from +x for z-up data.
  const Vec3f up = normalized(options.up);
  const Vec3f axis = std::abs(up.x) < 0.9f ? Vec3f{1, 0, 0} : Vec3f{0, 1, 0};
  const Vec3f h1 = normalized(axis - up * dot(axis, up));
  const Vec3f h2 = cross(up, h1);
  const float deg = std::numbers::pi_v<float> / 180.0f;
  const float yaw = options.yaw_degrees * deg, pitch = options.pitch_degrees * deg;
  const Vec3f to_eye = normalized((h1 * std::cos(yaw) + h2 * std::sin(yaw)) * std::cos(pitch) + up * std::sin(pitch));

  Camera camera;
  camera.width = options.width;
  camera.height = options.height;
  camera.target = center;
  camera.forward = -to_eye;
  camera.right = normalized(h2 * std::cos(yaw) - h1 * std::sin(yaw));  // horizontal: no roll
  camera.up = cross(camera.right, camera.forward);
  // Far enough that the bounding sphere spans the field of view, hence the whole box is in
  // front of the camera (distance > radius) whatever the view direction.
  const float distance = radius / std::sin(0.5f * options.field_of_view_degrees * deg);
  camera.eye = center + to_eye * distance;

  // Zoom and shift the image plane so the projected box spans frame_fill of the limiting
  // dimension and sits in the middle (a perspective box is not symmetric about its centre).
  float u_lo = std::numeric_limits<float>::infinity(), u_hi = -u_lo, v_lo = u_lo, v_hi = -u_lo;
  for (int corner = 0; corner < 8; ++corner) {
    const Vec3f p{(corner & 1) ? box.hi.x : box.lo.x, (corner & 2) ? box.hi.y : box.lo.y,
                  (corner & 4) ? box.hi.z : box.lo.z};
    const Vec3f d = p - camera.eye;
    const float depth = dot(d, camera.forward);
    const float u = dot(d, camera.right) / depth, v = -dot(d, camera.up) / depth;
    u_lo = std::min(u_lo, u);
    u_hi = std::max(u_hi, u);
    v_lo = std::min(v_lo, v);
    v_hi = std::max(v_hi, v);
  }
  const float w = float(options.width), h = float(options.height);
  const float span_u = u_hi - u_lo, span_v = v_hi - v_lo;
  const float tiny = 1e-6f;
  if (span_u > tiny && span_v > tiny)
    camera.focal = options.frame_fill * std::min(w / span_u, h / span_v);
  else if (span_u > tiny)
    camera.focal = options.frame_fill * w / span_u;
  else if (span_v > tiny)
    camera.focal = options.frame_fill * h / span_v;
  else
    camera.focal = 0.5f * h / std::tan(0.5f * options.field_of_view_degrees * deg);
  camera.cx = 0.5f * w - camera.focal * 0.5f * (u_lo + u_hi);
  camera.cy = 0.5f * h - camera.focal * 0.5f * (v_lo + v_hi);
  return camera;
}

Vec3f project(const Camera& camera, Vec3f point) {
  const Vec3f d = point - camera.eye;
  const float depth = dot(d, camera.forward);
  if (!(depth > 0)) return {0, 0, depth};
  return {camera.cx + camera.focal * dot(d, camera.right) / depth, camera.cy - camera.focal * dot(d, camera.up) / depth,
          depth};
}

Image render_mesh(const TriangleMesh& mesh, const RenderOptions& options) {
  check_mesh(mesh);
  const ParticleSet empty_particles;
  const ParticleSet& particle_set = options.particles != nullptr ? *options.particles : empty_particles;
  if (particle_set.size() >= kParticleBit)
    throw ResourceError(fmt::format("render_mesh: {} particles exceed the renderer's limit of {}", particle_set.size(),
                                    kParticleBit - 1));

  // Everything below works on the supersampled image; pixel coordinates simply scale by 2.
  Camera camera = frame_camera(mesh, options);
  camera.width *= kSupersample;
  camera.height *= kSupersample;
  camera.focal *= float(kSupersample);
  camera.cx *= float(kSupersample);
  camera.cy *= float(kSupersample);
  const int width = camera.width, height = camera.height;
  const float near = 1e-4f * length(camera.eye - camera.target);

  std::vector<ScreenVertex> screen(mesh.vertices.size());
  for_each_chunk(screen.size(), 4096, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      if (!is_finite(mesh.vertices[i])) continue;
      const Vec3f s = project(camera, mesh.vertices[i]);
      if (!(s.z > near && std::abs(s.x) < kGuardBand && std::abs(s.y) < kGuardBand)) continue;
      screen[i] = {static_cast<int32_t>(std::lround(s.x * float(kSubpixel))),
                   static_cast<int32_t>(std::lround(s.y * float(kSubpixel))), 1.0f / s.z};
    }
  });

  const float particle_radius = options.particle_radius_pixels * float(kSupersample);
  std::vector<ScreenParticle> particles(particle_set.size());
  for_each_chunk(particles.size(), 4096, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      if (!is_finite(particle_set.positions[i])) continue;
      const Vec3f s = project(camera, particle_set.positions[i]);
      if (s.z > near && std::abs(s.x) < kGuardBand && std::abs(s.y) < kGuardBand) particles[i] = {s.x, s.y, s.z};
    }
  });

  const TileGrid grid{(width + kTileSize - 1) / kTileSize, (height + kTileSize - 1) / kTileSize};
  const TileBins triangle_bins = bin_to_tiles(mesh.triangles.size(), grid, [&](std::size_t i) {
    const Triangle& t = mesh.triangles[i];
    return triangle_samples(screen[t[0]], screen[t[1]], screen[t[2]], width, height);
  });
  const TileBins particle_bins = bin_to_tiles(particles.size(), grid, [&](std::size_t i) {
    return particle_samples(particles[i], particle_radius, width, height);
  });

  VisibilityBuffer buffer(width, height);
  const float world_per_sample = 1.0f / camera.focal;  // world size of one sample at unit depth
  for_each_chunk(grid.count(), 1, [&](std::size_t begin, std::size_t end) {
    for (std::size_t tile = begin; tile < end; ++tile) {
      const SampleRect samples = grid.samples_of(tile, width, height);
      buffer.clear(samples);
      for (std::size_t k = triangle_bins.begin[tile]; k < triangle_bins.begin[tile + 1]; ++k) {
        const uint32_t id = triangle_bins.items[k];
        const Triangle& t = mesh.triangles[id];
        rasterize_triangle(screen[t[0]], screen[t[1]], screen[t[2]], id, samples, buffer);
      }
      for (std::size_t k = particle_bins.begin[tile]; k < particle_bins.begin[tile + 1]; ++k) {
        const uint32_t id = particle_bins.items[k];
        rasterize_particle(particles[id], id | kParticleBit, particle_radius, world_per_sample, samples, buffer);
      }
    }
  });

  const std::vector<Vec3f> colors = vertex_colors(mesh, options);
  const Scene scene{mesh,
                    screen,
                    colors,
                    particles,
                    camera,
                    make_lights(camera, options.up),
                    srgb_to_linear(options.base_color),
                    srgb_to_linear(options.particle_color),
                    particle_radius,
                    !mesh.normals.empty()};

  // Background per sample row, blended in linear light like everything else.
  std::vector<Vec3f> background(static_cast<std::size_t>(height));
  const Vec3f top = srgb_to_linear(options.background_top), bottom = srgb_to_linear(options.background_bottom);
  for (int y = 0; y < height; ++y)
    background[std::size_t(y)] =
        options.background_gradient ? lerp(top, bottom, (float(y) + 0.5f) / float(height)) : top;

  // Resolve 2×2 samples into each pixel, averaging in linear light. As in MSAA, a pixel whose
  // samples all see one primitive is shaded once at its centre: that is most pixels, and
  // shading dominates the cost. Pixels showing only background are copied from a per-row value.
  static_assert(kSupersample == 2);
  Image image;
  image.width = options.width;
  image.height = options.height;
  image.rgb.resize(std::size_t(image.width) * std::size_t(image.height) * 3);
  for_each_index(std::size_t(image.height), 4, [&](std::size_t row) {
    const int py = int(row);
    const int sy = 2 * py;
    const Vec3f row_background = (background[std::size_t(sy)] + background[std::size_t(sy + 1)]) * 0.5f;
    const std::array<uint8_t, 3> background_bytes = {to_byte(row_background.x), to_byte(row_background.y),
                                                     to_byte(row_background.z)};
    uint8_t* out = &image.rgb[std::size_t(py) * std::size_t(image.width) * 3];
    for (int px = 0; px < image.width; ++px, out += 3) {
      const int sx = 2 * px;
      const std::array<uint32_t, 4> ids = {
          buffer.primitive[buffer.index(sx, sy)], buffer.primitive[buffer.index(sx + 1, sy)],
          buffer.primitive[buffer.index(sx, sy + 1)], buffer.primitive[buffer.index(sx + 1, sy + 1)]};
      const bool uniform = ids[0] == ids[1] && ids[0] == ids[2] && ids[0] == ids[3];
      if (uniform && ids[0] == kNoPrimitive) {
        std::copy(background_bytes.begin(), background_bytes.end(), out);
        continue;
      }
      Vec3f color;
      if (uniform) {
        color = shade_primitive(scene, ids[0], int64_t(sx + 1) * kSubpixel, int64_t(sy + 1) * kSubpixel);
      } else {
        Vec3f sum{0, 0, 0};
        for (int k = 0; k < 4; ++k) {
          const int x = sx + (k & 1), y = sy + (k >> 1);
          sum += ids[std::size_t(k)] == kNoPrimitive
                     ? background[std::size_t(y)]
                     : shade_primitive(scene, ids[std::size_t(k)], int64_t(x) * kSubpixel + kHalfSample,
                                       int64_t(y) * kSubpixel + kHalfSample);
        }
        color = sum * 0.25f;
      }
      out[0] = to_byte(color.x);
      out[1] = to_byte(color.y);
      out[2] = to_byte(color.z);
    }
  });
  return image;
}

ColorMapping color_mapping(const Attribute& attribute) {
  if (attribute.components == 1) return ColorMapping::scalar;
  if (attribute.components != 3)
    throw InvalidParameter(fmt::format("colour attribute '{}' has {} components; colouring needs 1 (a scalar) or 3 "
                                       "(a colour or a vector)",
                                       attribute.name, attribute.components));
  const std::string name = lowercase(attribute.name);
  const bool colour_named = name == "cd" || name == "rgb" || name.find("color") != std::string::npos ||
                            name.find("colour") != std::string::npos;
  return colour_named ? ColorMapping::rgb : ColorMapping::magnitude;
}

std::optional<std::array<float, 2>> color_value_range(const Attribute& attribute) {
  if (color_mapping(attribute) == ColorMapping::rgb) return std::nullopt;
  float lo = std::numeric_limits<float>::infinity(), hi = -lo;
  for (std::size_t i = 0, n = attribute.size(); i < n; ++i) {
    const float v = mapped_value(attribute, i);
    if (std::isfinite(v)) {
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
  }
  if (!(lo <= hi)) return std::nullopt;
  return std::array{lo, hi};
}

Image render_turntable(const TriangleMesh& mesh, const RenderOptions& options, int views) {
  if (views < 1 || views > 64)
    throw InvalidParameter(fmt::format("turntable views = {} is out of range (expected 1 ..= 64)", views));
  std::vector<Image> images;
  images.reserve(std::size_t(views));
  RenderOptions view = options;
  for (int k = 0; k < views; ++k) {
    view.yaw_degrees = options.yaw_degrees + 360.0f * float(k) / float(views);
    images.push_back(render_mesh(mesh, view));
  }
  return join_images(images, views);
}

Image join_images(const std::vector<Image>& images, int columns) {
  if (images.empty()) throw InvalidParameter("join_images: no images");
  if (columns < 1) throw InvalidParameter(fmt::format("join_images: columns = {}: must be ≥ 1", columns));
  const int w = images[0].width, h = images[0].height;
  for (std::size_t i = 0; i < images.size(); ++i) {
    const Image& image = images[i];
    if (image.width != w || image.height != h || w < 1 || h < 1 ||
        image.rgb.size() != std::size_t(w) * std::size_t(h) * 3)
      throw InvalidParameter(fmt::format("join_images: image {} is {}×{} ({} bytes), expected {}×{}", i, image.width,
                                         image.height, image.rgb.size(), w, h));
  }
  const std::size_t cols = std::min(std::size_t(columns), images.size());
  const std::size_t rows = (images.size() + cols - 1) / cols;
  const std::size_t total_w = cols * std::size_t(w), total_h = rows * std::size_t(h);
  if (total_w * total_h > (std::size_t{1} << 30) || total_w > std::size_t(std::numeric_limits<int>::max()) ||
      total_h > std::size_t(std::numeric_limits<int>::max()))
    throw InvalidParameter(fmt::format("join_images: {}×{} pixels is too large (at most 2^30)", total_w, total_h));
  Image out;
  out.width = int(total_w);
  out.height = int(total_h);
  out.rgb.assign(total_w * total_h * 3, 0);
  const std::size_t row_bytes = std::size_t(w) * 3;
  for (std::size_t i = 0; i < images.size(); ++i) {
    const std::size_t x0 = (i % cols) * std::size_t(w), y0 = (i / cols) * std::size_t(h);
    for (std::size_t y = 0; y < std::size_t(h); ++y)
      std::copy_n(&images[i].rgb[y * row_bytes], row_bytes, &out.rgb[((y0 + y) * total_w + x0) * 3]);
  }
  return out;
}

}  // namespace meniscus
