// meniscus bench — mesh metrics shared by the comparison driver: library quality reports,
// the particles left outside (a sample through the library's ray-parity test) and the top-face flatness of the block scene.
#include "metrics.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "meniscus/quality.hpp"

namespace meniscus::bench {
std::size_t points_outside(const TriangleMesh& mesh, std::span<const Vec3f> points, std::size_t max_samples,
                           std::size_t* sampled) {
  const std::size_t stride = std::max<std::size_t>(1, points.size() / std::max<std::size_t>(max_samples, 1));
  std::vector<Vec3f> sample;
  for (std::size_t i = 0; i < points.size() && sample.size() < max_samples; i += stride) sample.push_back(points[i]);
  if (sampled) *sampled = sample.size();
  return meniscus::points_outside(mesh, sample);  // the library's ray-parity test (meniscus inspect uses it too)
}

MeshQuality measure_quality(const TriangleMesh& mesh, const Scene& scene, std::size_t max_samples) {
  MeshQuality q;
  const TopologyReport topo = analyze_topology(mesh);
  q.vertices = topo.vertices;
  q.triangles = topo.triangles;
  q.components = topo.components;
  q.watertight = topo.watertight();
  q.genus = topo.watertight() ? topo.genus() : -1;
  const double d = scene.spacing;
  q.volume_over_nd3 = std::abs(signed_volume(mesh)) / (double(scene.particles.size()) * d * d * d);
  const ValenceReport val = valence(mesh);
  q.min_valence = val.min;
  q.share_valence_below_5 = topo.vertices ? double(val.below_5) / double(topo.vertices) : 0;
  const AngleReport ang = triangle_angles(mesh);
  q.min_angle_degrees = ang.min_degrees;
  q.share_angles_below_10 = ang.share_below_10;
  q.outside = points_outside(mesh, scene.particles.positions, max_samples, &q.sampled);

  if (scene.has_flat_top) {
    // Area-weighted normals computed here (not taken from the mesh) so both tools' meshes are
    // judged alike; |n.z| because OpenVDB's winding may differ from ours.
    std::vector<Vec3f> n(mesh.vertices.size());
    for (const Triangle& t : mesh.triangles) {
      const Vec3f c = cross(mesh.vertices[t[1]] - mesh.vertices[t[0]], mesh.vertices[t[2]] - mesh.vertices[t[0]]);
      for (uint32_t v : t) n[v] += c;
    }
    // Vertices of the top face: facing up, above the top particle layer, and at least 3 d
    // inside its xy edges, where the rounded rim does not count as "not flat".
    const float margin = 3 * scene.spacing;
    std::vector<Vec3f> top;
    for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
      const Vec3f v = mesh.vertices[i];
      if (std::abs(normalized(n[i]).z) > 0.9f && v.z > scene.top_lo.z && v.x > scene.top_lo.x + margin &&
          v.x < scene.top_hi.x - margin && v.y > scene.top_lo.y + margin && v.y < scene.top_hi.y - margin)
        top.push_back(v);
    }
    if (top.size() >= 3) {
      const PlaneFit fit = fit_plane(top);
      q.flatness_rms_over_d = fit.rms / double(scene.spacing);
      q.flatness_vertices = fit.count;
    }
  }
  return q;
}

}  // namespace meniscus::bench
