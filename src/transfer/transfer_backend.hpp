// meniscus — attribute transfer written once over the backend tag: the per-vertex work of
// transfer_impl.hpp over a GridView, run by for_each_index (transfer_device.cu runs it on the
// device). The CPU's stage (attribute_transfer.cpp) runs the same transfer_vertex over its HashGrid.
#pragma once

#include <cstddef>

#include "common/buffer.hpp"
#include "grid/grid_buffers.hpp"
#include "mesh/mesh_buffers.hpp"
#include "transfer/transfer_impl.hpp"

namespace meniscus {

/// transfer_vertex over a GridView.
struct TransferVertex {
  GridView grid;
  TransferData d;
  MENISCUS_HD void operator()(uint64_t v) const { transfer_vertex(grid, d, v); }
};

/// The attribute `values` (original particle order, `components` per particle) on every vertex of
/// `mesh`: components per vertex.
template <class B>
BufferOf<B, float> transfer_attribute(B b, const BufferOf<B, float>& values, int components, const GridBuffers<B>& grid,
                                      const MeshBuffers<B>& mesh, float radius) {
  BufferOf<B, float> out(mesh.vertex_count * std::size_t(components));
  if (components == 0) return out;
  const TransferData d{values.data(), components, grid.order.data(), mesh.vertices.data(), radius, out.data()};
  for_each_index(b, mesh.vertex_count, TransferVertex{grid.view(), d});
  return out;
}

}  // namespace meniscus
