// meniscus — iso-surface extraction, the dispatcher (Williams 2008 Marching Tiles; Lorensen &
// Cline 1987 Marching Cubes; Doi & Koide 1991 Marching Tetrahedra): validate, march, weld.
#include <fmt/format.h>

#include <cmath>
#include <utility>

#include "extract/extract.hpp"
#include "extract/marching.hpp"
#include "extract/weld.hpp"
#include "meniscus/errors.hpp"

namespace meniscus {

ExtractResult extract_surface(const SparseField& field, float iso, Extractor extractor, bool vertex_keys) {
  if (!std::isfinite(iso)) throw InvalidParameter(fmt::format("extract_surface: iso value {} is not finite", iso));
  // Unallocated space must read as outside, otherwise the surface would not close at the band.
  if (!(field.background() > iso))
    throw InvalidParameter(
        fmt::format("extract_surface: the field background {} must be > the iso value {}", field.background(), iso));
  const bool a15 = field.lattice().kind == SampleLattice::Kind::a15;
  const bool wants_a15 = extractor == Extractor::tiles;
  if (a15 != wants_a15)
    throw InvalidParameter(fmt::format("extract_surface: {} extraction needs a field on the {} lattice, got {}",
                                       extractor == Extractor::tiles   ? "tiles"
                                       : extractor == Extractor::cubes ? "cubes"
                                                                       : "tetrahedra",
                                       wants_a15 ? "A15" : "cubic", a15 ? "A15" : "cubic"));
  MarchedCorners corners;
  switch (extractor) {
    case Extractor::tiles:
      corners = march_tiles(field, iso);
      break;
    case Extractor::cubes:
      corners = march_cubes(field, iso);
      break;
    case Extractor::tetrahedra:
      corners = march_tetrahedra(field, iso);
      break;
  }
  return weld_edge_keys(std::move(corners), field, iso, vertex_keys);
}

}  // namespace meniscus
