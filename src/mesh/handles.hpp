// meniscus — small handles round air cut from a closed mesh: pinholes through thin sheets and
// tunnels through thin water, closed before the smoothing (which only moves vertices) sets the
// surface (docs/method.md "Handles").
#pragma once

#include <cstddef>

#include "meniscus/mesh.hpp"

namespace meniscus {

struct HandleSettings {
  /// The most rings of triangles grown round a seed: a handle is cut where ring k ≤ rings first
  /// wraps round it. Larger rings find wider tubes, whose caps the sweeps may pull through the
  /// particles (bench/RESULTS.md#thin-water-genus-holes-and-tunnels-against-openvdb).
  int rings = 3;
  /// Seeds: vertices whose angle defect 2π − Σ angles is under −saddle_defect (radians), a saddle
  /// as sharp as a narrow tube's wall (which holds −4π of curvature in a small area).
  float saddle_defect = 0.9f;
  /// Water: within this distance of a particle centre (r_outer). A tube whose middle (halfway
  /// between its loops' centroids) has its nearest particle that near, within 45° of the tube's
  /// axis, is a neck of water between drops, never cut; 0: no such test.
  float water_distance = 0;
};

class HashGrid;

/// Cuts the small handles round air of a closed, manifold, oriented mesh. Round each seed the rings
/// of triangles within k edges grow (k = 1 … rings, each a disk while nothing wraps); where ring k
/// first wraps round a tube — an annulus, two clean boundary loops — the annulus is removed and
/// each loop capped by a disk, when
///  - the rest of the mesh joins the annulus' two sides (its loop does not separate the surface:
///    a pinhole's wall, whose sheet's top and bottom meet at its rim; not a neck between drops),
///  - the tube is not a neck of water between two drops (that a second neck joins round): its
///    middle's nearest particle is not within water_distance along its axis,
///  - and the plug — the annulus and its caps, round what the cut turns from outside to inside —
///    holds no particle centre (air: a pinhole, a tunnel; not a ring of water, nor a cap across
///    the particles at a hole's rim).
/// Components stay as they were; each cut takes one from the genus; vertex valences stay ≥ 5
/// where they were (edge flips round the caps). Annuli that share no vertex are cut together,
/// smallest first (ties by the lower seed), so the result is the same for any thread count. New
/// vertices are appended, the annuli's inner vertices removed (the others keep their order); the
/// attributes follow, a cap's vertices taking their loop's first vertex's. Returns the handles cut.
std::size_t cut_small_handles(TriangleMesh& mesh, const HandleSettings& settings, const HashGrid& particles);

}  // namespace meniscus
