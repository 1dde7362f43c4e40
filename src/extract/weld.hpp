// meniscus — the edge weld (Williams 2008; Edespong 2010 §4.3): triangle corners given as
// lattice-edge keys become an indexed mesh with one vertex per distinct edge, so connectivity is
// exact (never decided by comparing float positions).
#pragma once

#include <cstdint>
#include <span>

#include "extract/extract.hpp"
#include "extract/marching.hpp"
#include "field/sparse_field.hpp"

namespace meniscus {

/// `corner_keys` holds 3 edge keys per triangle (from the marching stages). Vertices are the
/// distinct keys in increasing key order; vertex i lies on its edge at the clamped crossing
/// parameter of {φ = iso} (edge_parameter with kEdgeClamp), values read from `field`. Triangles
/// keep their order; one with a repeated vertex is dropped and counted (vertices that only such
/// triangles used are removed). Parallel (oneTBB); the result does not depend on the thread count.
/// Throws ResourceError when there would be 2^32 or more vertices. The keys are taken by value:
/// move them in and the weld sorts them in place (no second copy at the peak of the extraction).
ExtractResult weld_edge_keys(std::vector<uint64_t> corner_keys, const SparseField& field, float iso);

/// The same mesh from the marching stages' output, using its block structure: each block has
/// merged its own corners, and the vertices — the crossing edges the marching recorded per cell —
/// are numbered in key order from per-row counts, so no key is sorted at all. With `vertex_keys`,
/// the result also lists each vertex's edge key (ExtractResult::vertex_keys).
ExtractResult weld_edge_keys(MarchedCorners marched, const SparseField& field, float iso, bool vertex_keys = false);

}  // namespace meniscus
