// meniscus — what the pipeline's files share (src/pipeline/; not part of the public API).
#pragma once

#include <chrono>
#include <cstddef>
#include <initializer_list>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "common/clock.hpp"
#include "grid/hash_grid.hpp"
#include "meniscus/params.hpp"
#include "meniscus/particles.hpp"
#include "meniscus/reconstruct.hpp"

namespace meniscus {

struct SampleLattice;
struct VertexOrderKey;

// --- resolve.cpp: the inputs and the frame-wide estimates ---------------------------------------

/// The finest cell or voxel surfaced: single precision squares distances, and below this their
/// squares come near the smallest normal float (1e-38).
inline constexpr double kMinSpacing = 1e-12;

/// The spacing estimate counts particles within one cell of a lattice this fine, relative to its
/// search cells (about the spacing), as one site, and a sample's nearest neighbour is never within
/// two such cells: a pile of coincident particles has no spacing of its own, however many there
/// are. Fluid particles are never this close (an SPH solver keeps them about d apart).
inline constexpr double kCoincidentInCell = 1e-4;

/// reconstruct() moves the particles within one cell of a lattice of this many spacings onto the
/// first of them (coincident_particles): the stages then see exact copies, which their queries
/// skip. At most √3 · 1e-5 d, far below what the surface resolves.
inline constexpr double kCoincidentSpacings = 1e-5;

/// Refuses (InputError) a cell of `cell` below kMinSpacing, and a particle farther from the
/// origin than a grid axis of such cells holds (kMaxCoord), naming it: a stray far from the fluid.
/// `first`: the index of positions[0] in the frame; `what`: the cells, for the message.
void check_coordinates(std::span<const Vec3f> positions, std::size_t first, double cell, std::string_view what);

/// Attribute lengths, and every coordinate finite (InputError naming the first that is not).
void check_particles(const ParticlesView& particles);

/// Coincident particles (coincident_particles): the particles the stages surface, and which are
/// copies of which.
struct CoincidentParticles {
  /// The particles with each copy moved onto the first of its group, when any lies apart from
  /// it (empty otherwise: the particles as given).
  std::optional<ParticleSet> moved;
  /// Per particle, the index of the first particle at its position (itself when it is alone or
  /// the first); empty when no two particles share a position.
  std::vector<uint32_t> first;
};

/// Groups the particles that lie within one cell of a lattice of kCoincidentSpacings · spacing
/// (coincident_points over a grid of max(spacing, voxel_size) cells) and moves each onto the first
/// of its group, so that a near-coincident pile becomes exact copies of one particle. A frame
/// without such particles comes back as given (nothing moved, nothing allocated but the search).
/// O(n) plus O(k log k) for a pile of k.
CoincidentParticles coincident_particles(const ParticlesView& particles, const Params& resolved);

/// The particles' attribute with one of these names and this many components, or nullptr.
const AttributeView* find_attribute(const ParticlesView& particles, std::initializer_list<const char*> names,
                                    int components);
const AttributeView* density_attribute(const ParticlesView& particles);
const AttributeView* mass_attribute(const ParticlesView& particles);
const AttributeView* velocity_attribute(const ParticlesView& particles);

/// The median of the particles' positive densities (0 when none is positive).
double median_density(const AttributeView& density);

/// SPH volumes m_i/ρ_i per original particle (Müller et al. 2003): mass/density when the particles
/// carry both, d³·ρ₀/ρ_i with a density only (uniform mass; ρ₀ = rest_density, resolved), empty
/// (uniform d³) otherwise. Each volume is the particle's own: nothing frame-wide but ρ₀.
std::vector<float> particle_volumes(const ParticlesView& particles, double d, double rho0);

/// The velocity weighting's reference speed when not given: the particles' 95th-percentile speed.
double velocity_reference(const AttributeView& velocity);

/// A per-particle array in the grid's sorted order.
template <class T>
std::vector<T> to_sorted_order(const HashGrid& grid, const std::vector<T>& original) {
  std::vector<T> out(original.size());
  const auto order = grid.order();
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = original[order[i]];
  return out;
}

// --- budget.cpp: the memory a run may use --------------------------------------------------------

/// Refuses, before allocating, a field that would not fit in `max_bytes`, and a run whose field,
/// mesh and smoothing would not (`limit_from`: where the limit comes from, for the message).
/// Returns the band's block keys (band_blocks).
std::vector<uint64_t> checked_band_blocks(const HashGrid& grid, const SampleLattice& lattice, float band,
                                          double max_bytes, const Params& p, const std::string& limit_from);

// --- order_keys.cpp: the vertex order keys of reconstruct_ordered (meniscus/distributed.hpp) ------

/// The integer attribute that carries each vertex's order key through the CPU stages from the
/// extraction on (the voids, blobs, reorder and strays move attributes with their vertices);
/// reconstruct_ordered takes it off the mesh. Four integer values under 2^24, exact as floats
/// (16 bytes a vertex): the 63-bit edge key and the 30-bit Z-order code above it.
inline constexpr const char* kOrderKeyAttribute = "meniscus order key";

/// The attribute for the extracted vertices `positions` and their edge keys: the Z-order code is
/// morton_key's on cells of `cell` (the reorder's), or 0 with cell 0 (no sweep: no reorder).
Attribute order_key_attribute(std::span<const Vec3f> positions, const std::vector<uint64_t>& edge_keys, float cell);

/// The keys of the mesh's order-key attribute, which is removed from the mesh (std::logic_error
/// without one).
std::vector<VertexOrderKey> take_order_keys(TriangleMesh& mesh);

// --- the host's stage timer (driver.cpp, cpu_stages.cpp) -------------------------------------------

/// Times a stage on the host's steady clock, appends it to Stats::stages and reports its start and
/// end to the progress callback.
class StageTimer {
 public:
  StageTimer(Stats& stats, const ProgressFn& progress) : stats_(stats), progress_(progress) {}
  template <class F>
  auto run(const char* name, F&& f) {
    if (progress_) progress_(name, 0.0);
    const auto t0 = std::chrono::steady_clock::now();
    if constexpr (std::is_void_v<decltype(f())>) {
      f();
      finish(name, t0);
    } else {
      auto result = f();
      finish(name, t0);
      return result;
    }
  }

 private:
  void finish(const char* name, std::chrono::steady_clock::time_point t0) {
    const double s = seconds_since(t0);
    stats_.stages.push_back({name, s});
    if (progress_) progress_(name, 1.0);
  }
  Stats& stats_;
  const ProgressFn& progress_;
};

}  // namespace meniscus
