// meniscus — the memory a run may use: the field's and the whole run's estimates, checked
// before the field is allocated (--max-memory, or 90 % of what the process is granted).
#include <unistd.h>

#include <fstream>

#include <fmt/format.h>

#include "extract/field_band.hpp"
#include "field/distance_field.hpp"
#include "field/sparse_field.hpp"
#include "meniscus/errors.hpp"
#include "meniscus/messages.hpp"
#include "pipeline/internal.hpp"

namespace meniscus {

namespace {

/// The process's resident memory now (0 where /proc is not there).
double resident_bytes() {
  std::ifstream statm("/proc/self/statm");
  double pages = 0, resident = 0;
  return statm >> pages >> resident ? resident * double(sysconf(_SC_PAGE_SIZE)) : 0.0;
}

/// What a run needs per block of the field band, through the smoothing: the block's samples, the
/// mesh extracted in it and that mesh's smoothing arrays. Set from the bundled real frames' peak
/// RSS over the baseline per field block (default field), near the top of their range; the 90 %
/// default share of the grant is the margin.
constexpr double kRunBytesPerBandBlock = 24e3;
/// What the simplification adds a block where it runs (--decimate): the points, normals, the
/// finished mesh's triangles and the patches it keeps over the finished mesh. Set above what the
/// bundled frames measure a block at E = 0.02.
constexpr double kDecimateBytesPerBandBlock = 32e3;

}  // namespace

/// Refuses, before allocating, a field that would not fit in `max_bytes`, and a run whose field,
/// mesh and smoothing would not (`limit_from`: where the limit comes from, for the message).
std::vector<uint64_t> checked_band_blocks(const HashGrid& grid, const SampleLattice& lattice, float band,
                                          double max_bytes, const Params& p, const std::string& limit_from) {
  // Upper bound on the keys band_blocks() would list (each occupied hash cell's box expanded by
  // the band, in blocks), so an absurd voxel size is refused before the key list is built.
  const double block_size = double(lattice.cell_size) * lattice.block_cells();
  const double span = (double(grid.cell_size()) + 2.0 * band) / block_size + 1.0;
  const double bound = double(grid.cell_keys().size()) * span * span * span;
  const auto refuse = [&](double blocks) {
    throw ResourceError(fmt::format(
        "the distance field would need about {} ({:.3g} blocks of {} samples at voxel size {:g}), more than "
        "the {} allowed ({}); use a larger {} or raise {}",
        human_bytes(blocks * kBlockSamples * 4), blocks, kBlockSamples, p.voxel_size, human_bytes(max_bytes), limit_from,
        spelled("voxel_size"), spelled("max_memory_gb")));
  };
  if (bound * 8.0 > max_bytes) refuse(bound);
  std::vector<uint64_t> keys = band_blocks(grid, lattice, band);
  if (double(keys.size()) * (kBlockSamples * 4 + 20) > max_bytes) refuse(double(keys.size()));
  const double per_block = kRunBytesPerBandBlock + (p.decimate > 0 ? kDecimateBytesPerBandBlock : 0);
  const double resident = resident_bytes(), need = resident + double(keys.size()) * per_block;
  if (need > max_bytes)
    throw ResourceError(fmt::format(
        "this frame would need about {} ({} in use, {} field blocks at voxel size {:g} for the field, the mesh and its "
        "smoothing{}), more than the {} allowed ({}); use a larger {}, or give the job more memory ({}, Slurm's --mem)",
        human_bytes(need), human_bytes(resident), keys.size(), p.voxel_size,
        p.decimate > 0 ? fmt::format(" and {}", spelled("decimate")) : std::string(), human_bytes(max_bytes),
        limit_from, spelled("voxel_size"), spelled("max_memory_gb")));
  return keys;
}

}  // namespace meniscus
