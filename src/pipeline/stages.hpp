// meniscus — the stages of a reconstruction as a backend provides them, and the one order the
// driver runs them in (pipeline/driver.cpp), whichever backend: the CPU's (pipeline/cpu_stages.cpp)
// or the CUDA device's (cuda/pipeline_cuda.cpp).
#pragma once

#include <functional>
#include <memory>
#include <span>
#include <vector>

#include "meniscus/reconstruct.hpp"
#include "pipeline/stage_plan.hpp"

namespace meniscus {

/// What the stages of either backend work from: the particles, the resolved parameters, their
/// plan, the SPH volumes per original particle (empty: uniform d³), the particles' velocity
/// attribute (null without one) and, per particle, the first particle at its position
/// (coincident_particles; empty when no two share one): the CPU's queries skip the copies where
/// they change nothing, the device's visit them (the same results). With `order_keys` (the CPU's
/// stages only), the extraction adds the vertices' order-key attribute (kOrderKeyAttribute,
/// reconstruct_ordered).
struct PipelineInput {
  const ParticlesView& particles;
  const Params& params;
  const StagePlan& plan;
  const std::vector<float>& volumes;
  const AttributeView* velocity;
  bool order_keys = false;
  std::span<const uint32_t> coincident = {};
};

/// A backend's side of the plan: one function per stage. run_stages calls them in the plan's
/// order, each through timed(), so the order lives in one place and --stats reports every stage of
/// every backend the same way; a stage function does its work and records its counts in the Stats
/// the backend was made with. A backend's own extra steps (the device's upload, adjacency and
/// download) are stages it times itself, inside prepare(), adjacency() and finish().
class StageBackend {
 public:
  virtual ~StageBackend() = default;
  /// Runs `stage` as the stage `name`: timed (the host's steady clock, or the device's CUDA
  /// events), its start and end reported to the progress callback, its time added to Stats.
  virtual void timed(const char* name, const std::function<void()>& stage) = 0;
  virtual void prepare() {}       ///< before the first stage (the device: checks and "upload")
  virtual void particles() = 0;   ///< "particles": Yu & Turk's pass, when the plan has it
  virtual void grid() = 0;        ///< "grid": the hash grid of the (smoothed) particles
  virtual void field() = 0;       ///< "field": the band of the distance or kernel field
  virtual void extract() = 0;     ///< "extract": marching and weld; the field is freed
  virtual void voids() = 0;       ///< "voids": small closed inward components
  virtual void blobs() = 0;       ///< "blobs": small closed components no particle supports
  virtual void handles() = 0;     ///< "handles": small handles round air cut and capped, when asked
  virtual void reorder() = 0;     ///< "reorder": vertices in Morton order, when any sweep runs
  virtual void adjacency() {}     ///< before the sweeps (the device: "adjacency")
  virtual void smooth() = 0;      ///< "smooth": the schedule of constrained sweeps
  virtual void erode() = 0;       ///< "erode", when the plan has it
  virtual void transfer() = 0;    ///< "transfer": the attributes asked for onto the vertices
  virtual void normals() = 0;     ///< "normals"
  /// After the last stage: the finished mesh, on the host (the device: "download").
  virtual void finish(TriangleMesh& mesh) = 0;
};

/// Runs the plan's stages on `backend`, in their one order, into `mesh`.
void run_stages(const StagePlan& plan, StageBackend& backend, TriangleMesh& mesh);

/// The CPU's stages (pipeline/cpu_stages.cpp), recording into `stats`.
std::unique_ptr<StageBackend> make_cpu_stages(const PipelineInput& in, Stats& stats, const ProgressFn& progress);

namespace cuda {
/// The CUDA device's stages (cuda/pipeline_cuda.cpp) on device 0; throws ResourceError (CudaError)
/// where the backend is not built or the device cannot be used.
std::unique_ptr<StageBackend> make_device_stages(const PipelineInput& in, Stats& stats, const ProgressFn& progress);
}  // namespace cuda

}  // namespace meniscus
