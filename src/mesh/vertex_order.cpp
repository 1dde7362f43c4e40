// meniscus — Morton-order vertex renumbering (Morton 1966; the usual locality order of GPU and
// CPU mesh pipelines, e.g. Karras 2012 for BVH construction).
#include "mesh/vertex_order.hpp"

#include <algorithm>
#include <bit>
#include <limits>

#include "common/for_each.hpp"
#include "common/huge_pages.hpp"
#include "common/radix_sort.hpp"
#include "system/memory_scope.hpp"
#include "mesh/vertex_order_impl.hpp"

namespace meniscus {

namespace {

/// values[i] = the old values[old_of_new(i)] for the n new indices i.
template <class T, class OldOfNew>
void permute(std::vector<T>& values, std::size_t n, OldOfNew&& old_of_new) {
  if (values.empty()) return;
  // The reordered arrays are what the smoothing and the normals read at random: huge pages.
  std::vector<T> out;
  resize_huge(out, n);
  for_each_index(n, [&](std::size_t i) { out[i] = values[old_of_new(i)]; });
  values.swap(out);
}

}  // namespace

void reorder_vertices_spatially(TriangleMesh& mesh, float cell) {
  const std::size_t nv = mesh.vertices.size();
  if (nv < 2) return;
  const std::vector<Vec3f>& x = mesh.vertices;
  const float inv_cell = 1.0f / cell;

  // Key: 30 Morton bits above the 32-bit old index (the payload keeps the sort stable).
  std::vector<uint64_t> keys(nv);
  for_each_index(nv, [&](std::size_t i) { keys[i] = uint64_t(morton_key(x[i], inv_cell)) << 32 | i; });
  radix_sort(keys, 32, 62);
  // The sorted keys' payloads are the old indices in the new order: the permutation, without an
  // array of its own (on a large frame this function's arrays can set the whole run's peak).
  {
    auto old_of_new = [&](std::size_t i) { return uint32_t(keys[i]); };
    permute(mesh.vertices, nv, old_of_new);
    permute(mesh.normals, nv, old_of_new);
    for (Attribute& a : mesh.attributes) {
      if (a.values.empty()) continue;
      const std::size_t k = std::size_t(a.components);
      std::vector<float> out(a.values.size());
      for_each_index(nv, [&](std::size_t i) {
        std::copy_n(a.values.begin() + std::ptrdiff_t(old_of_new(i) * k), k, out.begin() + std::ptrdiff_t(i * k));
      });
      a.values.swap(out);
    }
  }
  std::vector<uint32_t> new_of_old(nv);
  for_each_index(nv, [&](std::size_t i) { new_of_old[uint32_t(keys[i])] = uint32_t(i); });
  std::vector<uint64_t>().swap(keys);

  // The triangles renumbered in place, then sorted (stably: ties keep their old order) by their
  // smallest new vertex — the triangles themselves, with one scratch copy and no keys.
  for_each_index(mesh.triangles.size(), [&](std::size_t t) {
    for (uint32_t& v : mesh.triangles[t]) v = new_of_old[v];
  });
  std::vector<uint32_t>().swap(new_of_old);
  // The old positions (and normals) were freed above; the extraction placed them in the heap
  // (HeapReuseScope), where they would stay resident through the sort's copy of the triangles
  // and raise the run's peak above its live arrays.
  give_back_free_heap_pages();
  radix_sort_by(mesh.triangles, [](const Triangle& t) { return std::min({t[0], t[1], t[2]}); }, 0,
                int(std::bit_width(nv - 1)));
}

}  // namespace meniscus
