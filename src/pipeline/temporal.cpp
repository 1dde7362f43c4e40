// meniscus — a frame's particles smoothed in time with the frames either side (temporal.hpp).
#include "meniscus/temporal.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "common/for_each.hpp"
#include "common/primitives.hpp"
#include "meniscus/errors.hpp"

namespace meniscus {

namespace {

/// Ids are read as floats: whole numbers in [0, 2²⁴) are exact, larger ones may round onto one
/// another.
constexpr float kIdLimit = 16777216.0f;

/// Where each id of a frame is: a table over the ids (index + 1, 0: none) where they are no more
/// than a few times the particles, else (id << 32 | index) keys sorted; or why neither can be.
struct IdIndex {
  std::vector<uint32_t> table;
  std::vector<uint64_t> keys;
  std::string problem;

  /// The index of the particle with this id, or -1.
  int64_t find(uint32_t id) const {
    if (!table.empty()) return id < table.size() ? int64_t(table[id]) - 1 : -1;
    const auto it = std::lower_bound(keys.begin(), keys.end(), uint64_t(id) << 32);
    return it != keys.end() && uint32_t(*it >> 32) == id ? int64_t(*it & 0xffffffffu) : -1;
  }
};

/// The ids of a frame, checked: one component, whole numbers in [0, 2²⁴), no two alike.
IdIndex index_ids(const ParticlesView& frame, const char* which) {
  IdIndex x;
  const AttributeView* ids = frame.find(kParticleIdAttribute);
  if (ids == nullptr) {
    x.problem = fmt::format("no '{}' attribute in the {} frame", kParticleIdAttribute, which);
    return x;
  }
  if (ids->components != 1 || ids->size() != frame.size()) {
    x.problem = fmt::format("the {} frame's '{}' attribute has {} components, not 1", which, kParticleIdAttribute,
                            ids->components);
    return x;
  }
  const std::size_t n = frame.size();
  float largest = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const float v = ids->values[i];
    if (!(v >= 0 && v < kIdLimit && v == std::floor(v))) {
      x.problem = fmt::format("the {} frame's ids are not all whole numbers from 0 to 2^24 − 1", which);
      return x;
    }
    largest = std::max(largest, v);
  }
  const auto twice = [&](uint32_t id) {
    x.problem = fmt::format("the {} frame has two particles with id {}", which, id);
    x.table.clear(), x.keys.clear();
    return x;
  };
  // Ids below 2^24, n below 2^22 where they are sparse: an index fits in 32 bits on either path.
  if (std::size_t(largest) <= 4 * n + 65536) {
    x.table.assign(std::size_t(largest) + 1, 0);
    for (std::size_t i = 0; i < n; ++i) {
      uint32_t& slot = x.table[std::size_t(ids->values[i])];
      if (slot != 0) return twice(uint32_t(ids->values[i]));
      slot = uint32_t(i + 1);
    }
    return x;
  }
  x.keys.resize(n);
  for (std::size_t i = 0; i < n; ++i) x.keys[i] = (uint64_t(uint32_t(ids->values[i])) << 32) | uint64_t(i);
  sort(Host{}, x.keys.begin(), x.keys.end());
  for (std::size_t i = 1; i < n; ++i)
    if (x.keys[i] >> 32 == x.keys[i - 1] >> 32) return twice(uint32_t(x.keys[i] >> 32));
  return x;
}

}  // namespace

std::vector<Vec3f> temporal_smoothing(const ParticlesView& previous, const ParticlesView& current,
                                      const ParticlesView& next, double weight, double limit, TemporalReport* report) {
  if (!(weight >= 0 && weight <= 0.5))
    throw InvalidParameter("temporal_smoothing", fmt::format("{:g}", weight), "must be a number from 0 to 0.5");
  if (!(limit >= 0 && std::isfinite(limit)))
    throw InvalidParameter(fmt::format("temporal smoothing: the shift's limit {:g} must be a finite number ≥ 0", limit));
  previous.validate(), current.validate(), next.validate();
  TemporalReport r;
  std::vector<Vec3f> out(current.positions.begin(), current.positions.end());
  // Every exit sets *report and returns `out` itself (moved, not copied).
  const auto tell = [&] {
    if (report) *report = r;
  };
  if (weight == 0) {
    r.skipped = "the weight is 0";
    tell();
    return out;
  }
  const IdIndex here = index_ids(current, "current");
  IdIndex before, after;
  if (here.problem.empty()) before = index_ids(previous, "previous");
  if (here.problem.empty() && before.problem.empty()) after = index_ids(next, "next");
  const std::string& problem = !here.problem.empty() ? here.problem : !before.problem.empty() ? before.problem : after.problem;
  if (!problem.empty()) {
    r.skipped = problem;
    tell();
    return out;
  }
  // Each particle's shift, in its own slot: the positions do not depend on the order of the work.
  const AttributeView& ids = *current.find(kParticleIdAttribute);
  const std::size_t n = current.size();
  std::vector<float> shift(n, -1.0f);  // −1: not found in both neighbours
  std::vector<uint8_t> cut(n, 0);
  const float w = float(weight), lim = float(limit);
  for_each_index(n, kElementGrain, [&](std::size_t i) {
    const uint32_t id = uint32_t(ids.values[i]);
    const int64_t a = before.find(id), b = after.find(id);
    if (a < 0 || b < 0) return;
    const Vec3f x = current.positions[i];
    // (x₋ + x₊) first: the same bits with the frames' order reversed.
    Vec3f s = ((previous.positions[std::size_t(a)] + next.positions[std::size_t(b)]) - x * 2.0f) * w;
    float len = std::sqrt(length2(s));
    if (len > lim) s = len > 0 ? s * (lim / len) : Vec3f{0, 0, 0}, len = lim, cut[i] = 1;
    out[i] = x + s;
    shift[i] = len;
  });
  double sum = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (shift[i] < 0) continue;
    ++r.matched;
    sum += shift[i];
    r.max_shift = std::max(r.max_shift, double(shift[i]));
    r.clamped += cut[i];
  }
  r.applied = true;
  r.mean_shift = r.matched > 0 ? sum / double(r.matched) : 0;
  tell();
  return out;
}

}  // namespace meniscus
