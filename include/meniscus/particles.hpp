// meniscus — particles and per-element attributes.
#pragma once

#include <cstddef>
#include <functional>
#include <span>
#include <string>
#include <string_view>
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

/// An attribute read in place: `values` holds size() × components floats, element-major, as in
/// Attribute, in memory its owner keeps unchanged while a call reads it. An Attribute is one.
struct AttributeView {
  std::string_view name;
  int components = 1;
  bool integer = false;
  std::span<const float> values;
  AttributeView() = default;
  AttributeView(std::string_view name_, int components_, bool integer_, std::span<const float> values_)
      : name(name_), components(components_), integer(integer_), values(values_) {}
  AttributeView(const Attribute& a)  // NOLINT(google-explicit-constructor): an Attribute is a view of itself
      : name(a.name), components(a.components), integer(a.integer), values(a.values) {}
  std::size_t size() const { return components > 0 ? values.size() / std::size_t(components) : 0; }
  /// The attribute as an owned copy.
  Attribute copy() const;
};

/// Particles read in place: positions as xyz float triples and attributes, in memory the caller
/// owns and keeps unchanged while a call reads them (reconstruct() and Reconstructor read a
/// simulator's arrays this way, without copying them). A ParticleSet is one.
struct ParticlesView {
  std::span<const Vec3f> positions;
  std::vector<AttributeView> attributes;
  ParticlesView() = default;
  ParticlesView(std::span<const Vec3f> positions_, std::vector<AttributeView> attributes_ = {})
      : positions(positions_), attributes(std::move(attributes_)) {}
  ParticlesView(const ParticleSet& set);  // NOLINT(google-explicit-constructor): a set is a view of itself
  std::size_t size() const { return positions.size(); }
  /// The attribute with this name, or nullptr.
  const AttributeView* find(std::string_view name) const;
  /// Throws InvalidParameter if an attribute's length does not match the particle count.
  void validate() const;
  /// The particles as an owned copy.
  ParticleSet copy() const;
};

}  // namespace meniscus
