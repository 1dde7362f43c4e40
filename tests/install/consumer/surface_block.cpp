// Surfaces a block of particles through the installed library and checks the mesh is closed.
#include <meniscus/io.hpp>
#include <meniscus/quality.hpp>
#include <meniscus/reconstruct.hpp>

#include <cstdio>

int main(int argc, char** argv) {
  meniscus::ParticleSet block;
  for (int k = 0; k < 10; ++k)
    for (int j = 0; j < 10; ++j)
      for (int i = 0; i < 10; ++i) block.positions.push_back({0.1f * float(i), 0.1f * float(j), 0.1f * float(k)});
  const meniscus::Result r = meniscus::reconstruct(block, meniscus::Params{});
  const bool closed = meniscus::analyze_topology(r.mesh).watertight();
  std::printf("%zu particles -> %zu vertices, %zu triangles, %s\n", block.size(), r.mesh.vertices.size(),
              r.mesh.triangles.size(), closed ? "watertight" : "NOT watertight");
  if (argc > 1) meniscus::write_mesh(argv[1], r.mesh);
  return closed && !r.mesh.triangles.empty() ? 0 : 1;
}
