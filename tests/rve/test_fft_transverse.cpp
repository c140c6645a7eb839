// Transverse loading of a glass fiber in a nearly incompressible Gent matrix with the fiber stretch
// free (F22 = λ, F21 = F23 = F13 = 0 prescribed, every other P̄ component zero), the case of
// BENCHMARKS.md "FFT solver cost": the conforming FE engine as the reference of the FFT engine, and the
// cost of the FFT Newton iteration on it.
//
// What the figures say (bench_rve freefiber ... fe=D kg=X disc=D): the FE answer converges with the
// mesh (K/G = 100: P22 0.066242, 0.066178, 0.066170 at L/8, L/16, L/24) and the FFT hex discretization
// converges to it at first order (0.0839, 0.0750, 0.0704 at 32², 64², 128²), while the rotated scheme
// converges to a value 23 % below it (0.0507, 0.0506, 0.0501) — at K/G = 1.2e5 40 % below (0.0533 at
// 32² against the FE 0.08847). The rotated (and spectral) discretization is inconsistent for in-plane
// flow of a nearly incompressible matrix around a stiff fiber; the indefinite Newton systems of this case
// come with it (none with hex at K/G = 100), not from a bifurcation of the cell: the 8² and 16² Newton
// operators of the converged rotated states are positive definite at every step (bench_rve eigen).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "softhom/materials/laws.hpp"
#include "softhom/rve/fe_mesh.hpp"
#include "softhom/rve/fe_solver.hpp"
#include "softhom/rve/fft_solver.hpp"
#include "softhom/rve/geometry.hpp"
#include "rve/rve_test_helpers.hpp"

using namespace softhom;
using namespace softhom::rve;
using softhom::rve::testing::glass;

namespace {

Section circle_section() {
  FiberCellSpec spec;
  spec.shape = SectionShape::circle;
  spec.arrangement = Arrangement::square;
  spec.volume_fraction = 0.23;
  spec.radius = 0.2;
  return generate_section(spec);
}

MaterialPtr gent_matrix(double k_over_g) {
  return make_material(make_gent_hgo({0.017, 14.0, 0.017 * k_over_g, {}, FiberInvariant::full, true}));
}

/// F22: 1 → 1.5 in `steps` steps (8: the figures of the iteration counts below); F21 = F23 = F13 = 0;
/// every other component stress-free.
MixedControl transverse_fiber_free(int steps = 8) {
  MixedControl c = uniaxial_control(PiecewiseLinear{{0.0, 1.0}, {1.0, 1.5}});
  c.times.clear();
  for (int s = 1; s <= steps; ++s) c.times.push_back(double(s) / steps);
  for (int k = 0; k < 9; ++k) {
    c.kind[k] = ControlKind::stress;
    c.value[k] = PiecewiseLinear::constant(0.0);
  }
  c.kind[4] = ControlKind::deformation;
  c.value[4] = PiecewiseLinear{{0.0, 1.0}, {1.0, 1.5}};
  for (int k : {3, 5, 2}) c.kind[k] = ControlKind::deformation;
  return c;
}

RveRunResult fe_run(double k_over_g, double divisions, int steps = 8) {
  const Section section = circle_section();
  SectionMeshOptions mo;
  mo.mesh_size = section.L1 / divisions;
  mo.interface_size = mo.mesh_size / 3.0;
  FeSolverOptions fo;
  fo.tolerance = 1e-8;
  FeRveSolver fe(mesh_section(section, mo), gent_matrix(k_over_g), glass(), 90.0, Mat3::Identity(), fo);
  return fe.run(transverse_fiber_free(steps));
}

RveRunResult fft_run(double k_over_g, int n, fft::Discretization d,
                     VolumetricKinematics volumetric = VolumetricKinematics::pointwise, bool mixed_pressure = true,
                     int steps = 8) {
  FftSolverOptions o;
  o.tolerance = 1e-6;
  o.mixed_pressure = mixed_pressure;
  o.discretization = d;
  o.volumetric = volumetric;
  o.plan.rigor = fft::PlanRigor::estimate;
  FftRveSolver s(voxelize_section(circle_section(), n, n), gent_matrix(k_over_g), glass(), 90.0, Mat3::Identity(), o);
  return s.run(transverse_fiber_free(steps));
}

void print(const char* what, const RveRunResult& r) {
  std::printf("[ info     ] %s: Newton %d, Krylov %d (discarded %d), shifted %d, cut-backs %d, P22 %.7g, F11 %.7g\n", what,
              r.newton_iterations, r.krylov_iterations, r.discarded_krylov_iterations, r.shifted_solves, r.cutbacks,
              r.steps.back().P(1, 1), r.steps.back().F(0, 0));
}

}  // namespace

// K/G = 100, where the hex discretization does not lock at 32²–64²: its first-order Richardson
// extrapolation 2 P(64²) − P(32²) = 0.06620 agrees with the FE reference (0.066242 at L/8, which
// is within 1.1e-3 of the L/24 value 0.066170) to 7e-4. Tolerance 1 %: the extrapolation's O(h²)
// remainder (the 64²–128² pair gives 0.06567, 0.8 % lower). The rotated scheme at 32² is asserted to lie
// 15–35 % below the reference (measured 23.4 %): this test fails when that discretization changes,
// in either direction — a consistent scheme for this case should replace the band by the tolerance above.
// Every run in two load steps: the end states are the eight-step runs' to 7 digits of P22 (measured: FE
// 13 Newton against 32, hex 32² 448 Krylov against 979, 64² 538 against 1 099, rotated 2 796 against
// 3 966, still no shifted solve on the hex path); the counts of eight steps are asserted below.
TEST(FftRveTransverse, HexConvergesToTheFeReferenceAndRotatedDoesNot) {
  const int steps = 2;
  const RveRunResult fe = fe_run(100.0, 8, steps);
  ASSERT_TRUE(fe.completed) << fe.error;
  print("FE L/8", fe);
  const double reference = fe.steps.back().P(1, 1);
  EXPECT_NEAR(reference, 0.066170, 3e-3 * 0.066170);  // the L/24 value; L/8 is 1.1e-3 above it
  EXPECT_NEAR(fe.steps.back().P(0, 0), 0.0, 1e-10);

  const auto hex = [&](int n) {
    return fft_run(100.0, n, fft::Discretization::hex, VolumetricKinematics::pointwise, true, steps);
  };
  const RveRunResult h32 = hex(32), h64 = hex(64);
  ASSERT_TRUE(h32.completed && h64.completed) << h32.error << h64.error;
  print("FFT hex 32²", h32);
  print("FFT hex 64²", h64);
  const double richardson = 2.0 * h64.steps.back().P(1, 1) - h32.steps.back().P(1, 1);
  EXPECT_NEAR(richardson, reference, 0.01 * reference);
  // No negative curvature at all on the hex path (0 shifted solves measured at 32², 64², 128²).
  EXPECT_EQ(h32.shifted_solves + h64.shifted_solves, 0);

  const RveRunResult rot = fft_run(100.0, 32, fft::Discretization::rotated, VolumetricKinematics::pointwise, true, steps);
  ASSERT_TRUE(rot.completed) << rot.error;
  print("FFT rotated 32²", rot);
  const double gap = 1.0 - rot.steps.back().P(1, 1) / reference;
  EXPECT_GT(gap, 0.15);
  EXPECT_LT(gap, 0.35);
}

// The case of BENCHMARKS.md (K/G = 1.2e5) on an 8² section with the default (rotated) discretization:
// measured 74 Newton / 9 637 Krylov on 1 thread, 77 / 10 156 on 2 (16 shifted solves, ≈ 500 Krylov
// iterations in abandoned solves; 103 / 11 874–12 144 with the mixed iteration's line search measured
// against the accepted iterate's linearized merit instead of its true residual), P22 0.0521527 (32²:
// 0.0533, 128² at K/G = 1000: 0.0522 — the rotated scheme's limit, flat in n).
// Bounds: counts + 15 % (the thread count and float tangents move them by up to 10 %), P22 within 1 % of
// the measured value (the 8²–32² spread of the rotated answer is 2 %). The FE reference (L/4, 0.09046;
// L/24: 0.08847) is 40 % higher: asserted as a band, as above, so that a change of the discretization
// shows here.
TEST(FftRveTransverse, EcoflexCostAndAnswerOnASmallCell) {
  const RveRunResult r = fft_run(1.2e5, 8, fft::Discretization::rotated);
  ASSERT_TRUE(r.completed) << r.error;
  print("FFT rotated 8²", r);
  EXPECT_LE(r.newton_iterations, 89);
  EXPECT_LE(r.krylov_iterations, 11680);
  EXPECT_LE(r.discarded_krylov_iterations, r.krylov_iterations);
  EXPECT_NEAR(r.steps.back().P(1, 1), 0.0521527, 0.01 * 0.0521527);
  EXPECT_NEAR(r.steps.back().P(0, 0), 0.0, 1e-8);

  const RveRunResult fe = fe_run(1.2e5, 4);
  ASSERT_TRUE(fe.completed) << fe.error;
  print("FE L/4", fe);
  EXPECT_NEAR(fe.steps.back().P(1, 1), 0.08847, 0.03 * 0.08847);  // L/4 is 2.3 % above the L/24 value
  const double gap = 1.0 - r.steps.back().P(1, 1) / fe.steps.back().P(1, 1);
  EXPECT_GT(gap, 0.3);
  EXPECT_LT(gap, 0.5);
}

// The mean-dilatation hex variant ([solver] volumetric = "mean-dilatation", one volume ratio per voxel)
// converges to the FE answer where rotated does not and pointwise hex locks.
// K/G = 100: P22 0.075765 (32²), 0.070882 (64²), 0.068341 (128²), first order; the Richardson value of
// 32²/64², 0.065999, is 0.26 % below the FE L/24 value 0.066170 (64²/128²: 0.06580, 0.56 % below).
// Tolerance 1 % as for pointwise hex above (the O(h²) remainder of the extrapolation).
// K/G = 1.2e5 (the BENCHMARKS case): 0.14037 (16²), 0.10683 (32²), 0.097824 (64²), approaching the FE
// 0.088469 from above (32²/64² Richardson 0.08881, +0.4 %); pointwise hex gives 0.584 at 32² (locked),
// rotated 0.0533 (40 % below). Asserted at 32²: 10–30 % above the FE value (measured +20.8 %, the
// first-order discretization error at this grid), and the Newton iterations of the voxel's mixed
// (u, p) iteration (MeanDilatationVoxelPressure... below): measured 74 on 2 threads, the same P22 to 7
// digits (the plain iteration took 228–298, the preconditioner's round-off deciding its line-search
// cut-backs); bound: 86 (+15 %). The K/G = 100 pair runs in two load steps (the same P22 to 7 digits,
// 618 and 623 Krylov iterations against 1 577 and 1 363); the ecoflex run keeps the eight steps its
// Newton count was measured with (in four it takes 146 with two cut-backs).
TEST(FftRveTransverse, MeanDilatationHexConvergesToTheFeReference) {
  const double fe_100 = 0.066170, fe_ecoflex = 0.0884690;  // FE L/24 (HexConvergesToTheFeReference..., BENCHMARKS)
  const auto mean_dilatation = [](double k_over_g, int n, int steps) {
    return fft_run(k_over_g, n, fft::Discretization::hex, VolumetricKinematics::mean_dilatation, true, steps);
  };
  const RveRunResult m32 = mean_dilatation(100.0, 32, 2), m64 = mean_dilatation(100.0, 64, 2);
  ASSERT_TRUE(m32.completed && m64.completed) << m32.error << m64.error;
  print("FFT hex mean-dilatation 32², K/G 100", m32);
  print("FFT hex mean-dilatation 64², K/G 100", m64);
  const double richardson = 2.0 * m64.steps.back().P(1, 1) - m32.steps.back().P(1, 1);
  EXPECT_NEAR(richardson, fe_100, 0.01 * fe_100);
  EXPECT_EQ(m32.shifted_solves + m64.shifted_solves, 0);  // measured 0 (no negative curvature)

  const RveRunResult e32 = mean_dilatation(1.2e5, 32, 8);
  ASSERT_TRUE(e32.completed) << e32.error;
  print("FFT hex mean-dilatation 32², K/G 1.2e5", e32);
  const double excess = e32.steps.back().P(1, 1) / fe_ecoflex - 1.0;
  EXPECT_GT(excess, 0.10);
  EXPECT_LT(excess, 0.30);
  EXPECT_NEAR(e32.steps.back().P(0, 0), 0.0, 1e-8);
  EXPECT_LE(e32.newton_iterations, 86);
}

// The mixed (u, p) iteration of the mean-dilatation variant: one pressure per voxel, carried linearized
// in J̄ between Newton iterations, so the geometric term of a spike in the voxel's volume ratio no longer
// makes its tangent indefinite. The converged state is the plain iteration's (the same discrete energy;
// tolerance 1e-6 on the residual: P22 and F11 agree to 1e-7 relative, 2e-6 asserted). Measured on the
// ecoflex cell at 8²: 75 Newton / 11 290 Krylov against the plain 278 / 56 851 (3 cut-backs) on 1
// thread, 76 / 11 300 against 222 / 44 343 on 2 (the preconditioner's round-off decides the plain
// iteration's cut-backs), P22 0.161981 in all; bound: 88 Newton (+15 %), fewer than the plain
// iteration's, and fewer than half its Krylov iterations.
TEST(FftRveTransverse, MeanDilatationVoxelPressureSameAnswerFewerNewtonSteps) {
  const RveRunResult mixed = fft_run(1.2e5, 8, fft::Discretization::hex, VolumetricKinematics::mean_dilatation);
  const RveRunResult plain = fft_run(1.2e5, 8, fft::Discretization::hex, VolumetricKinematics::mean_dilatation, false);
  ASSERT_TRUE(mixed.completed && plain.completed) << mixed.error << plain.error;
  print("FFT hex mean-dilatation 8², K/G 1.2e5, voxel pressure", mixed);
  print("FFT hex mean-dilatation 8², K/G 1.2e5, plain", plain);
  EXPECT_NEAR(mixed.steps.back().P(1, 1), plain.steps.back().P(1, 1), 2e-6 * plain.steps.back().P(1, 1));
  EXPECT_NEAR(mixed.steps.back().F(0, 0), plain.steps.back().F(0, 0), 2e-6);
  EXPECT_LE(mixed.newton_iterations, 88);
  EXPECT_LT(mixed.newton_iterations, plain.newton_iterations);
  EXPECT_LT(2 * mixed.krylov_iterations, plain.krylov_iterations);
}
