// meniscus — the names of the enumerated parameters (Params::validate is in parameters.cpp, with
// the table of ranges).
#include "meniscus/params.hpp"

#include "meniscus/errors.hpp"

namespace meniscus {

const char* to_string(Extractor e) {
  switch (e) {
    case Extractor::tiles: return "tiles";
    case Extractor::cubes: return "cubes";
    case Extractor::tetrahedra: return "tetrahedra";
  }
  return "?";
}

const char* to_string(SmoothingSolver s) { return s == SmoothingSolver::jacobi ? "jacobi" : "chebyshev"; }

Extractor parse_extractor(const std::string& name) {
  if (name == "tiles") return Extractor::tiles;
  if (name == "cubes") return Extractor::cubes;
  if (name == "tetrahedra") return Extractor::tetrahedra;
  throw InvalidParameter("extract", name, "expected tiles, cubes or tetrahedra");
}

SmoothingSolver parse_solver(const std::string& name) {
  if (name == "chebyshev") return SmoothingSolver::chebyshev;
  if (name == "jacobi") return SmoothingSolver::jacobi;
  if (name == "gauss-seidel")
    throw InvalidParameter("solver", name,
                           "gauss-seidel is gone: its colour order made every vertex depend on the whole frame; use "
                           "chebyshev (the default: Jacobi sweeps accelerated as far, and local)");
  throw InvalidParameter("solver", name, "expected chebyshev or jacobi");
}

const char* to_string(Backend b) {
  switch (b) {
    case Backend::automatic: return "auto";
    case Backend::cpu: return "cpu";
    case Backend::cuda: return "cuda";
  }
  return "?";
}

const char* to_string(FieldMethod f) {
  switch (f) {
    case FieldMethod::distance: return "distance";
    case FieldMethod::metaball: return "metaball";
    case FieldMethod::sph: return "sph";
    case FieldMethod::zhu_bridson: return "zhu-bridson";
    case FieldMethod::anisotropic: return "anisotropic";
  }
  return "?";
}

Backend parse_backend(const std::string& name) {
  if (name == "auto") return Backend::automatic;
  if (name == "cpu") return Backend::cpu;
  if (name == "cuda") return Backend::cuda;
  throw InvalidParameter("backend", name, "expected auto, cpu or cuda");
}

FieldMethod parse_field(const std::string& name) {
  for (FieldMethod f : {FieldMethod::distance, FieldMethod::metaball, FieldMethod::sph, FieldMethod::zhu_bridson,
                        FieldMethod::anisotropic})
    if (name == to_string(f)) return f;
  throw InvalidParameter("field", name, "expected distance, metaball, sph, zhu-bridson or anisotropic");
}

}  // namespace meniscus
