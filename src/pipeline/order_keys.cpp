// meniscus — the vertex order keys that reconstruct_ordered gives each rank of an MPI job
// (meniscus/distributed.hpp): the keys one process's vertex order sorts by, carried from the
// extraction to the finished mesh as an attribute.
#include <fmt/format.h>

#include <algorithm>
#include <stdexcept>

#include "meniscus/distributed.hpp"
#include "mesh/vertex_order_impl.hpp"
#include "pipeline/internal.hpp"

namespace meniscus {

namespace {

// The key as one 93-bit number, the edge key (63 bits) below the Z-order code (30 bits), in four
// 24-bit words: integers under 2^24, which floats hold exactly.
constexpr int kKeyValues = 4;
constexpr uint64_t kWord = (uint64_t(1) << 24) - 1;

}  // namespace

Attribute order_key_attribute(std::span<const Vec3f> positions, const std::vector<uint64_t>& edge_keys, float cell) {
  if (edge_keys.size() != positions.size())
    throw std::logic_error(fmt::format("order keys: {} edge keys for {} vertices", edge_keys.size(), positions.size()));
  Attribute a{kOrderKeyAttribute, kKeyValues, true, std::vector<float>(positions.size() * kKeyValues)};
  // The same expression as reorder_vertices_spatially's, so that the code is the one it sorts by.
  const float inv_cell = cell > 0 ? 1.0f / cell : 0.0f;
  for (std::size_t v = 0; v < positions.size(); ++v) {
    const uint64_t morton = cell > 0 ? morton_key(positions[v], inv_cell) : 0, edge = edge_keys[v];
    float* out = a.values.data() + v * kKeyValues;
    out[0] = float(edge & kWord);
    out[1] = float((edge >> 24) & kWord);
    out[2] = float((edge >> 48) | ((morton << 15) & kWord));
    out[3] = float(morton >> 9);
  }
  return a;
}

std::vector<VertexOrderKey> take_order_keys(TriangleMesh& mesh) {
  const auto it = std::find_if(mesh.attributes.begin(), mesh.attributes.end(),
                               [](const Attribute& a) { return a.name == kOrderKeyAttribute; });
  if (it == mesh.attributes.end() || it->components != kKeyValues || it->values.size() != mesh.vertices.size() * kKeyValues)
    throw std::logic_error("order keys: the mesh has no order-key attribute for its vertices");
  std::vector<VertexOrderKey> keys(mesh.vertices.size());
  for (std::size_t v = 0; v < keys.size(); ++v) {
    const float* in = it->values.data() + v * kKeyValues;
    const uint64_t w0 = uint64_t(in[0]), w1 = uint64_t(in[1]), w2 = uint64_t(in[2]), w3 = uint64_t(in[3]);
    keys[v].edge = w0 | (w1 << 24) | ((w2 & 0x7fff) << 48);
    keys[v].morton = (w2 >> 15) | (w3 << 9);
  }
  mesh.attributes.erase(it);
  return keys;
}

}  // namespace meniscus
