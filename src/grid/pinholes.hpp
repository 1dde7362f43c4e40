// meniscus — pinholes in thin water: where a sheet one or two particles deep is sparser than
// about 1.4 spacings, the union of the particles' outer balls has holes through it, and the
// surface extracted from it keeps them (the smoothing moves vertices, it does not change the
// topology). A bridge is a particle added at the middle of such a hole: it takes part in the
// field and the constraints like any other, so the sheet comes out whole and flat over the hole.
//
// A point x is in a pinhole when it is outside every outer ball (r_outer < φ(x) ≤ reach) and the
// particles around it enclose it in a plane: the particles within reach + plane_tolerance of x
// that lie within plane_tolerance of their least-squares plane through x surround x with no
// angular gap wider than max_gap, and each is within 2·r_outer (their balls overlap) of the next
// one round x. The ring is then already one piece of the surface, so the bridge fills its hole
// without joining anything that was apart: a bridge is refused when a particle its ball would
// touch is not touched by the ring's balls too. Droplets, however close, are never joined (their
// balls do not overlap), nor are two layers of water, nor a groove or a crease (the particles
// lie on one side of it).
#pragma once

#include <cstddef>
#include <span>
#include <vector>

#include "meniscus/vec.hpp"

namespace meniscus {

/// What makes a hole a pinhole, in scene units (pinhole_settings gives the defaults).
struct PinholeSettings {
  float r_outer = 0;          ///< the outer balls' radius
  float reach = 0;            ///< the largest distance from a hole's middle to the particles round it
  float plane_tolerance = 0;  ///< how far from the ring's plane its particles may lie
  float max_gap_degrees = 150;
  float probe_step = 0;       ///< the lattice of points tested for holes
};

/// The settings for particles of spacing d and outer radius r_outer: reach 1.2 d, plane tolerance
/// 0.6 d, probes 0.3 d apart.
PinholeSettings pinhole_settings(double spacing, double r_outer);

/// How far from a bridge the particles that decide it lie (the cells its probes read, 7.3 d by
/// default): what locality adds for bridges.
double pinhole_reach(const PinholeSettings& s);

/// The bridges for `points`, in the order of the cubes of edge r_outer / 2 (a lattice at the
/// origin) they lie in, at most one in each: the one the first probe (in z, y, x order) found. Deterministic: the same for any thread count, and
/// each bridge a function of the points within pinhole_reach() of it.
std::vector<Vec3f> pinhole_bridges(std::span<const Vec3f> points, const PinholeSettings& s);

}  // namespace meniscus
