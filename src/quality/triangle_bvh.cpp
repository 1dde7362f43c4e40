// meniscus — closest-point and inside queries through Embree's BVH (Wald et al. 2014); the
// per-triangle tests are ours (mesh/closest_point_impl.hpp, mesh/ray_parity_impl.hpp).
#include "quality/triangle_bvh.hpp"

#include <embree3/rtcore.h>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>

#include "common/primitives.hpp"
#include "meniscus/errors.hpp"
#include "mesh/closest_point_impl.hpp"
#include "mesh/ray_parity_impl.hpp"

namespace meniscus {
namespace {

const char* embree_error_name(RTCError e) {
  switch (e) {
    case RTC_ERROR_NONE:
      return "no error";
    case RTC_ERROR_INVALID_ARGUMENT:
      return "invalid argument";
    case RTC_ERROR_INVALID_OPERATION:
      return "invalid operation";
    case RTC_ERROR_OUT_OF_MEMORY:
      return "out of memory";
    case RTC_ERROR_UNSUPPORTED_CPU:
      return "unsupported CPU";
    case RTC_ERROR_CANCELLED:
      return "cancelled";
    default:
      return "unknown error";
  }
}

void check(RTCDevice device, const char* what) {
  const RTCError e = rtcGetDeviceError(device);
  if (e != RTC_ERROR_NONE) throw ResourceError(fmt::format("Embree: {} failed: {}", what, embree_error_name(e)));
}

/// One Embree device for the process (it owns Embree's thread set-up; creating one per query
/// would cost a millisecond each time). Thread-safe; never released before exit.
RTCDevice shared_device() {
  static std::once_flag once;
  static RTCDevice device = nullptr;
  std::call_once(once, [] {
    device = rtcNewDevice(nullptr);
    if (!device)
      throw ResourceError(
          fmt::format("Embree: rtcNewDevice failed: {}", embree_error_name(rtcGetDeviceError(nullptr))));
  });
  return device;
}

/// The geometry's user data: what the bounds and intersect callbacks read.
struct MeshView {
  const Vec3f* v;
  const Triangle* t;
  float pad;  ///< every box grows by this much on each side, so float traversal is conservative
};

void triangle_bounds(const RTCBoundsFunctionArguments* args) {
  const auto& m = *static_cast<const MeshView*>(args->geometryUserPtr);
  const Triangle& t = m.t[args->primID];
  const Vec3f lo = min(min(m.v[t[0]], m.v[t[1]]), m.v[t[2]]), hi = max(max(m.v[t[0]], m.v[t[1]]), m.v[t[2]]);
  RTCBounds* b = args->bounds_o;
  b->lower_x = lo.x - m.pad, b->lower_y = lo.y - m.pad, b->lower_z = lo.z - m.pad;
  b->upper_x = hi.x + m.pad, b->upper_y = hi.y + m.pad, b->upper_z = hi.z + m.pad;
}

/// A ray query's context: Embree hands the RTCIntersectContext (the first member) to the
/// intersect callback, which reads the exact origin and counts the crossings.
struct ParityContext {
  RTCIntersectContext context;
  double px, py, pz;
  int crossings;
};

void count_crossing(const RTCIntersectFunctionNArguments* args) {
  if (!args->valid[0]) return;
  const auto& m = *static_cast<const MeshView*>(args->geometryUserPtr);
  auto* c = reinterpret_cast<ParityContext*>(args->context);
  const Triangle& t = m.t[args->primID];
  c->crossings += ray_crosses(m.v[t[0]], m.v[t[1]], m.v[t[2]], c->px, c->py, c->pz);
  // No hit is reported: tfar stays infinite and the traversal goes on to every box on the line.
}

struct ClosestQuery {
  Vec3f p;
  const MeshView* m;
  TriangleBvh::Closest* result;
  float best2;
};

bool closer_triangle(RTCPointQueryFunctionArguments* args) {
  auto& q = *static_cast<ClosestQuery*>(args->userPtr);
  const Triangle& t = q.m->t[args->primID];
  const Vec3f* v = q.m->v;
  const float d2 = length2(closest_point_on_triangle(q.p, v[t[0]], v[t[1]], v[t[2]]) - q.p);
  ++q.result->triangle_tests;
  if (!(d2 < q.best2)) return false;
  q.best2 = d2;
  q.result->triangle = args->primID;
  args->query->radius = std::sqrt(d2);  // only nodes nearer than this are visited from now on
  return true;
}

}  // namespace

struct TriangleBvh::Impl {
  RTCScene scene = nullptr;
  MeshView view{};
  RayParityFrame frame{};
  ~Impl() {
    if (scene) rtcReleaseScene(scene);
  }
};

TriangleBvh::TriangleBvh(std::span<const Vec3f> vertices, std::span<const Triangle> triangles)
    : vertices_(vertices), triangles_(triangles), impl_(std::make_unique<Impl>()) {
  if (triangles.empty()) return;
  if (triangles.size() > std::numeric_limits<uint32_t>::max() - 1)
    throw ResourceError(fmt::format("TriangleBvh: {} triangles exceed the 32-bit primitive ids", triangles.size()));
  struct Box {
    Vec3f lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
  };
  const Box box = reduce(
      triangles.size(), 4096, Box{},
      [&](std::size_t begin, std::size_t end, Box b) {
        for (std::size_t i = begin; i != end; ++i)
          for (uint32_t k : triangles[i]) {
            if (k >= vertices.size())
              throw std::invalid_argument(
                  fmt::format("TriangleBvh: triangle {} names vertex {} of {}", i, k, vertices.size()));
            b.lo = min(b.lo, vertices[k]), b.hi = max(b.hi, vertices[k]);
          }
        return b;
      },
      [](Box a, const Box& b) {
        return Box{min(a.lo, b.lo), max(a.hi, b.hi)};
      });
  impl_->frame = ray_parity_frame(box.lo, box.hi, triangles.size());
  // The pad exceeds the float rounding of any coordinate in the box and the ray's nudge
  // (at most 2.4e-7 of the extent), so no box Embree tests in float misses a candidate.
  const float reach = std::max({std::abs(box.lo.x), std::abs(box.lo.y), std::abs(box.lo.z), std::abs(box.hi.x),
                                std::abs(box.hi.y), std::abs(box.hi.z), length(box.hi - box.lo)});
  impl_->view = {vertices.data(), triangles.data(), std::max(1e-6f * reach, std::numeric_limits<float>::min())};

  const RTCDevice device = shared_device();
  impl_->scene = rtcNewScene(device);
  check(device, "rtcNewScene");
  rtcSetSceneFlags(impl_->scene, RTC_SCENE_FLAG_ROBUST);
  // Embree's Morton builder: much faster to build than its SAH builder on our meshes, whose
  // triangles are small and evenly sized, for the same query times (one BVH serves one query set).
  rtcSetSceneBuildQuality(impl_->scene, RTC_BUILD_QUALITY_LOW);
  RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_USER);
  check(device, "rtcNewGeometry");
  rtcSetGeometryBuildQuality(g, RTC_BUILD_QUALITY_LOW);
  rtcSetGeometryUserPrimitiveCount(g, unsigned(triangles.size()));
  rtcSetGeometryUserData(g, &impl_->view);
  rtcSetGeometryBoundsFunction(g, triangle_bounds, nullptr);
  rtcSetGeometryIntersectFunction(g, count_crossing);
  rtcCommitGeometry(g);
  rtcAttachGeometry(impl_->scene, g);
  rtcReleaseGeometry(g);
  rtcCommitScene(impl_->scene);
  check(device, "building the BVH (rtcCommitScene)");
}

TriangleBvh::~TriangleBvh() = default;

TriangleBvh::Closest TriangleBvh::closest(Vec3f p, float max_distance) const {
  Closest result;
  if (empty() || !(max_distance >= 0)) return result;
  ClosestQuery q{p, &impl_->view, &result, max_distance * max_distance};
  RTCPointQuery query;
  query.x = p.x, query.y = p.y, query.z = p.z;
  query.radius = max_distance, query.time = 0;
  RTCPointQueryContext context;
  rtcInitPointQueryContext(&context);
  rtcPointQuery(impl_->scene, &query, &context, closer_triangle, &q);
  if (result.triangle != UINT32_MAX) result.distance = std::sqrt(q.best2);
  return result;
}

bool TriangleBvh::inside(Vec3f p) const {
  if (empty()) return false;
  ParityContext c;
  rtcInitIntersectContext(&c.context);
  if (!ray_parity_origin(impl_->frame, p, &c.px, &c.py, &c.pz)) return false;
  c.crossings = 0;
  RTCRayHit rh{};
  rh.ray.org_x = p.x, rh.ray.org_y = p.y, rh.ray.org_z = p.z;
  rh.ray.dir_x = 1, rh.ray.dir_y = 0, rh.ray.dir_z = 0;
  rh.ray.tnear = 0, rh.ray.tfar = INFINITY;
  rh.ray.mask = UINT32_MAX;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(impl_->scene, &c.context, &rh);
  return c.crossings % 2 == 1;
}

}  // namespace meniscus
