// meniscus — one frame over several processes (docs/cluster.md#one-frame-over-mpi): the frame is
// cut into slabs along its longest axis, each process surfaces its slab plus a halo of particles
// at least R_local wide (local_reach), keeps the triangles it owns, and the owned pieces weld into
// the mesh one process makes of the whole frame, bit for bit. Plain functions on particles and
// meshes: the MPI transport lives in the command-line tool, and the tests run the same steps
// process by process in one.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <vector>

#include "meniscus/mesh.hpp"
#include "meniscus/params.hpp"
#include "meniscus/particles.hpp"

namespace meniscus {

/// Reductions over the ranks that each hold a part of the frame: MPI_Allreduce in the tool, the
/// identity for one process that holds all of it (local_reduce). The frame-wide estimates made
/// from parts with them are bit for bit those made from the whole frame.
struct Reduce {
  std::function<void(std::vector<float>&)> min;     ///< element-wise minimum over the ranks, in place
  std::function<void(std::vector<uint64_t>&)> sum;  ///< element-wise sum over the ranks, in place
};
Reduce local_reduce();

/// estimate_spacing() of the whole frame from the ranks' parts: `part` is particles
/// [first, first + part.size()) of the frame's `total`, in the frame's order. Every rank gets the
/// value estimate_spacing() gives on the whole frame, bit for bit.
double estimate_spacing_parts(const ParticleSet& part, std::size_t first, std::size_t total, const Reduce& reduce,
                              std::size_t max_samples = 50000);

/// resolve_frame_estimates() of the whole frame from the ranks' parts (as estimate_spacing_parts):
/// the spacing, the rest density and the reference speed, the same on every rank, bit for bit.
Params resolve_frame_estimates_parts(const ParticleSet& part, std::size_t first, std::size_t total,
                                     const Params& params, const Reduce& reduce);

/// The k-th smallest (0-based) of values spread over the ranks (exact: a radix selection on the
/// floats' bits, four rounds of 256 counts). Every rank gets every answer; `ks` ascending or not.
std::vector<float> select_parts(const std::vector<float>& values, const std::vector<uint64_t>& ks, const Reduce& reduce);

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
/// decompose() of the whole frame from the ranks' parts (`total` particles in all): the same cuts.
Decomposition decompose_parts(const ParticleSet& part, std::size_t total, const Params& p, int ranks, const Reduce& reduce);

/// The particles rank `rank` surfaces: those within its slab widened by the halo on each side,
/// in their original order, with every attribute.
ParticleSet slab_particles(const ParticleSet& particles, const Decomposition& d, int rank);

/// The part of `mesh` (rank `rank`'s surface of its slab particles) that rank owns: the triangles
/// whose centroid lies in its slab (each triangle of the whole frame's mesh is owned by exactly
/// one rank) and the vertices they use, with their normals and attributes, in the mesh's order.
TriangleMesh owned_piece(const TriangleMesh& mesh, const Decomposition& d, int rank);
/// Where an owned piece's vertices meet the other pieces', for a gather that writes the pieces
/// one after the other (each vertex once): per vertex of the piece, the lowest rank that owns a
/// triangle on it (that rank writes it) and whether a higher rank owns one too (it will refer to
/// it). From the rank's own halo mesh, where every owned vertex has its whole ring.
struct Seams {
  std::vector<int32_t> writer;
  std::vector<uint8_t> shared_up;
};

/// owned_piece() in place: `mesh` becomes its owned piece, its arrays shrunk (no second copy);
/// with `seams`, also the piece's seams.
void keep_owned(TriangleMesh& mesh, const Decomposition& d, int rank, Seams* seams = nullptr);

/// A rank's piece as the streamed gather sends it: the gathered mesh's vertices are the ranks'
/// written vertices one rank after the other, then its triangles likewise, so the rank that
/// writes holds one piece at a time, never the whole mesh.
struct StreamPart {
  TriangleMesh written;             ///< the vertices this rank writes (normals, attributes), in piece order; no triangles
  std::vector<uint8_t> shared_up;   ///< per written vertex: a higher rank refers to it
  std::vector<Triangle> triangles;  ///< < written count: its own vertices; written count + j: foreign[j]
  std::vector<Vec3f> foreign;       ///< the positions of its vertices that lower ranks write
};
/// The piece (keep_owned with seams) split for the streamed gather; `piece` is consumed.
StreamPart stream_part(TriangleMesh piece, const Seams& seams, int rank);

/// The writing side of the streamed gather: numbers the parts' written vertices in the order they
/// arrive and turns each part's triangles into indices of the gathered mesh, finding its foreign
/// vertices among the shared vertices of the parts before it (bit-identical positions).
class StreamIndex {
 public:
  /// The next part's written vertices: they take the next indices. Returns the first.
  std::size_t add_written(const std::vector<Vec3f>& positions, const std::vector<uint8_t>& shared_up);
  /// Part `part`'s triangles (in add_written's order) in the gathered mesh's indices, in place.
  /// Throws InvalidParameter when a foreign vertex was not written by an earlier part.
  void resolve(std::size_t part, std::vector<Triangle>& triangles, const std::vector<Vec3f>& foreign);
  std::size_t vertices() const { return next_; }

 private:
  struct Shared {
    std::array<uint32_t, 3> bits;
    uint32_t index;
  };
  std::vector<Shared> shared_;
  bool sorted_ = true;
  std::vector<std::pair<std::size_t, std::size_t>> parts_;  // first index, count
  std::size_t next_ = 0;
};

/// The rank that owns a triangle whose centroid is at `c` along the axis.
int owner_of(const Decomposition& d, double c);

/// Welds pieces into one mesh: vertices that coincide bit for bit are one vertex (the seams' are
/// computed identically by every rank that has them). The result is in a canonical order —
/// vertices by their Z-order on a grid of 1024 cells across the pieces' box (ties: by coordinates),
/// triangles by their smallest vertex, then the others — so it does not depend on how the frame was
/// cut: canonical(whole-frame mesh) = weld(pieces). Normals, when the pieces have them, are
/// computed again on the welded mesh (they equal the pieces' to rounding: a vertex's sum over its
/// triangles then runs in one order whatever the cut). Throws InvalidParameter when two vertices of
/// one piece coincide (their identity would be lost) or pieces disagree on a vertex's attributes.
TriangleMesh weld_pieces(std::vector<TriangleMesh> pieces);

/// weld_pieces() fed one array at a time, for the process that receives the pieces: it holds
/// every piece's positions until weld_vertices(), then the welded mesh as it grows and one
/// piece's attributes or triangles at a time (not all the pieces and the welded mesh at once).
/// The calls, in this order: add_vertices() for every piece; weld_vertices(); then, for each
/// piece in any order, add_attributes() before add_triangles(); finish(). Same result and
/// errors as weld_pieces() (which is this, fed from the vector).
class PieceWelder {
 public:
  explicit PieceWelder(std::size_t pieces);
  void add_vertices(std::size_t piece, std::vector<Vec3f> positions);
  /// The merged vertices in their canonical order; the pieces' positions are freed.
  void weld_vertices();
  /// Room for this many triangles in all (so that the welded triangles grow without a copy).
  void reserve_triangles(std::size_t triangles) { out_.triangles.reserve(triangles); }
  /// The piece's vertex attributes (one value group per vertex of the piece, as add_vertices had).
  void add_attributes(std::size_t piece, const std::vector<Attribute>& attributes);
  /// The piece's triangles (indices into its own vertices); its index map is freed.
  void add_triangles(std::size_t piece, const std::vector<Triangle>& triangles);
  /// The welded mesh, triangles in canonical order, with vertex normals when `normals`.
  TriangleMesh finish(bool normals);

 private:
  std::vector<std::vector<Vec3f>> positions_;
  std::vector<std::vector<uint32_t>> merged_of_;  // each piece's vertex → its merged vertex
  std::vector<uint32_t> first_piece_;             // the piece whose copy of a merged vertex is kept
  std::vector<bool> attributes_added_, triangles_added_;
  TriangleMesh out_;
  bool welded_ = false, attributes_started_ = false;
};

}  // namespace meniscus
