#include <fmt/format.h>

#include "meniscus/errors.hpp"
#include "meniscus/mesh.hpp"
#include "meniscus/particles.hpp"

namespace meniscus {

namespace {
const Attribute* find_attribute(const std::vector<Attribute>& attributes, const std::string& name) {
  for (const Attribute& a : attributes)
    if (a.name == name) return &a;
  return nullptr;
}
}  // namespace

const Attribute* ParticleSet::find(const std::string& name) const { return find_attribute(attributes, name); }
const Attribute* TriangleMesh::find(const std::string& name) const { return find_attribute(attributes, name); }

void ParticleSet::validate() const {
  for (const Attribute& a : attributes) {
    if (a.components < 1)
      throw InvalidParameter(fmt::format("attribute '{}' has {} components", a.name, a.components));
    if (a.values.size() != positions.size() * std::size_t(a.components))
      throw InvalidParameter(fmt::format("attribute '{}' has {} values, expected {} ({} particles × {})", a.name,
                                         a.values.size(), positions.size() * std::size_t(a.components),
                                         positions.size(), a.components));
  }
}

}  // namespace meniscus
