// meniscus — attribute transfer by a smooth kernel-weighted mean (Zhu & Bridson 2005 weights), the
// per-vertex work shared with the device (transfer_impl.hpp).
#include "transfer/attribute_transfer.hpp"

#include "common/for_each.hpp"
#include "transfer/transfer_impl.hpp"

namespace meniscus {

Attribute transfer_attribute(const AttributeView& attribute, const HashGrid& grid, std::span<const Vec3f> vertices,
                             float radius) {
  Attribute out;
  out.name = attribute.name;
  out.components = attribute.components;
  out.integer = false;
  out.values.resize(vertices.size() * std::size_t(attribute.components));
  const TransferData d{attribute.values.data(), attribute.components, grid.order().data(), vertices.data(), radius,
                       out.values.data()};
  for_each_index(vertices.size(), 512, [&](std::size_t v) { transfer_vertex(grid, d, v); });
  return out;
}

}  // namespace meniscus
