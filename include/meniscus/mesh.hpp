// meniscus — the triangle mesh the pipeline produces.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "meniscus/particles.hpp"
#include "meniscus/vec.hpp"

namespace meniscus {

using Triangle = std::array<uint32_t, 3>;

/// An indexed triangle mesh. Triangles are counter-clockwise seen from outside the fluid
/// (their normal points from the fluid into the air). `normals` is empty or one per vertex;
/// every attribute has one element per vertex.
struct TriangleMesh {
  std::vector<Vec3f> vertices;
  std::vector<Triangle> triangles;
  std::vector<Vec3f> normals;
  std::vector<Attribute> attributes;

  const Attribute* find(const std::string& name) const;
};

}  // namespace meniscus
