// meniscus — particles and per-element attributes.
#pragma once

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "meniscus/vec.hpp"

namespace meniscus {

/// A named per-element attribute: `values` holds size() × components floats, element-major
/// (the components of element i are values[i*components .. i*components+components)).
/// Integer attributes (ids, flags) are stored as float; `integer` records that they were
/// integers in the file so writers can restore the type.
struct Attribute {
  std::string name;
  int components = 1;
  bool integer = false;
  std::vector<float> values;

  std::size_t size() const { return components > 0 ? values.size() / std::size_t(components) : 0; }
};

/// A set of particles: positions plus any number of per-particle attributes of the same length.
struct ParticleSet {
  std::vector<Vec3f> positions;
  std::vector<Attribute> attributes;

  std::size_t size() const { return positions.size(); }
  /// The attribute with this name, or nullptr.
  const Attribute* find(const std::string& name) const;
  /// Throws InvalidParameter if an attribute's length does not match the particle count.
  void validate() const;
  /// Keeps the particles whose position satisfies `keep`, in order, with their attribute values
  /// (in place); returns how many were dropped.
  std::size_t keep_if(const std::function<bool(Vec3f)>& keep);
};

}  // namespace meniscus
