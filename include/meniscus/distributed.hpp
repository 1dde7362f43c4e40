// meniscus — one frame over several processes (docs/cluster.md#one-frame-over-mpi): the frame is
// cut into slabs along its longest axis, each process surfaces its slab plus a halo of particles
// at least R_local wide (local_reach) and keeps the triangles it owns. The owned pieces gather into
// the mesh one process makes of the whole frame, bit for bit and in its vertex and triangle order
// (OrderedGather), or weld into it in a canonical order (weld_pieces, for pieces written apart).
// Plain functions on particles and meshes: the MPI transport lives in the command-line tool, and
// the tests run the same steps process by process in one.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <vector>

#include "meniscus/mesh.hpp"
#include "meniscus/params.hpp"
#include "meniscus/particles.hpp"
#include "meniscus/reconstruct.hpp"

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
double estimate_spacing_parts(const ParticlesView& part, std::size_t first, std::size_t total, const Reduce& reduce,
                              std::size_t max_samples = 50000);

/// resolve_frame_estimates() of the whole frame from the ranks' parts (as estimate_spacing_parts):
/// the spacing, the rest density and the reference speed, the same on every rank, bit for bit.
Params resolve_frame_estimates_parts(const ParticlesView& part, std::size_t first, std::size_t total,
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
/// owned_piece() in place: `mesh` becomes its owned piece, its arrays shrunk (no second copy).
void keep_owned(TriangleMesh& mesh, const Decomposition& d, int rank);

/// The rank that owns a triangle whose centroid is at `c` along the axis.
int owner_of(const Decomposition& d, double c);

// --- The ordered gather: the ranks' pieces as one process's mesh, in one process's order ---------

/// Where a vertex comes in the mesh one process makes of a frame (docs/method.md, `extract` and
/// `reorder`). The extraction numbers the vertices by the key of the lattice edge each lies on; the
/// reorder, when any sweep runs, renumbers them by the Z-order code of their extracted position on
/// the lattice's cells anchored at the origin, ties in edge-key order. Both are functions of the
/// vertex alone, so one process's vertices are in increasing key order, and a rank's surface of
/// its slab gives a vertex the key the whole frame's mesh gives it.
struct VertexOrderKey {
  uint64_t morton = 0;  ///< the Z-order code of the extracted position (0 when no sweep runs)
  uint64_t edge = 0;    ///< the key of the vertex's lattice edge (extract/edge_key.hpp)
  auto operator<=>(const VertexOrderKey&) const = default;
};

/// reconstruct() with each vertex's order key (`keys[v]` for mesh vertex v, strictly increasing):
/// what a rank runs on its slab. Runs the CPU backend whatever `params.backend` says but cuda,
/// which it refuses (InvalidParameter: the keys come from the CPU's extraction, and the CUDA
/// backend's positions agree with the CPU's to rounding, not bit for bit). Also refuses a
/// schedule without sweeps (steps_a, steps_b and steps_free all 0): the triangles are then in the
/// extraction's block order, which vertex keys do not give; and erosion, whose normals are summed
/// in the slab's triangle order (mesh/normals.hpp), which rounds differently from the whole
/// frame's at a few vertices. `origin`: the whole frame's local_origin (reconstruct.hpp), so that
/// a slab of a frame far from the origin is computed about the point the whole frame would be; the
/// mesh returned stays in those local coordinates (ordered_part moves it back).
Result reconstruct_ordered(const ParticleSet& particles, const Params& params, std::vector<VertexOrderKey>& keys,
                           const std::array<double, 3>& origin = {});

/// A rank's owned piece as the ordered gather takes it. Each vertex of the piece is written by the
/// lowest rank that owns a triangle on it (which a rank knows from its own slab's mesh, where the
/// vertex has its whole ring); the others are the piece's foreign vertices.
struct OrderedPart {
  TriangleMesh written;                 ///< the vertices this rank writes (positions, attributes), in order; no triangles
  std::vector<VertexOrderKey> keys;     ///< per written vertex
  std::vector<uint8_t> shared_up;       ///< per written vertex: a higher rank owns a triangle on it
  std::vector<uint32_t> runs;           ///< per written vertex: the slab's triangles whose smallest vertex it is
  std::vector<Triangle> triangles;      ///< owned, in order: < written count its own vertices, written count + j foreign[j]
  std::vector<uint32_t> ties;           ///< per triangle: the slab's triangles before it with its smallest vertex
  std::vector<Vec3f> crosses;           ///< per triangle: its corners' cross product, its term of the vertex normals
  std::vector<VertexOrderKey> foreign;  ///< the keys of its vertices that lower ranks write
  std::vector<int32_t> foreign_writer;  ///< per foreign vertex: the rank that writes it
};

/// The owned part of rank `rank`'s surface of its slab (`mesh` and `keys` from reconstruct_ordered,
/// consumed). One process sorts its triangles by their smallest vertex, ties in the extraction's
/// order, which is their order in the slab's mesh too (`ties`), so a triangle's place is the first
/// place of its smallest vertex's run plus its tie. Throws std::logic_error when the mesh is not in
/// that order (keys not increasing, triangles not sorted by their smallest vertex).
/// `origin`: the frame's local origin the slab was surfaced about (reconstruct_ordered's mesh is
/// in those coordinates); the part's vertices are written back where the frame is.
OrderedPart ordered_part(TriangleMesh mesh, std::vector<VertexOrderKey> keys, const Decomposition& d, int rank,
                         const std::array<double, 3>& origin = {});

/// Where vertices go in the gathered mesh: their index, and the index of the first triangle whose
/// smallest vertex each is (the triangles before it: the runs of the vertices before it).
struct VertexPlaces {
  std::vector<uint32_t> index;
  std::vector<uint32_t> first_triangle;
};

/// A part in the gathered mesh's numbering (place_part).
struct PlacedPart {
  std::vector<uint32_t> vertex_index;    ///< per written vertex
  std::vector<Triangle> triangles;       ///< the owned triangles' corners in the gathered mesh
  std::vector<uint32_t> triangle_index;  ///< per owned triangle: its index in the gathered mesh
};
/// The part's vertices and triangles in the gathered mesh's numbering, from the places of its own
/// vertices and of its foreign ones (the writers'). Throws InvalidParameter when the sizes do not
/// match or a triangle's place lies past its vertex's run.
PlacedPart place_part(const OrderedPart& part, const VertexPlaces& own, const VertexPlaces& foreign);

/// One process's vertex normals, in pieces (mesh/normals.hpp: each vertex adds its triangles'
/// terms in the order (chunk of kNormalChunk triangles mod the waves' stride, triangle index)).
/// normal_chunk_bounds: the smallest and largest corner of the part's triangles in each chunk of
/// the gathered mesh's `triangles` (UINT32_MAX and 0 where it has none); their element-wise minimum
/// and maximum over the parts give the stride (normal_stride).
void normal_chunk_bounds(const PlacedPart& placed, std::size_t triangles, std::vector<uint32_t>& lo,
                         std::vector<uint32_t>& hi);
std::size_t normal_stride(const std::vector<uint32_t>& lo, const std::vector<uint32_t>& hi);

/// One triangle's term of a vertex normal: the vertex, where the term comes in its sum, the term.
struct NormalTerm {
  VertexOrderKey vertex;
  uint64_t order = 0;  ///< (chunk mod stride) · 2^32 + triangle index
  Vec3f cross;
  uint32_t unused = 0;
};
/// The terms of the part's triangles at its foreign vertices, per rank that writes them (`ranks` lists).
std::vector<std::vector<NormalTerm>> foreign_terms(const OrderedPart& part, const PlacedPart& placed,
                                                   std::size_t stride, int ranks);
/// The written vertices' normals (part.written.normals): the part's own terms and `received` (the
/// other parts' terms at its vertices) summed in one process's order, then normalised. Throws
/// InvalidParameter for a term at a vertex the part does not write.
void gather_normals(OrderedPart& part, const PlacedPart& placed, std::size_t stride, std::vector<NormalTerm> received);

/// The gathering side of the ordered gather (rank 0), fed chunk by chunk so that it holds a chunk of
/// each part and the seam vertices, never the whole mesh. First it numbers the vertices: it merges
/// the parts' keys (one process's vertex order) and gives each vertex its index and its first
/// triangle's. Then, once every part knows its places, it merges the parts' vertices and triangles
/// by index. Throws InvalidParameter when the parts do not fit together (a vertex written twice,
/// an index missing or given twice, a seam vertex nobody wrote, chunks with different attributes).
class OrderedGather {
 public:
  /// The next run of a part's written vertices' keys, seam flags and runs; none at the part's end.
  struct KeyChunk {
    std::vector<VertexOrderKey> keys;
    std::vector<uint8_t> shared_up;
    std::vector<uint32_t> runs;
  };
  /// The next run of a part's written vertices (positions, normals, attributes) with their indices;
  /// none at the part's end.
  struct VertexChunk {
    std::vector<uint32_t> index;
    TriangleMesh vertices;
  };
  /// The next run of a part's triangles (in the gathered mesh's numbering) with their indices.
  struct TriangleChunk {
    std::vector<uint32_t> index;
    std::vector<Triangle> triangles;
  };
  /// At most this many vertices or triangles in a chunk and in a batch given to emit.
  static constexpr std::size_t kChunk = std::size_t(1) << 16;

  explicit OrderedGather(std::size_t parts);
  /// Pulls each part's key chunks with next(part), in order; when a chunk is used up, placed(part,
  /// places) gets its vertices' places, before next(part) is asked for the part's next chunk.
  /// Returns the vertex count.
  std::size_t number_vertices(const std::function<KeyChunk(std::size_t)>& next,
                              const std::function<void(std::size_t, VertexPlaces)>& placed);
  /// The places of vertices that a higher rank refers to, by their keys (after number_vertices).
  VertexPlaces seam_places(const std::vector<VertexOrderKey>& keys) const;
  /// The triangle count: the sum of every vertex's run (after number_vertices).
  std::size_t triangles() const { return triangles_; }
  /// Merges the parts' vertex chunks by index into batches given to emit, in order.
  void merge_vertices(const std::function<VertexChunk(std::size_t)>& next,
                      const std::function<void(const TriangleMesh&)>& emit);
  /// Merges the parts' triangle chunks by index into batches given to emit, in order.
  void merge_triangles(const std::function<TriangleChunk(std::size_t)>& next,
                       const std::function<void(const std::vector<Triangle>&)>& emit);
  /// The attribute names and components (no values) and normals or not of the first chunk with
  /// vertices, or of one without (a part with none to write): the layout of the gathered mesh.
  const TriangleMesh& layout() const { return layout_; }

 private:
  std::size_t parts_, vertices_ = 0, triangles_ = 0;
  TriangleMesh layout_;
  bool has_layout_ = false;
  struct Seam {
    VertexOrderKey key;
    uint32_t index, first_triangle;
  };
  std::vector<Seam> seams_;  // sorted by key after number_vertices
};

/// Appends a batch that OrderedGather::merge_vertices emitted (positions, normals, attribute
/// values) to `mesh`; the first batch with attributes gives a mesh without any their layout.
void append_gathered_vertices(TriangleMesh& mesh, const TriangleMesh& batch);

/// Part `part`'s chunks from `first` on (none past its end): its keys, and once placed its vertices
/// and triangles.
OrderedGather::KeyChunk key_chunk(const OrderedPart& part, std::size_t first);
OrderedGather::VertexChunk vertex_chunk(const OrderedPart& part, const PlacedPart& placed, std::size_t first);
OrderedGather::TriangleChunk triangle_chunk(const PlacedPart& placed, std::size_t first);

/// The whole ordered gather in one process, from every part: one process's mesh of the frame, bit
/// for bit and in its order, normals and attributes included.
TriangleMesh gather_ordered(std::vector<OrderedPart> parts);

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
