// Tests of the field-method building blocks: the 3×3 symmetric eigen-solver, the kernels, Yu &
// Turk's ellipsoids, the kernel fields' level-0 form, the ellipsoid constraint projection and the
// point-to-surface distance of the flicker metric.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <span>

#include "extract/extract.hpp"
#include "field/anisotropy.hpp"
#include "field/anisotropy_impl.hpp"
#include "field/band_field.hpp"
#include "field/distance_field.hpp"
#include "field/eigen_sym3_impl.hpp"
#include "field/kernel_field.hpp"
#include "field/kernel_impl.hpp"
#include "grid/build_grid.hpp"
#include "meniscus/io.hpp"
#include "meniscus/quality.hpp"
#include "meniscus/reconstruct.hpp"
#include "mesh/closest_point_impl.hpp"
#include "smooth/constraint_impl.hpp"
#include "smooth/constraints.hpp"
#include "smooth/smooth.hpp"
#include "support/io_helpers.hpp"
#include "support/test_support.hpp"

namespace meniscus {
namespace {

/// Q diag(l) Qᵀ for the rotation Q of angle `angle` about the unit axis `axis`.
void make_matrix(const double (&l)[3], Vec3f axis, double angle, double (&a)[3][3], double (&q)[3][3]) {
  // Normalized in double: a float unit vector is off by ~1e-8, which would perturb the spectrum.
  const double n = std::sqrt(double(axis.x) * axis.x + double(axis.y) * axis.y + double(axis.z) * axis.z);
  const double c = std::cos(angle), s = std::sin(angle), x = axis.x / n, y = axis.y / n, z = axis.z / n;
  const double r[3][3] = {{c + x * x * (1 - c), x * y * (1 - c) - z * s, x * z * (1 - c) + y * s},
                          {y * x * (1 - c) + z * s, c + y * y * (1 - c), y * z * (1 - c) - x * s},
                          {z * x * (1 - c) - y * s, z * y * (1 - c) + x * s, c + z * z * (1 - c)}};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      q[i][j] = r[i][j];
      a[i][j] = 0;
      for (int k = 0; k < 3; ++k) a[i][j] += r[i][k] * l[k] * r[j][k];
    }
}

/// The A15 lattice of cell d (the pipeline's for spacing d).
SampleLattice a15_lattice(float d) {
  SampleLattice lattice;
  lattice.kind = SampleLattice::Kind::a15;
  lattice.cell_size = d;
  return lattice;
}

/// The anisotropic field over `grid`'s centres with these ellipsoids (in the grid's order):
/// support R, uniform volumes d³, iso 0.5.
KernelFieldInput anisotropic_input(const HashGrid& grid, std::span<const Ellipsoid> ellipsoids, float R, float d) {
  KernelFieldInput in;
  in.centres = &grid;
  in.method = FieldMethod::anisotropic;
  in.kernel_radius = R;
  in.iso = 0.5f;
  in.uniform_volume = d * d * d;
  in.ellipsoids = ellipsoids;
  return in;
}

TEST(EigenSym3, RecoversKnownSpectraAndVectors) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  const double spectra[][3] = {{3, 2, 1}, {1, 1, 1}, {5, 5, 1e-4}, {1, 1e-6, 1e-7}, {-2, 0.5, 7}, {1e3, 1, 1e-3}};
  for (const auto& l : spectra)
    for (int trial = 0; trial < 20; ++trial) {
      const Vec3f axis = normalized(Vec3f{float(u(rng)), float(u(rng)), float(u(rng))});
      double a[3][3], q[3][3];
      make_matrix(l, axis, 3.0 * u(rng), a, q);
      const Eigen3<double> e = eigen_sym3(a);
      double sorted[3] = {l[0], l[1], l[2]};
      std::sort(sorted, sorted + 3, [](double x, double y) { return x > y; });
      const double scale = std::max({std::abs(l[0]), std::abs(l[1]), std::abs(l[2])});
      for (int k = 0; k < 3; ++k) {
        EXPECT_NEAR(e.values[k], sorted[k], 1e-12 * scale) << k;
        // A v = λ v and |v| = 1.
        double res = 0, norm = 0;
        for (int i = 0; i < 3; ++i) {
          double av = 0;
          for (int j = 0; j < 3; ++j) av += a[i][j] * e.vectors[k][j];
          res = std::max(res, std::abs(av - e.values[k] * e.vectors[k][i]));
          norm += e.vectors[k][i] * e.vectors[k][i];
        }
        EXPECT_LT(res, 1e-12 * scale);
        EXPECT_NEAR(norm, 1.0, 1e-12);
      }
      // Orthogonal eigenvectors.
      for (int k = 0; k < 3; ++k)
        for (int m = k + 1; m < 3; ++m) {
          double d = 0;
          for (int i = 0; i < 3; ++i) d += e.vectors[k][i] * e.vectors[m][i];
          if (sorted[k] != sorted[m]) {
            EXPECT_LT(std::abs(d), 1e-12);
          }
        }
    }
}

TEST(EigenSym3, FloatIsAccurateToRoundingAndHandlesDiagonalInput) {
  const float diag[3][3] = {{2, 0, 0}, {0, 5, 0}, {0, 0, 1}};
  const Eigen3<float> d = eigen_sym3(diag);
  EXPECT_EQ(d.values[0], 5.0f);
  EXPECT_EQ(d.values[1], 2.0f);
  EXPECT_EQ(d.values[2], 1.0f);
  EXPECT_EQ(std::abs(d.vectors[0][1]), 1.0f);
  // The covariance of points on a plane tilted about x: one eigenvalue ~0 with the plane normal.
  double a[3][3], q[3][3];
  make_matrix({0.04, 0.04, 1e-6}, Vec3f{1, 0, 0}, 0.3, a, q);
  const float af[3][3] = {{float(a[0][0]), float(a[0][1]), float(a[0][2])},
                          {float(a[1][0]), float(a[1][1]), float(a[1][2])},
                          {float(a[2][0]), float(a[2][1]), float(a[2][2])}};
  const Eigen3<float> e = eigen_sym3(af);
  EXPECT_NEAR(e.values[0], 0.04f, 1e-7f);
  EXPECT_NEAR(e.values[2], 1e-6f, 1e-7f);
  // The normal is the third column of q.
  const float dn = float(e.vectors[2][0] * q[0][2] + e.vectors[2][1] * q[1][2] + e.vectors[2][2] * q[2][2]);
  EXPECT_GT(std::abs(dn), 1.0f - 1e-5f);
}

TEST(Kernels, MetaballPoly6AndBulkValues) {
  const float R = 2.0f;
  EXPECT_FLOAT_EQ(metaball_kernel(0, R), 0.25f);
  EXPECT_FLOAT_EQ(metaball_kernel(R * R, R), 0.0f);
  EXPECT_NEAR(metaball_kernel(R * R * 0.999f, R), 0.0f, 1e-6f);
  // Σ over a dense lattice approximates the bulk value used for the default iso.
  const float d = 0.1f;
  double sum = 0, sph = 0;
  for (int i = -25; i <= 25; ++i)
    for (int j = -25; j <= 25; ++j)
      for (int k = -25; k <= 25; ++k) {
        const float r2 = d * d * float(i * i + j * j + k * k);
        sum += metaball_kernel(r2, 2 * d * 10);  // R = 20 d: lattice sum ≈ integral
        sph += double(d * d * d) * poly6_kernel(r2, 20 * d);
      }
  EXPECT_NEAR(sum / metaball_bulk_value(20 * d, d), 1.0, 2e-3);
  EXPECT_NEAR(sph, 1.0, 2e-3);  // unit integral
}

TEST(Kernels, YuTurkEllipsoidIsIsotropicInBulkFlatOnASheetAndClamped) {
  const float d = 0.1f, R = 2 * d, radius = 2 * R;
  AnisotropyConstants k;
  k.bulk_variance = yu_turk_bulk_variance(radius);
  // A lattice block: the centre particle's ellipsoid is within 10 % of the unit sphere.
  const ParticleSet block = test::lattice_block(13, 13, 13, d);
  const HashGrid bg(block.positions, radius);
  const auto eb = yu_turk_ellipsoids(bg, radius, k);
  const Ellipsoid& c = eb[(6 * 13 + 6) * 13 + 6];
  EXPECT_NEAR(c.max_axis, 1.0f, 0.1f);
  EXPECT_NEAR(c.metric.xx, c.metric.zz, 1e-3f);
  EXPECT_NEAR(std::cbrt(c.det), 1.0f, 0.1f);
  // One layer: flat along z, the z axis clamped to σ̃₁ / k_r.
  const ParticleSet sheet = test::lattice_block(15, 15, 1, d);
  const HashGrid sg(sheet.positions, radius);
  const Ellipsoid s = yu_turk_ellipsoids(sg, radius, k)[7 * 15 + 7];
  const Vec3f axis_len{1.0f / (s.metric * Vec3f{1, 0, 0}).x, 1.0f / (s.metric * Vec3f{0, 1, 0}).y,
                       1.0f / (s.metric * Vec3f{0, 0, 1}).z};
  EXPECT_NEAR(axis_len.z * k.k_r, axis_len.x, 1e-4f);
  EXPECT_NEAR(axis_len.x, axis_len.y, 1e-4f);
  EXPECT_NEAR(axis_len.x, s.max_axis, 1e-4f);
  // Too few neighbours: the isotropic k_n kernel.
  const ParticleSet few = test::lattice_block(2, 2, 2, d);
  const HashGrid fg(few.positions, radius);
  const Ellipsoid f = yu_turk_ellipsoids(fg, radius, k)[0];
  EXPECT_FLOAT_EQ(f.max_axis, k.k_n);
  EXPECT_FLOAT_EQ(f.metric.xx, 1.0f / k.k_n);
  // The anisotropic kernel integrates to 1 whatever the ellipsoid.
  double integral = 0;
  const float step = 0.01f;
  for (float x = -0.3f; x <= 0.3f; x += step)
    for (float y = -0.3f; y <= 0.3f; y += step)
      for (float z = -0.3f; z <= 0.3f; z += step) integral += anisotropic_kernel(s, {x, y, z}, R) * step * step * step;
  EXPECT_NEAR(integral, 1.0, 0.02);
}

// The shells' cube root is the correctly rounded one (cbrtf is not, and differs between glibc and
// the device), computed with plain arithmetic that both backends round alike.
TEST(Kernels, CubeRootIsCorrectlyRounded) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> exponent(-40, 38);
  int tried = 0;
  for (int i = 0; i < 200000; ++i) {
    const float x = std::pow(10.0f, exponent(rng));
    if (!(x > 0) || !std::isfinite(x)) continue;
    ++tried;
    ASSERT_EQ(cube_root(x), float(cbrtl(static_cast<long double>(x)))) << x;
  }
  EXPECT_GT(tried, 190000);
  for (float x : {1.0f, 8.0f, 27.0f, 0.125f, 1e-36f, 1e36f}) EXPECT_EQ(cube_root(x), float(cbrtl(static_cast<long double>(x)))) << x;
  EXPECT_EQ(cube_root(0.0f), 0.0f);
}

TEST(KernelField, EveryMethodIsNegativeInsideAndPositiveOutside) {
  const float d = 0.1f;
  const ParticleSet ps = test::lattice_block(8, 8, 8, d);
  const HashGrid grid(ps.positions, 2 * d);
  SampleLattice lattice;
  lattice.cell_size = d / 2;
  AnisotropyConstants k;
  k.bulk_variance = yu_turk_bulk_variance(4 * d);
  const HashGrid pca(ps.positions, 4 * d);
  const std::vector<Ellipsoid> original = yu_turk_ellipsoids(pca, 4 * d, k);
  std::vector<Ellipsoid> sorted(original.size());
  for (std::size_t i = 0; i < sorted.size(); ++i) sorted[i] = original[grid.order()[i]];
  for (FieldMethod m : {FieldMethod::metaball, FieldMethod::sph, FieldMethod::zhu_bridson, FieldMethod::anisotropic}) {
    KernelFieldInput in;
    in.centres = &grid;
    in.method = m;
    in.kernel_radius = 2 * d;
    in.iso = m == FieldMethod::metaball ? float(0.5 * metaball_bulk_value(2 * d, d)) : (m == FieldMethod::zhu_bridson ? d : 0.5f);
    in.uniform_volume = d * d * d;
    in.ellipsoids = sorted;
    const float band = kernel_support(in) + d;
    const SparseField f = kernel_field(in, lattice, band_blocks(grid, lattice, band));
    EXPECT_GT(f.background(), 0) << to_string(m);
    // Centre of the block (cell 7,7,7 = 0.35): inside; 2 d above the top layer: outside.
    EXPECT_LT(f.value({7, 7, 7}, 0), 0.0f) << to_string(m);
    EXPECT_GT(f.value({7, 7, 14 + 4}, 0), 0.0f) << to_string(m);
    EXPECT_EQ(f.value({7, 7, 200}, 0), f.background()) << to_string(m);
  }
}

// The field written once for both backends (field/band_field.hpp, run here with Host{} over the
// grid of grid/build_grid.hpp) gathers each sample's kernel sum (kernel_field_sample) where the
// CPU's fast path scatters each particle into its block: the same terms in the same order, so the
// same bits. On a real frame, both lattices, every method, with per-particle volumes and
// ellipsoids, on every ninth block.
TEST(KernelField, PerSampleGatherMatchesTheScatterBitForBit) {
  const ParticleSet ps = read_particles(test::data_file("ply/double_dam_break_frame_26_4732_particles.ply"));
  const float d = float(estimate_spacing(ps)), R = 2 * d;
  const HashGrid grid(ps.positions, 2 * d);
  const uint32_t count = uint32_t(ps.positions.size());
  Vec3f lo, hi;
  point_bounds(Host{}, ps.positions.data(), count, &lo, &hi);
  const GridBuffers<Host> shared_grid =
      build_grid(Host{}, ps.positions.data(), count, 2 * d, grid_cell_of(lo, 2 * d), grid_cell_of(hi, 2 * d));
  AnisotropyConstants k;
  k.bulk_variance = yu_turk_bulk_variance(2 * R);
  const HashGrid pca(ps.positions, 2 * R);
  const std::vector<Ellipsoid> original = yu_turk_ellipsoids(pca, 2 * R, k);
  std::vector<Ellipsoid> ellipsoids(original.size());
  std::vector<float> volumes(original.size());
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> jitter(0.5f, 1.5f);
  for (std::size_t i = 0; i < ellipsoids.size(); ++i) {
    ellipsoids[i] = original[grid.order()[i]];
    volumes[i] = d * d * d * jitter(rng);
  }
  std::size_t compared = 0, inside = 0;
  for (SampleLattice::Kind kind : {SampleLattice::Kind::a15, SampleLattice::Kind::cubic})
    for (FieldMethod m : {FieldMethod::metaball, FieldMethod::sph, FieldMethod::zhu_bridson, FieldMethod::anisotropic}) {
      SampleLattice lattice;
      lattice.kind = kind;
      lattice.cell_size = kind == SampleLattice::Kind::a15 ? d : d / 2;
      KernelFieldInput in;
      in.centres = &grid;
      in.method = m;
      in.kernel_radius = R;
      in.iso = m == FieldMethod::zhu_bridson ? d : (m == FieldMethod::metaball ? float(0.5 * metaball_bulk_value(R, d)) : 0.5f);
      in.volumes = volumes;
      in.uniform_volume = d * d * d;
      in.ellipsoids = ellipsoids;
      std::vector<Ellipsoid> shells;  // anisotropic: the outer shells' part of the field too
      if (m == FieldMethod::anisotropic)
        for (const Ellipsoid& e : ellipsoids) shells.push_back(unit_volume_shell(e));
      in.shells = shells;
      in.shell_radius = d;
      const float support = kernel_support(in);
      const SparseField f = kernel_field(in, lattice, band_blocks(grid, lattice, support + d));
      const KernelParticles kp = kernel_particles(in);
      std::vector<uint64_t> every_ninth;
      for (std::size_t b = 0; b < f.block_count(); b += 9) every_ninth.push_back(f.block_keys()[b]);
      HostBuffer<uint64_t> keys;
      keys.upload(every_ninth.data(), every_ninth.size());
      const FieldBuffers<Host> gathered = kernel_field(Host{}, shared_grid, lattice, kp, support, in.iso, f.background(),
                                                       std::move(keys), every_ninth.size());
      for (std::size_t g = 0; g < every_ninth.size(); ++g) {
        const std::size_t b = 9 * g;
        for (int j = 0; j < kBlockSamples; ++j) {
          const float value = gathered.values.data()[g * kBlockSamples + std::size_t(j)];
          const float scattered = f.block_values(b)[std::size_t(j)];
          ASSERT_TRUE(test::same_bits(value, scattered))
              << to_string(m) << " block " << b << " sample " << j << ": " << value << " vs " << scattered;
          ++compared;
          inside += scattered < 0;
        }
      }
    }
  EXPECT_GT(compared, 100000u);
  EXPECT_GT(inside, compared / 40);  // the comparison covers the inside, not just empty space
}

// A one-layer sheet (stretched 10 %): Yu & Turk's flattened kernels make a level set about 0.5 d
// thick, which a lattice of d/2 samples with holes. With the particles' outer constraint shells
// the inside is the level set united with the shells: every sample the kernels hold keeps their
// value to the bit, every other sample inside a shell takes the shell's value, the rest the
// kernels'; the surface is one closed sheet around every particle.
TEST(KernelField, AnisotropicInsideIsTheLevelSetUnitedWithTheOuterShells) {
  const float d = 0.1f, R = 2 * d;
  const ParticleSet ps = test::lattice_block(12, 12, 1, 1.1f * d, 0.05f, 2);
  const HashGrid grid(ps.positions, 2 * d);
  AnisotropyConstants k;
  k.bulk_variance = yu_turk_bulk_variance(2 * R);
  const HashGrid pca(ps.positions, 2 * R);
  const std::vector<Ellipsoid> original = yu_turk_ellipsoids(pca, 2 * R, k);
  std::vector<Ellipsoid> ellipsoids(original.size()), shells(original.size());
  for (std::size_t i = 0; i < ellipsoids.size(); ++i) {
    ellipsoids[i] = original[grid.order()[i]];
    shells[i] = unit_volume_shell(ellipsoids[i]);
  }
  const SampleLattice lattice = a15_lattice(d);
  KernelFieldInput in = anisotropic_input(grid, ellipsoids, R, d);
  const KernelFieldInput kernels_only = in;
  in.shells = shells;
  in.shell_radius = d;  // r_outer
  const std::vector<uint64_t> keys = band_blocks(grid, lattice, kernel_support(in) + d);
  const SparseField united = kernel_field(in, lattice, keys), level_set = kernel_field(kernels_only, lattice, keys);
  const auto points = grid.sorted_points();
  const int n = lattice.block_cells(), spc = lattice.samples_per_cell();
  std::size_t kept = 0, from_shells = 0;
  for (std::size_t b = 0; b < united.block_count(); ++b) {
    const Vec3i origin = united.block_origin(b);
    for (int j = 0; j < kBlockSamples; ++j) {
      const int cell = j / spc;
      const Vec3f o = lattice.sample_offset(j % spc);
      const float off[3] = {o.x, o.y, o.z};
      const Vec3f q = kernel_sample_point({origin.x + cell % n, origin.y + (cell / n) % n, origin.z + cell / (n * n)}, off, d);
      float m = INFINITY;
      for (std::size_t i = 0; i < points.size(); ++i) m = std::min(m, length(shells[i].metric * (q - points[i])));
      const float a = level_set.block_values(b)[std::size_t(j)], u = united.block_values(b)[std::size_t(j)];
      if (a <= 0 || m >= d * 1.00001f) {
        ASSERT_TRUE(test::same_bits(a, u)) << a << " " << u;
        kept += a <= 0;
      } else if (m < d * 0.99999f) {
        ASSERT_NEAR(u, 0.5f * (m / d - 1), 1e-5f);
        ++from_shells;
      }
    }
  }
  EXPECT_GT(kept, 500u);         // measured 911
  EXPECT_GT(from_shells, 500u);  // 677: the shells do hold samples the level set leaves out
  const TriangleMesh sheet = extract_surface(united, 0.0f, Extractor::tiles).mesh;
  const TopologyReport t = analyze_topology(sheet);
  EXPECT_TRUE(t.watertight());
  EXPECT_EQ(t.components, 1u);
  EXPECT_EQ(t.euler, 2);
  EXPECT_EQ(points_outside(sheet, ps.positions), 0u);
  // The level set alone: a sheet with a hole (χ = 0).
  EXPECT_LT(analyze_topology(extract_surface(level_set, 0.0f, Extractor::tiles).mesh).euler, 2);
}

// A kernel centre that the Laplacian smoothing pulled farther from its particle than `reach` in
// the metric of the particle's shell is taken back along the line to the particle, to `reach`.
TEST(Kernels, CentreHoldingParticleKeepsTheParticleWithinReach) {
  Ellipsoid flat;  // axes 2, 2, 1/4 (unit volume): thin along z
  flat.metric = SymMat3{0.5f, 0, 0, 0.5f, 0, 4.0f};
  flat.max_axis = 2;
  flat.min_axis = 0.25f;
  flat.det = 1;
  const Vec3f x{1, 2, 3};
  // Along the thin axis: 0.1 is metric 0.4, beyond reach 0.3: back to 0.075 from x.
  const Vec3f pulled = centre_holding_particle(x, x + Vec3f{0, 0, -0.1f}, flat, 0.3f);
  EXPECT_NEAR(pulled.z - x.z, -0.075f, 1e-6f);
  EXPECT_EQ(pulled.x, x.x);
  EXPECT_NEAR(length(flat.metric * (x - pulled)), 0.3f, 1e-6f);
  // Along a long axis 0.1 is metric 0.05: within reach, untouched; reach 0: no bound.
  EXPECT_EQ(centre_holding_particle(x, x + Vec3f{0.1f, 0, 0}, flat, 0.3f), (x + Vec3f{0.1f, 0, 0}));
  EXPECT_EQ(centre_holding_particle(x, x + Vec3f{0, 0, -0.1f}, flat, 0.0f), (x + Vec3f{0, 0, -0.1f}));
}

TEST(EllipsoidConstraint, ProjectionOntoTheShellIsExactInTheMetric) {
  const SymMat3 a{2.0f, 0.3f, 0.0f, 0.8f, -0.1f, 4.0f};
  const Vec3f c{1, 2, 3};
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-1, 1);
  for (int i = 0; i < 1000; ++i) {
    const Vec3f x = c + Vec3f{u(rng), u(rng), u(rng)};
    const Vec3f y = project_to_ellipsoid_shell(x, c, a, 0.2f, 0.5f);
    const float m = metric_distance(a, y, c);
    EXPECT_GE(m, 0.2f * (1 - 1e-6f));
    EXPECT_LE(m, 0.5f * (1 + 1e-6f));
    // Along the line from the centre.
    EXPECT_LT(length(cross(normalized(y - c), normalized(x - c))), 1e-5f);
  }
  EXPECT_NEAR(metric_distance(a, project_to_ellipsoid_shell(c, c, a, 0.2f, 0.5f), c), 0.2f, 1e-6f);
}

TEST(EllipsoidConstraint, SmoothedJitteredBlockResidualIsBelow1e5Relative) {
  const float d = 0.1f, R = 2 * d;
  const ParticleSet ps = test::lattice_block(14, 12, 6, d, 0.2f, 9);
  const HashGrid raw(ps.positions, 2 * R);
  AnisotropyConstants k;
  k.bulk_variance = yu_turk_bulk_variance(2 * R);
  const std::vector<Ellipsoid> original = yu_turk_ellipsoids(raw, 2 * R, k);
  const std::vector<Vec3f> centres = smooth_positions(raw, 2 * d, 0.9f);
  const HashGrid grid(centres, 2 * d);
  std::vector<Ellipsoid> sorted(original.size());
  float max_axis = 0;
  for (std::size_t i = 0; i < sorted.size(); ++i) {
    sorted[i] = original[grid.order()[i]];
    max_axis = std::max(max_axis, sorted[i].max_axis);
  }
  const SampleLattice lattice = a15_lattice(d);
  KernelFieldInput in = anisotropic_input(grid, sorted, R, d);
  const SparseField f = kernel_field(in, lattice, band_blocks(grid, lattice, kernel_support(in) + d));
  TriangleMesh mesh = extract_surface(f, 0.0f, Extractor::tiles).mesh;
  // The constraint shells the pipeline uses: the kernel ellipsoids scaled to unit volume.
  std::vector<Ellipsoid> shells(sorted.size());
  float shell_axis = 0;
  for (std::size_t i = 0; i < sorted.size(); ++i) {
    shells[i] = unit_volume_shell(sorted[i]);
    const SymMat3& a = shells[i].metric;
    const float det = a.xx * (a.yy * a.zz - a.yz * a.yz) - a.xy * (a.xy * a.zz - a.yz * a.xz) + a.xz * (a.xy * a.yz - a.yy * a.xz);
    EXPECT_NEAR(det, 1.0f, 1e-4f);
    shell_axis = std::max(shell_axis, shells[i].max_axis);
  }
  const EllipsoidConstraint c{&grid, shells, 0.5f * d, d, shell_axis};
  const double before = ellipsoid_constraint_residual(c, mesh.vertices);
  SmoothOptions o;
  o.steps_free = 0;
  TriangleMesh plain = mesh;
  smooth_surface(mesh.vertices, mesh.triangles, &c, o);
  // The sweeps on the 32-bit neighbour lists give the same bits as on the 16-bit ones.
  o.compact_neighbors = false;
  smooth_surface(plain.vertices, plain.triangles, &c, o);
  ASSERT_TRUE(plain.triangles == mesh.triangles);
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i)
    for (int a = 0; a < 3; ++a) ASSERT_TRUE(test::same_bits(plain.vertices[i][a], mesh.vertices[i][a])) << i;
  const double after = ellipsoid_constraint_residual(c, mesh.vertices);
  EXPECT_GT(before, 0.05 * d) << "the raw extraction should violate the shells somewhere";
  EXPECT_LE(after, 1e-5 * d) << "residual " << after / d << " r_outer (before smoothing " << before / d << ")";
  EXPECT_TRUE(analyze_topology(mesh).watertight());
}

TEST(SurfaceDistance, MatchesBruteForceOnASphereAndIsZeroOnItself) {
  const float d = 0.1f;
  const ParticleSet ps = test::shell_ball(0.6f, d);
  const HashGrid grid(ps.positions, 2 * d);
  const SampleLattice lattice = a15_lattice(d);
  const SparseField f = distance_field(grid, lattice, 1.2f * d, band_blocks(grid, lattice, 1.2f * d));
  const TriangleMesh mesh = extract_surface(f, d, Extractor::tiles).mesh;
  const SurfaceDistanceReport self = distance_to_surface(mesh.vertices, mesh);
  EXPECT_EQ(self.count, mesh.vertices.size());
  EXPECT_EQ(self.max, 0.0);
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-1.2f, 1.2f);
  std::vector<Vec3f> pts(200);
  for (Vec3f& p : pts) p = {u(rng), u(rng), u(rng)};
  const SurfaceDistanceReport r = distance_to_surface(pts, mesh);
  double mean = 0, worst = 0;
  for (const Vec3f& p : pts) {
    float best = INFINITY;
    for (const Triangle& t : mesh.triangles)
      best = std::min(best, length(closest_point_on_triangle(p, mesh.vertices[t[0]], mesh.vertices[t[1]], mesh.vertices[t[2]]) - p));
    mean += best;
    worst = std::max(worst, double(best));
  }
  EXPECT_NEAR(r.mean, mean / 200, 1e-6);
  EXPECT_NEAR(r.max, worst, 1e-6);
  EXPECT_LE(r.p95, r.max);
}

}  // namespace
}  // namespace meniscus
