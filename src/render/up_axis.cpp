// meniscus render — which axis is up in a scene (render.hpp: guess_up_axis).
#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include <fmt/format.h>

#include "meniscus/render.hpp"

namespace meniscus {

namespace {

// A score must reach this, and lead every other axis by kLead, to decide.
constexpr double kClear = 0.1, kLead = 0.04;

bool houdini_format(std::string_view format) { return format.starts_with("bgeo"); }

}  // namespace

Vec3f UpAxis::direction() const { return axis == 0 ? Vec3f{1, 0, 0} : (axis == 1 ? Vec3f{0, 1, 0} : Vec3f{0, 0, 1}); }

UpAxis guess_up_axis(const std::vector<Vec3f>& points, const Attribute* velocity, std::string_view format) {
  if (houdini_format(format)) return {1, "the file is Houdini geometry, y-up by convention"};

  std::array<double, 3> lo{}, hi{}, sum{};
  lo.fill(INFINITY), hi.fill(-INFINITY);
  std::size_t count = 0;
  for (const Vec3f& p : points) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) continue;
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], double(p[a])), hi[a] = std::max(hi[a], double(p[a]));
      sum[a] += p[a];
    }
    ++count;
  }
  std::array<double, 3> settled{}, falling{};  // the two signs of gravity, per axis
  if (count > 0)
    for (int a = 0; a < 3; ++a) {
      const double extent = hi[a] - lo[a];
      if (extent > 0) settled[a] = std::max(0.0, 0.5 - (sum[a] / double(count) - lo[a]) / extent);
    }
  if (velocity != nullptr && velocity->components == 3) {
    std::array<double, 3> mean{};
    double speed = 0;
    for (std::size_t i = 0; i < velocity->size(); ++i) {
      const float* v = &velocity->values[3 * i];
      if (!std::isfinite(v[0]) || !std::isfinite(v[1]) || !std::isfinite(v[2])) continue;
      for (int a = 0; a < 3; ++a) mean[a] += v[a];
      speed += std::sqrt(double(v[0]) * v[0] + double(v[1]) * v[1] + double(v[2]) * v[2]);
    }
    if (speed > 0)
      for (int a = 0; a < 3; ++a) falling[a] = std::max(0.0, -mean[a] / speed);
  }
  std::array<double, 3> score{};
  for (int a = 0; a < 3; ++a) score[a] = settled[a] + falling[a];
  const int best = int(std::max_element(score.begin(), score.end()) - score.begin());
  bool clear = score[best] >= kClear;
  for (int a = 0; a < 3; ++a)
    if (a != best && score[best] - score[a] < kLead) clear = false;
  if (!clear) return {2, "the default: neither the file nor the particles show which way is up"};
  const char name = char('x' + best);
  std::string shows;
  if (falling[best] > 0 && settled[best] > 0)
    shows = fmt::format("the particles move down {} on average and settle low along it", name);
  else if (falling[best] > 0)
    shows = fmt::format("the particles move down {} on average", name);
  else
    shows = fmt::format("the particles settle low along {}", name);
  return {best, shows};
}

}  // namespace meniscus
