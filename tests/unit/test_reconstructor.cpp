// meniscus::Reconstructor (reconstruct.hpp): made once, called per frame as a simulator's loop
// calls it; every call gives reconstruct()'s mesh bit for bit, reads the caller's arrays in place
// (ParticlesView), and a call while another runs is refused, not raced.
#include <gtest/gtest.h>

#include <condition_variable>
#include <cstring>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "meniscus/errors.hpp"
#include "meniscus/io.hpp"
#include "meniscus/reconstruct.hpp"
#include "support/test_support.hpp"

namespace meniscus {
namespace {

void expect_same_mesh(const TriangleMesh& a, const TriangleMesh& b, const std::string& frame) {
  SCOPED_TRACE(frame);
  ASSERT_EQ(a.vertices.size(), b.vertices.size());
  ASSERT_EQ(a.triangles.size(), b.triangles.size());
  EXPECT_EQ(0, std::memcmp(a.vertices.data(), b.vertices.data(), a.vertices.size() * sizeof(Vec3f)));
  EXPECT_EQ(a.triangles, b.triangles);
  ASSERT_EQ(a.normals.size(), b.normals.size());
  EXPECT_EQ(0, std::memcmp(a.normals.data(), b.normals.data(), a.normals.size() * sizeof(Vec3f)));
  ASSERT_EQ(a.attributes.size(), b.attributes.size());
  for (std::size_t k = 0; k < a.attributes.size(); ++k) {
    EXPECT_EQ(a.attributes[k].name, b.attributes[k].name);
    EXPECT_EQ(a.attributes[k].values, b.attributes[k].values);
  }
}

/// A velocity per particle (a swirl about the z axis), for the transfer.
ParticleSet with_velocity(ParticleSet p) {
  Attribute v{"velocity", 3, false, {}};
  for (const Vec3f& x : p.positions) v.values.insert(v.values.end(), {-x.y, x.x, 0.5f});
  p.attributes.push_back(std::move(v));
  return p;
}

TEST(Reconstructor, EveryFrameGivesReconstructsMeshBitForBitAsTheCountAndExtentChange) {
  // Frames as a loop hands them over: growing, moving, shrinking, far away, then a real one; the
  // spacing is estimated on each (as reconstruct() does), the velocity carried onto the mesh.
  std::vector<ParticleSet> frames;
  frames.push_back(with_velocity(test::lattice_block(6, 6, 6, 0.1f, 0.02f, 1)));
  frames.push_back(with_velocity(test::lattice_block(14, 7, 6, 0.1f, 0.02f, 2, {3, 0, 0})));
  frames.push_back(with_velocity(test::lattice_block(3, 3, 3, 0.05f, 0.01f, 3, {-40, 7, 2})));
  frames.push_back(with_velocity(test::lattice_block(9, 9, 4, 0.1f, 0.03f, 4)));
  ParticleSet real = read_particles(test::data_file("dam_break_frame_9_6859_particles.bgeo"));
  frames.push_back(with_velocity(std::move(real)));
  Params p;
  p.transfer = {"velocity"};
  p.threads = 2;
  Reconstructor surface(p);
  for (std::size_t f = 0; f < frames.size(); ++f) {
    const Result once = reconstruct(frames[f], p);
    const Result looped = surface(frames[f]);
    expect_same_mesh(once.mesh, looped.mesh, "frame " + std::to_string(f));
    EXPECT_EQ(once.params.spacing, looped.params.spacing);
    EXPECT_EQ(once.stats.genus, looped.stats.genus);
    EXPECT_EQ(once.stats.components, looped.stats.components);
    EXPECT_GT(looped.mesh.triangles.size(), 100u);
  }
  EXPECT_EQ(surface.frames(), frames.size());
  EXPECT_EQ(surface.params().spacing, 0.0);  // as given: each frame's own estimate
}

TEST(Reconstructor, ReadsTheCallersArraysInPlace) {
  // A simulator's arrays: positions and a density in buffers of its own, handed over as views.
  const ParticleSet block = test::lattice_block(8, 8, 5, 0.1f, 0.02f, 5);
  std::vector<float> xyz(3 * block.size()), density(block.size());
  for (std::size_t i = 0; i < block.size(); ++i) {
    std::memcpy(&xyz[3 * i], &block.positions[i], sizeof(Vec3f));
    density[i] = 1000.0f + float(i % 7);
  }
  ParticlesView view(std::span<const Vec3f>(reinterpret_cast<const Vec3f*>(xyz.data()), block.size()),
                     {AttributeView("density", 1, false, density)});
  ParticleSet owned = view.copy();
  EXPECT_EQ(owned.positions, block.positions);
  ASSERT_NE(owned.find("density"), nullptr);
  EXPECT_EQ(owned.find("density")->values, density);

  Params p;
  p.spacing = 0.1;
  p.field = FieldMethod::sph;  // reads the density
  p.transfer = {"density"};
  Reconstructor surface(p);
  const Result from_view = surface(view);
  const Result from_set = reconstruct(owned, p);
  expect_same_mesh(from_view.mesh, from_set.mesh, "view");
  EXPECT_GT(from_view.mesh.triangles.size(), 1000u);
  EXPECT_EQ(from_view.mesh.vertices.size(), from_view.mesh.find("density")->values.size());

  // A view whose attribute does not match the particle count is refused by name, as a set's is.
  view.attributes[0].values = std::span<const float>(density).first(density.size() - 1);
  EXPECT_THROW(surface(view), InvalidParameter);
}

TEST(Reconstructor, BadParametersAreRefusedWhenItIsMade) {
  Params p;
  p.steps_a = 20001;
  EXPECT_THROW(Reconstructor{p}, InvalidParameter);
  Params q;
  q.r_inner = 2;
  q.r_outer = 1;
  EXPECT_THROW(Reconstructor{q}, InvalidParameter);
}

TEST(Reconstructor, ACallWhileAnotherRunsIsRefusedAndTheRunningOneFinishes) {
  const ParticleSet block = test::lattice_block(6, 6, 6, 0.1f, 0.02f, 6);
  Params p;
  p.spacing = 0.1;
  Reconstructor surface(p);
  const Result alone = surface(block);

  // Thread A's call waits in its progress callback until thread B's call has come back.
  std::mutex m;
  std::condition_variable cv;
  bool a_inside = false, b_done = false;
  std::string refused;
  Result a_result;
  std::thread a([&] {
    a_result = surface(block, [&](std::string_view, double) {
      std::unique_lock lock(m);
      if (!a_inside) {
        a_inside = true;
        cv.notify_all();
      }
      cv.wait(lock, [&] { return b_done; });
    });
  });
  std::thread b([&] {
    {
      std::unique_lock lock(m);
      cv.wait(lock, [&] { return a_inside; });
    }
    try {
      surface(block);
    } catch (const std::runtime_error& e) {
      refused = e.what();
    }
    std::lock_guard lock(m);
    b_done = true;
    cv.notify_all();
  });
  a.join();
  b.join();
  EXPECT_NE(refused.find("one Reconstructor per thread"), std::string::npos) << refused;
  expect_same_mesh(a_result.mesh, alone.mesh, "the running call");
  // From its own progress callback too; and it surfaces again afterwards.
  bool inner_refused = false;
  surface(block, [&](std::string_view, double) {
    if (inner_refused) return;
    try {
      surface(block);
    } catch (const std::runtime_error&) {
      inner_refused = true;
    }
  });
  EXPECT_TRUE(inner_refused);
  expect_same_mesh(surface(block).mesh, alone.mesh, "afterwards");
  EXPECT_EQ(surface.frames(), 4u);
}

}  // namespace
}  // namespace meniscus
