// meniscus — Morton-order vertex renumbering (Morton 1966; the usual locality order of GPU and
// CPU mesh pipelines, e.g. Karras 2012 for BVH construction).
#include "mesh/vertex_order.hpp"

#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <limits>

#include "common/huge_pages.hpp"
#include "extract/radix_sort.hpp"
#include "mesh/vertex_order_impl.hpp"

namespace meniscus {

namespace {

struct Box {
  Vec3f lo{std::numeric_limits<float>::max(), std::numeric_limits<float>::max(), std::numeric_limits<float>::max()};
  Vec3f hi{-std::numeric_limits<float>::max(), -std::numeric_limits<float>::max(), -std::numeric_limits<float>::max()};
  void add(Vec3f p) {
    lo = min(lo, p);
    hi = max(hi, p);
  }
};

template <class T>
void permute(std::vector<T>& values, const std::vector<uint32_t>& old_of_new) {
  if (values.empty()) return;
  // The reordered arrays are what the smoothing and the normals read at random: huge pages.
  std::vector<T> out;
  resize_huge(out, old_of_new.size());
  tbb::parallel_for(std::size_t(0), old_of_new.size(), [&](std::size_t i) { out[i] = values[old_of_new[i]]; });
  values.swap(out);
}

}  // namespace

void reorder_vertices_spatially(TriangleMesh& mesh) {
  const std::size_t nv = mesh.vertices.size();
  if (nv < 2) return;
  const std::vector<Vec3f>& x = mesh.vertices;
  const Box box = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, nv, 4096), Box{},
      [&](const auto& r, Box b) {
        for (std::size_t i = r.begin(); i != r.end(); ++i) b.add(x[i]);
        return b;
      },
      [](Box a, const Box& b) {
        a.add(b.lo);
        a.add(b.hi);
        return a;
      });
  const float scale = morton_scale(box.lo, box.hi);

  // Key: 30 Morton bits above the 32-bit old index (the payload keeps the sort stable).
  std::vector<uint64_t> keys(nv);
  tbb::parallel_for(std::size_t(0), nv, [&](std::size_t i) { keys[i] = uint64_t(morton_key(x[i], box.lo, scale)) << 32 | i; });
  radix_sort(keys, 32, 62);
  std::vector<uint32_t> old_of_new(nv), new_of_old(nv);
  tbb::parallel_for(std::size_t(0), nv, [&](std::size_t i) {
    old_of_new[i] = uint32_t(keys[i]);
    new_of_old[old_of_new[i]] = uint32_t(i);
  });
  permute(mesh.vertices, old_of_new);
  permute(mesh.normals, old_of_new);
  for (Attribute& a : mesh.attributes) {
    if (a.values.empty()) continue;
    const std::size_t k = std::size_t(a.components);
    std::vector<float> out(a.values.size());
    tbb::parallel_for(std::size_t(0), nv, [&](std::size_t i) {
      std::copy_n(a.values.begin() + std::ptrdiff_t(old_of_new[i] * k), k, out.begin() + std::ptrdiff_t(i * k));
    });
    a.values.swap(out);
  }

  // Triangles by their smallest new vertex, then by their old position.
  const std::size_t nt = mesh.triangles.size();
  std::vector<uint64_t> tri_keys(nt);
  tbb::parallel_for(std::size_t(0), nt, [&](std::size_t t) {
    Triangle& tri = mesh.triangles[t];
    for (uint32_t& v : tri) v = new_of_old[v];
    tri_keys[t] = uint64_t(std::min({tri[0], tri[1], tri[2]})) << 32 | t;
  });
  radix_sort(tri_keys, 32, 64);
  std::vector<Triangle> sorted;
  resize_huge(sorted, nt);
  tbb::parallel_for(std::size_t(0), nt, [&](std::size_t t) { sorted[t] = mesh.triangles[uint32_t(tri_keys[t])]; });
  mesh.triangles.swap(sorted);
}

}  // namespace meniscus
