// meniscus — the energy guard's undo of a Gauss-Seidel sweep (see the header).
#include "smooth/sweep_undo.hpp"

#include "common/parallel_index.hpp"

namespace meniscus {

void SweepUndo::undo(std::span<Vec3f> x) const {
  parallel_for_index(x.size(), 4096, [&](std::size_t i) {
    const int16_t* u = ulps_.data() + 3 * i;
    if (u[0] == kAside) return;
    for (int k = 0; k < 3; ++k)
      x[i][k] = std::bit_cast<float>(int32_t(uint32_t(std::bit_cast<int32_t>(x[i][k])) + uint32_t(int32_t(u[k]))));
  });
  for (const auto& list : aside_)
    for (const auto& [i, before] : list) x[i] = before;
}

}  // namespace meniscus
