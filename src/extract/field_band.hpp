// meniscus — how far from the particles the distance field must be exact, shared by the CPU and
// CUDA backends (both allocate the same blocks and compute the same values).
#pragma once

#include <algorithm>
#include <cmath>

#include "extract/tile_table.hpp"
#include "meniscus/params.hpp"

namespace meniscus {

/// The longest lattice edge the extractor interpolates along: the A15 tile's tetrahedron edges
/// (from its table; √6/4 of the tile period 2h), the cube's axis edges, or the Kuhn tetrahedra's
/// cube diagonals.
inline double longest_extraction_edge(Extractor extract, double h) {
  switch (extract) {
    case Extractor::tiles: {
      int longest2 = 0;  // in quarters of the tile period, squared
      for (const auto& tet : kA15Tets)
        for (int i = 0; i < 4; ++i)
          for (int j = i + 1; j < 4; ++j) {
            int l2 = 0;
            const int ds[3] = {tet[j].dx - tet[i].dx, tet[j].dy - tet[i].dy, tet[j].dz - tet[i].dz};
            for (int ax = 0; ax < 3; ++ax) {
              const int q = 4 * ds[ax] + kA15SampleQuarters[tet[j].s][ax] - kA15SampleQuarters[tet[i].s][ax];
              l2 += q * q;
            }
            longest2 = std::max(longest2, l2);
          }
      return std::sqrt(double(longest2)) / 4 * (2 * h);
    }
    case Extractor::cubes: return h;
    case Extractor::tetrahedra: return h * std::sqrt(3.0);
  }
  return 2 * h;
}

/// The longest edge a triangle of the extracted mesh can have: a triangle lies inside one
/// tetrahedron (tiles: its longest edge) or one cube (cubes and its Kuhn tetrahedra: the cube's
/// diagonal √3·h).
inline double longest_triangle_edge(Extractor extract, double h) {
  return extract == Extractor::tiles ? longest_extraction_edge(extract, h) : h * std::sqrt(3.0);
}

/// The band of the field for these (resolved) parameters. The field must be exact wherever an
/// extraction edge crosses φ = r_outer: both ends of such an edge are within r_outer + (edge
/// length) of a particle, so the band needs only that much (beyond it every sample reads
/// "outside"), plus 1 % for rounding.
inline float field_band(const Params& p) {
  return float(p.r_outer + 1.01 * longest_extraction_edge(p.extract, p.voxel_size));
}

}  // namespace meniscus
