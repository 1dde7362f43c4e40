// meniscus — one frame over several processes (docs/cluster.md#one-frame-over-mpi): the frame is
// cut into slabs along its longest axis, each process surfaces its slab plus a halo of particles
// at least R_local wide (local_reach), keeps the triangles it owns, and the owned pieces weld into
// the mesh one process makes of the whole frame, bit for bit. Plain functions on particles and
// meshes: the MPI transport lives in the command-line tool, and the tests run the same steps
// process by process in one.
#pragma once

#include <vector>

#include "meniscus/mesh.hpp"
#include "meniscus/params.hpp"
#include "meniscus/particles.hpp"

namespace meniscus {

/// Slabs along one axis: rank r owns [cuts[r-1], cuts[r]) (−∞ and +∞ at the ends).
struct Decomposition {
  int ranks = 1;
  int axis = 0;               ///< 0, 1, 2: x, y, z
  std::vector<double> cuts;   ///< ranks − 1 increasing planes, each on a block boundary of the field lattice
  double halo = 0;            ///< particles this far beyond a slab travel with it

  double lo(int rank) const;  ///< −∞ for rank 0
  double hi(int rank) const;  ///< +∞ for the last rank
};

/// The halo for resolved parameters `p`: local_reach(p) (every vertex position is a function of
/// the particles within it), plus two triangle edges (an owned triangle's vertices lie within one
/// edge of the slab; a vertex normal reads its ring) and one spacing of margin.
double halo_width(const Params& p);

/// Cuts the frame for `ranks` processes: along the longest axis of the particles' box, at the
/// particle-count quantiles, each cut moved to the nearest block boundary of the field lattice
/// (blocks of `p` anchored at the origin). `p`: resolved parameters (resolve_params). Cuts that
/// would coincide leave some slabs empty of particles; that is allowed.
Decomposition decompose(const ParticleSet& particles, const Params& p, int ranks);

/// The particles rank `rank` surfaces: those within its slab widened by the halo on each side,
/// in their original order, with every attribute.
ParticleSet slab_particles(const ParticleSet& particles, const Decomposition& d, int rank);

/// The part of `mesh` (rank `rank`'s surface of its slab particles) that rank owns: the triangles
/// whose centroid lies in its slab (each triangle of the whole frame's mesh is owned by exactly
/// one rank) and the vertices they use, with their normals and attributes, in the mesh's order.
TriangleMesh owned_piece(const TriangleMesh& mesh, const Decomposition& d, int rank);
/// owned_piece() in place: `mesh` becomes its owned piece, its arrays shrunk (no second copy).
void keep_owned(TriangleMesh& mesh, const Decomposition& d, int rank);

/// Welds pieces into one mesh: vertices that coincide bit for bit are one vertex (the seams' are
/// computed identically by every rank that has them). The result is in a canonical order —
/// vertices by their Z-order on a grid of 1024 cells across the pieces' box (ties: by coordinates),
/// triangles by their smallest vertex, then the others — so it does not depend on how the frame was
/// cut: canonical(whole-frame mesh) = weld(pieces). Normals, when the pieces have them, are
/// computed again on the welded mesh (they equal the pieces' to rounding: a vertex's sum over its
/// triangles then runs in one order whatever the cut). Throws InvalidParameter when two vertices of
/// one piece coincide (their identity would be lost) or pieces disagree on a vertex's attributes.
TriangleMesh weld_pieces(std::vector<TriangleMesh> pieces);

}  // namespace meniscus
