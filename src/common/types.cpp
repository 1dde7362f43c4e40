#include <fmt/format.h>

#include <algorithm>

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

std::size_t ParticleSet::keep_if(const std::function<bool(Vec3f)>& keep) {
  const std::size_t n = positions.size();
  std::size_t kept = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!keep(positions[i])) continue;
    if (kept != i) {
      positions[kept] = positions[i];
      for (Attribute& a : attributes) {
        const std::size_t c = std::size_t(a.components);
        std::copy_n(a.values.begin() + std::ptrdiff_t(i * c), c, a.values.begin() + std::ptrdiff_t(kept * c));
      }
    }
    ++kept;
  }
  positions.resize(kept);
  for (Attribute& a : attributes) a.values.resize(kept * std::size_t(a.components));
  return n - kept;
}

void ParticleSet::validate() const { ParticlesView(*this).validate(); }

Attribute AttributeView::copy() const {
  return Attribute{std::string(name), components, integer, std::vector<float>(values.begin(), values.end())};
}

ParticlesView::ParticlesView(const ParticleSet& set)
    : positions(set.positions), attributes(set.attributes.begin(), set.attributes.end()) {}

const AttributeView* ParticlesView::find(std::string_view name) const {
  for (const AttributeView& a : attributes)
    if (a.name == name) return &a;
  return nullptr;
}

ParticleSet ParticlesView::copy() const {
  ParticleSet out;
  out.positions.assign(positions.begin(), positions.end());
  out.attributes.reserve(attributes.size());
  for (const AttributeView& a : attributes) out.attributes.push_back(a.copy());
  return out;
}

void ParticlesView::validate() const {
  for (const AttributeView& a : attributes) {
    if (a.components < 1)
      throw InvalidParameter(fmt::format("attribute '{}' has {} components", a.name, a.components));
    if (a.values.size() != positions.size() * std::size_t(a.components))
      throw InvalidParameter(fmt::format("attribute '{}' has {} values, expected {} ({} particles × {})", a.name,
                                         a.values.size(), positions.size() * std::size_t(a.components),
                                         positions.size(), a.components));
  }
}

}  // namespace meniscus
