// meniscus — the per-particle stages of the field methods on the device (issue #7): Yu & Turk's
// centres and ellipsoids (anisotropy_impl.hpp, as on the CPU), the reordering of per-particle data
// into the grid's order, the constraint shells, the velocity weights, and the small reductions
// (bounds, largest axis) the host needs to size the next stage.
#include <climits>
#include <cstring>

#include "cuda/stages_cuda.hpp"
#include "field/anisotropy_impl.hpp"
#include "transfer/velocity_weight_impl.hpp"

namespace meniscus::cuda {

namespace {

/// A float as an int with the same order (for atomicMin/atomicMax; min and max do not depend on
/// the order of the updates, so the result is exact and deterministic).
__device__ inline int ordered_bits(float f) {
  const int i = __float_as_int(f);
  return i >= 0 ? i : i ^ 0x7fffffff;
}
float from_ordered_bits(int i) {
  const int b = i >= 0 ? i : i ^ 0x7fffffff;
  float f;
  std::memcpy(&f, &b, sizeof f);
  return f;
}

__global__ void bounds_kernel(const Vec3f* points, uint64_t n, int* out) {  // out: min x y z, max x y z
  int lo[3] = {INT_MAX, INT_MAX, INT_MAX}, hi[3] = {INT_MIN, INT_MIN, INT_MIN};
  MENISCUS_GRID_STRIDE(i, n) {
    for (int a = 0; a < 3; ++a) {
      const int v = ordered_bits(points[i][a]);
      lo[a] = v < lo[a] ? v : lo[a];
      hi[a] = v > hi[a] ? v : hi[a];
    }
  }
  // One atomic per warp (every thread of the block reaches this line: the loop above has no exit).
  for (int a = 0; a < 3; ++a) {
    lo[a] = __reduce_min_sync(0xffffffffu, lo[a]);
    hi[a] = __reduce_max_sync(0xffffffffu, hi[a]);
    if ((threadIdx.x & 31) == 0) {
      atomicMin(&out[a], lo[a]);
      atomicMax(&out[3 + a], hi[a]);
    }
  }
}

__global__ void max_axis_kernel(const Ellipsoid* e, uint64_t n, int* out) {
  int m = 0;  // ordered_bits(0.0f)
  MENISCUS_GRID_STRIDE(i, n) {
    const int v = ordered_bits(e[i].max_axis);
    m = v > m ? v : m;
  }
  m = __reduce_max_sync(0xffffffffu, m);
  if ((threadIdx.x & 31) == 0) atomicMax(out, m);
}

__global__ void frames_kernel(GridView g, const uint32_t* order, uint64_t n, float pca_radius, AnisotropyConstants k,
                              float smooth_radius, float lambda, float centre_reach, Vec3f* centres,
                              Ellipsoid* ellipsoids) {
  MENISCUS_GRID_STRIDE(i, n) {
    const uint32_t o = order[i];
    if (ellipsoids != nullptr) ellipsoids[o] = particle_ellipsoid(g, uint32_t(i), pca_radius, k);
    if (centres != nullptr) {
      const Vec3f p = g.point(uint32_t(i));
      const Vec3f c = lambda > 0 ? smoothed_position(g, uint32_t(i), smooth_radius, lambda) : p;
      centres[o] = ellipsoids != nullptr && lambda > 0 ? centre_holding_particle(p, c, ellipsoids[o], centre_reach) : c;
    }
  }
}

template <class T>
__global__ void gather_kernel(const T* values, const uint32_t* order, uint64_t n, T* out) {
  MENISCUS_GRID_STRIDE(i, n) { out[i] = values[order[i]]; }
}

__global__ void shells_kernel(const Ellipsoid* e, uint64_t n, Ellipsoid* out) {
  MENISCUS_GRID_STRIDE(i, n) { out[i] = unit_volume_shell(e[i]); }
}

__global__ void velocity_weight_kernel(const float* v, uint64_t n, float reference, float min_weight, float* w) {
  MENISCUS_GRID_STRIDE(i, n) { w[i] = velocity_weight(Vec3f{v[3 * i], v[3 * i + 1], v[3 * i + 2]}, reference, min_weight); }
}

template <class T>
DeviceBuffer<T> gather(const DeviceGrid& grid, const DeviceBuffer<T>& values) {
  DeviceBuffer<T> out(grid.count);
  if (grid.count > 0) {
    MENISCUS_LAUNCH(gather_kernel<T>, blocks_for(grid.count), 256)(values.data(), grid.order.data(), grid.count, out.data());
    MENISCUS_CUDA_CHECK_LAUNCH();
  }
  return out;
}

}  // namespace

void point_bounds(const DeviceBuffer<Vec3f>& points, uint32_t count, Vec3f* lo, Vec3f* hi) {
  DeviceBuffer<int> out(6);
  const int init[6] = {INT_MAX, INT_MAX, INT_MAX, INT_MIN, INT_MIN, INT_MIN};
  MENISCUS_CUDA_CHECK(counted_memcpy(out.data(), init, sizeof init, cudaMemcpyHostToDevice));
  MENISCUS_LAUNCH(bounds_kernel, blocks_for(count), 256)(points.data(), count, out.data());
  MENISCUS_CUDA_CHECK_LAUNCH();
  int b[6];
  out.download(b, 6);
  *lo = {from_ordered_bits(b[0]), from_ordered_bits(b[1]), from_ordered_bits(b[2])};
  *hi = {from_ordered_bits(b[3]), from_ordered_bits(b[4]), from_ordered_bits(b[5])};
}

float max_ellipsoid_axis(const DeviceBuffer<Ellipsoid>& ellipsoids, uint32_t count) {
  DeviceBuffer<int> out(1);
  out.zero();
  MENISCUS_LAUNCH(max_axis_kernel, blocks_for(count), 256)(ellipsoids.data(), count, out.data());
  MENISCUS_CUDA_CHECK_LAUNCH();
  return from_ordered_bits(out.get(0));
}

void particle_frames(const DeviceGrid& raw, float pca_radius, const AnisotropyConstants& k, float smooth_radius,
                     float lambda, DeviceBuffer<Vec3f>* centres, DeviceBuffer<Ellipsoid>* ellipsoids,
                     float centre_reach) {
  if (centres != nullptr) centres->resize(raw.count);
  if (ellipsoids != nullptr) ellipsoids->resize(raw.count);
  if (raw.count == 0) return;
  MENISCUS_LAUNCH(frames_kernel, blocks_for(raw.count, 128), 128)(raw.view(), raw.order.data(), raw.count, pca_radius, k,
                                                     smooth_radius, lambda, centre_reach,
                                                     centres != nullptr ? centres->data() : nullptr,
                                                     ellipsoids != nullptr ? ellipsoids->data() : nullptr);
  MENISCUS_CUDA_CHECK_LAUNCH();
}

DeviceBuffer<float> to_sorted_order(const DeviceGrid& grid, const DeviceBuffer<float>& values) {
  return gather(grid, values);
}
DeviceBuffer<Ellipsoid> to_sorted_order(const DeviceGrid& grid, const DeviceBuffer<Ellipsoid>& values) {
  return gather(grid, values);
}

DeviceBuffer<Ellipsoid> unit_volume_shells(const DeviceBuffer<Ellipsoid>& ellipsoids) {
  DeviceBuffer<Ellipsoid> out(ellipsoids.size());
  if (!ellipsoids.size()) return out;
  MENISCUS_LAUNCH(shells_kernel, blocks_for(ellipsoids.size()), 256)(ellipsoids.data(), ellipsoids.size(), out.data());
  MENISCUS_CUDA_CHECK_LAUNCH();
  return out;
}

DeviceBuffer<float> velocity_weights(const DeviceBuffer<float>& velocity, std::size_t vertices, float reference,
                                     float min_weight) {
  DeviceBuffer<float> w(vertices);
  if (vertices == 0) return w;
  MENISCUS_LAUNCH(velocity_weight_kernel, blocks_for(vertices), 256)(velocity.data(), vertices, reference, min_weight, w.data());
  MENISCUS_CUDA_CHECK_LAUNCH();
  return w;
}

}  // namespace meniscus::cuda
