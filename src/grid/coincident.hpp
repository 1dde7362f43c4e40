// meniscus — coincident points: the points of a hash grid that share a position (or a cell of a
// much finer lattice), each group named by its first point. Piles of copies (duplicated exports,
// particles stuck in a sink or a corner) would make every query near them scan the whole pile;
// the stages query the groups' first points instead wherever a copy changes nothing (a nearest
// particle, a minimum distance, whether any particle is inside), and count a group's size where a
// count matters.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "grid/hash_grid.hpp"

namespace meniscus {

/// The groups of coincident_points().
struct CoincidentPoints {
  /// Per point (original index): the original index of the first point of its group (the lowest
  /// index; a point alone is its own first). Empty when every point is alone.
  std::vector<uint32_t> first;
  /// How many points are not the first of their group.
  std::size_t copies = 0;
};

/// Groups the points of `grid`: within one of its cells, the points whose coordinates fall in one
/// cell of a lattice of edge `tolerance` (floor(x / tolerance) on each axis, in double) form a
/// group; `tolerance` 0 groups identical positions only (-0 and +0 alike). Points in different
/// cells of `grid` stay apart, so a pile straddling a cell wall makes a group on each side (at
/// most 8 for a pile narrower than both lattices). Every point within `tolerance`·√3 of its
/// group's first. O(k) for a cell of k ≤ 16 points (pairwise), O(k log k) above; parallel over
/// cells. `tolerance` ≥ 0 and finite.
CoincidentPoints coincident_points(const HashGrid& grid, double tolerance);

/// The first point of each group, ascending: the indices 0 … n − 1 whose `first` is themselves
/// (all of them when `groups.first` is empty), with the size of each one's group.
struct GroupHeads {
  std::vector<uint32_t> index;  ///< original indices, ascending
  std::vector<uint32_t> count;  ///< the size of each one's group (1 for a point alone)
};
GroupHeads group_heads(const CoincidentPoints& groups, std::size_t n);

}  // namespace meniscus
