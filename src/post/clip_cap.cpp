// meniscus — closing a box cut with the box's faces (post/clip.hpp): per face, a constrained
// Delaunay triangulation (CGAL's Constrained_Delaunay_triangulation_2, exact predicates) of the
// cut's curves and the face's edges, and the regions of it inside the uncut surface.
#include <CGAL/Constrained_Delaunay_triangulation_2.h>
#include <CGAL/Constrained_triangulation_face_base_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_face_base_with_info_2.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>

#include <algorithm>
#include <cstdint>
#include <utility>
#include <vector>

#include "post/clip.hpp"
#include "mesh/directed_edges.hpp"

namespace meniscus {

namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
/// A vertex's mesh index; kCorner + k for the box's corner k; kSteiner for a point CGAL made
/// where two constraints cross.
constexpr uint32_t kSteiner = UINT32_MAX, kCorner = UINT32_MAX - 8;
struct VertexInfo {
  uint32_t id = kSteiner;
};
using VertexBase = CGAL::Triangulation_vertex_base_with_info_2<VertexInfo, Kernel>;
using FaceBase = CGAL::Constrained_triangulation_face_base_2<Kernel, CGAL::Triangulation_face_base_with_info_2<int, Kernel>>;
using Cdt = CGAL::Constrained_Delaunay_triangulation_2<Kernel, CGAL::Triangulation_data_structure_2<VertexBase, FaceBase>,
                                                      CGAL::Exact_predicates_tag>;

/// Corner k of the box: bit c of k chooses the max of axis c.
Vec3f corner(const ClipBox& box, uint32_t k) {
  return {box[(k & 1) ? 3 : 0], box[(k & 2) ? 4 : 1], box[(k & 4) ? 5 : 2]};
}

}  // namespace

const char* clip_cap_unavailable() { return nullptr; }

void cap_box_faces(TriangleMesh& mesh, const ClipBox& box, const TriangleBvh& inside, ClipOutcome& outcome) {
  // The cut's curves: the directed edges no triangle runs the other way.
  const std::vector<EdgeKey> open = open_edges(sorted_directed_edges(mesh.triangles));
  std::vector<uint32_t> cut_vertices;
  for (const EdgeKey e : open) cut_vertices.push_back(edge_from(e)), cut_vertices.push_back(edge_to(e));
  std::sort(cut_vertices.begin(), cut_vertices.end());
  cut_vertices.erase(std::unique(cut_vertices.begin(), cut_vertices.end()), cut_vertices.end());
  uint32_t corner_vertex[8];
  std::fill(std::begin(corner_vertex), std::end(corner_vertex), kSteiner);

  for (int face = 0; face < 6; ++face) {
    const int a = face / 2, u = (a + 1) % 3, v = (a + 2) % 3;
    const bool upper = face % 2 == 1;
    const float value = box[std::size_t(a + (upper ? 3 : 0))];
    const auto on_face = [&](uint32_t i) { return mesh.vertices[i][a] == value; };
    Cdt cdt;
    const auto point = [&](Vec3f x) { return Kernel::Point_2(double(x[u]), double(x[v])); };
    // The face's corners, and its four edges through the cut's vertices on them, as constraints.
    std::vector<std::pair<double, Cdt::Vertex_handle>> side[4];  // u = min, u = max, v = min, v = max
    for (uint32_t k = 0; k < 8; ++k) {
      if (((k >> a) & 1) != uint32_t(upper)) continue;
      const Vec3f x = corner(box, k);
      const Cdt::Vertex_handle h = cdt.insert(point(x));
      h->info().id = kCorner + k;
      side[(k >> u) & 1].emplace_back(double(x[v]), h);
      side[2 + ((k >> v) & 1)].emplace_back(double(x[u]), h);
    }
    for (const uint32_t i : cut_vertices) {
      if (!on_face(i)) continue;
      const Vec3f x = mesh.vertices[i];
      const Cdt::Vertex_handle h = cdt.insert(point(x));
      h->info().id = i;
      if (x[u] == box[std::size_t(u)] || x[u] == box[std::size_t(u) + 3]) side[x[u] == box[std::size_t(u)] ? 0 : 1].emplace_back(double(x[v]), h);
      if (x[v] == box[std::size_t(v)] || x[v] == box[std::size_t(v) + 3]) side[x[v] == box[std::size_t(v)] ? 2 : 3].emplace_back(double(x[u]), h);
    }
    for (auto& s : side) {
      std::sort(s.begin(), s.end(), [](const auto& l, const auto& r) { return l.first < r.first; });
      for (std::size_t k = 1; k < s.size(); ++k)
        if (s[k - 1].second != s[k].second) cdt.insert_constraint(s[k - 1].second, s[k].second);
    }
    for (const EdgeKey e : open)
      if (on_face(edge_from(e)) && on_face(edge_to(e)))
        cdt.insert_constraint(point(mesh.vertices[edge_from(e)]), point(mesh.vertices[edge_to(e)]));

    // Regions between the constraints; each is inside the uncut surface or not, as a whole.
    for (auto f = cdt.finite_faces_begin(); f != cdt.finite_faces_end(); ++f) f->info() = -1;
    std::vector<bool> region_inside;
    for (auto seed = cdt.finite_faces_begin(); seed != cdt.finite_faces_end(); ++seed) {
      if (seed->info() >= 0) continue;
      const int region = int(region_inside.size());
      std::vector<Cdt::Face_handle> stack{seed};
      seed->info() = region;
      double largest = -1;
      Kernel::Point_2 probe;
      while (!stack.empty()) {
        const Cdt::Face_handle f = stack.back();
        stack.pop_back();
        const double area = std::abs(CGAL::area(f->vertex(0)->point(), f->vertex(1)->point(), f->vertex(2)->point()));
        if (area > largest) largest = area, probe = CGAL::centroid(f->vertex(0)->point(), f->vertex(1)->point(), f->vertex(2)->point());
        for (int i = 0; i < 3; ++i) {
          const Cdt::Face_handle n = f->neighbor(i);
          if (cdt.is_infinite(n) || n->info() >= 0 || f->is_constrained(i)) continue;
          n->info() = region;
          stack.push_back(n);
        }
      }
      Vec3f x;
      x[a] = value, x[u] = float(probe.x()), x[v] = float(probe.y());
      region_inside.push_back(inside.inside(x));
    }

    // The inside regions' triangles, facing out of the box: counter-clockwise in (u, v) faces +a.
    const Vec3f outward = [&] { Vec3f n{0, 0, 0}; n[a] = upper ? 1.0f : -1.0f; return n; }();
    for (auto f = cdt.finite_faces_begin(); f != cdt.finite_faces_end(); ++f) {
      if (!region_inside[std::size_t(f->info())]) continue;
      Triangle t;
      bool steiner = false;
      for (int i = 0; i < 3; ++i) {
        uint32_t id = f->vertex(i)->info().id;
        if (id == kSteiner) steiner = true;
        t[std::size_t(i)] = id;
      }
      if (steiner) continue;  // left open: counted below
      for (int i = 0; i < 3; ++i) {
        uint32_t& id = t[std::size_t(i)];
        if (id < kCorner) continue;
        uint32_t& made = corner_vertex[id - kCorner];
        if (made == kSteiner) {  // the corner's first use: a new vertex
          const uint32_t neighbour = std::min({t[0], t[1], t[2]});
          made = uint32_t(mesh.vertices.size());
          mesh.vertices.push_back(corner(box, id - kCorner));
          if (!mesh.normals.empty()) mesh.normals.push_back(outward);
          for (Attribute& attribute : mesh.attributes) {
            const std::size_t k = std::size_t(attribute.components);
            for (std::size_t c = 0; c < k; ++c)
              attribute.values.push_back(neighbour < kCorner ? attribute.values[neighbour * k + c] : 0.0f);
          }
        }
        id = made;
      }
      if (!upper) std::swap(t[1], t[2]);
      mesh.triangles.push_back(t);
      ++outcome.cap_triangles;
    }
  }
  outcome.cap_defects = open_edges(sorted_directed_edges(mesh.triangles)).size();
}

}  // namespace meniscus
