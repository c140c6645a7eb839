// FE RVE engine on conforming T6 section meshes: homogeneous cell = material point, rank-one laminate
// = its exact solution (both with and without the mixed pressure), mesh convergence of the
// homogenized stress at λ = 1.5, and agreement with the FFT engine on a chapter-IV PDMS cell.
#include <gtest/gtest.h>

#include <cmath>

#include <Eigen/Dense>

#include "rve/rve_test_helpers.hpp"
#include "softhom/materials/driver.hpp"
#include "softhom/materials/laws.hpp"
#include "softhom/materials/library.hpp"
#include "softhom/rve/fe_solver.hpp"
#include "softhom/rve/fft_solver.hpp"

using namespace softhom;
using namespace softhom::rve;
using softhom::rve::testing::full_deformation;
using softhom::rve::testing::uniaxial_ramp;
using softhom::rve::testing::preset;
using softhom::rve::testing::rel;
using softhom::rve::testing::neo_hookean;

namespace {

Section circle_cell(double vf = 0.23) {
  FiberCellSpec s;
  s.shape = SectionShape::circle;
  s.radius = 0.2;
  s.volume_fraction = vf;
  return generate_section(s);
}

SectionMesh mesh_of(const Section& s, double mesh_size, double interface_size) {
  SectionMeshOptions o;
  o.mesh_size = mesh_size;
  o.interface_size = interface_size;
  return mesh_section(s, o);
}

}  // namespace

// Both phases the same nearly incompressible Gent law (ecoflex, K/G = 1.2e5: the mixed P2/P0 path),
// curved interface elements, α = 30° so that the grid and load frames differ: the fluctuation is
// exactly zero and the macro Newton solves the material point's mixed control. Tolerance 1e-8: both
// solvers converge to ≤ 1e-10 relative stress residual (or the round-off floor ~eps K / |P|).
TEST(FeRve, HomogeneousCellEqualsMaterialPoint) {
  const Section s = circle_cell();
  const MaterialPtr m = preset("ecoflex");
  const MixedControl control = uniaxial_ramp(3.0, 8);
  const PointRunResult point = run_material_point(*m, control);
  ASSERT_TRUE(point.completed) << point.error;
  FeSolverOptions o;
  o.tolerance = 1e-10;
  FeRveSolver solver(mesh_of(s, s.L1 / 5, s.L1 / 10), m, m, 30.0, control.frame, o);
  const RveRunResult r = solver.run(control);
  ASSERT_TRUE(r.completed) << r.error;
  softhom::rve::testing::expect_steps_match_point(r, point, 1e-8);
  for (std::size_t k = 1; k < r.steps.size(); ++k) {
    EXPECT_LT(rel(r.steps[k].sigma, point.steps[k].sigma), 1e-8) << "step " << k;
    EXPECT_LT(rel(r.steps[k].P_fiber, point.steps[k].P), 1e-8);  // phase means of a uniform field
  }
  EXPECT_EQ(r.cutbacks, 0);
}

// Rank-one laminate of two neo-Hookean layers (normal y1) under a general prescribed F̄: the exact
// solution is piecewise homogeneous, F_a = F̄ + (1−φ) a⊗n, F_b = F̄ − φ a⊗n with (P_a − P_b) n = 0
// (solved by Newton to machine precision). T6 elements (and the P1 / P0 pressure) represent it exactly,
// so the homogenized P must match to the solver tolerance: 1e-10 → 1e-8 relative. Second case: a
// nearly incompressible soft layer (K/G = 1.2e5, mixed pressure path).
TEST(FeRve, RankOneLaminateMatchesExactSolution) {
  Mat3 F_load;
  F_load << 1.3, 0.15, 0.05, -0.1, 0.85, 0.1, 0.04, -0.06, 1.1;
  for (int variant = 0; variant < 2; ++variant) {
    const MaterialPtr stiff = neo_hookean(2.0, 10.0);
    const MaterialPtr soft = variant == 0 ? neo_hookean(0.1, 1.0) : neo_hookean(0.017, 2000.0);
    // Fiber layer 0.1 < y1 < 0.5 spanning the full height of a 1 × 0.5 cell.
    Section s;
    s.L1 = 1.0;
    s.L2 = 0.5;
    FiberSection f;
    f.shape = SectionShape::rectangle;
    f.center = Eigen::Vector2d(0.3, 0.25);
    f.width = 0.4;
    f.height = 0.5;
    s.fibers.push_back(f);
    const double phi = 0.4;
    const double alpha = 0.0;
    const Mat3 R = grid_rotation(alpha);
    const Mat3 Fg = R.transpose() * F_load * R;
    const Vec3 n = Vec3::UnitX();  // grid frame
    Vec3 a = Vec3::Zero();
    Mat3 Pa, Pb;
    for (int it = 0; it < 60; ++it) {
      Mat9 Aa, Ab;
      const Mat3 Fa = Fg + (1 - phi) * a * n.transpose(), Fb = Fg - phi * a * n.transpose();
      ASSERT_EQ(stiff->evaluate(Fa, nullptr, nullptr, 0.0, Pa, &Aa), MaterialStatus::ok);
      ASSERT_EQ(soft->evaluate(Fb, nullptr, nullptr, 0.0, Pb, &Ab), MaterialStatus::ok);
      const Vec3 r = (Pa - Pb) * n;
      if (r.norm() < 1e-15) break;
      Mat3 Q;
      for (int i = 0; i < 3; ++i)
        for (int k = 0; k < 3; ++k) Q(i, k) = (1 - phi) * Aa(3 * i, 3 * k) + phi * Ab(3 * i, 3 * k);
      a -= Q.inverse() * r;
    }
    const Mat3 P_exact = R * (phi * Pa + (1 - phi) * Pb) * R.transpose();
    SectionMesh mesh = mesh_of(s, 0.2, 0.1);
    EXPECT_NEAR(mesh.area(1), phi * 0.5, 1e-14);
    FeSolverOptions o;
    o.tolerance = 1e-10;
    FeRveSolver solver(std::move(mesh), soft, stiff, alpha, Mat3::Identity(), o);
    const RveRunResult r = solver.run(full_deformation(F_load, 4));
    ASSERT_TRUE(r.completed) << r.error;
    EXPECT_LT(rel(r.steps.back().P, P_exact), 1e-8) << "variant " << variant;
    EXPECT_LT(rel(r.steps.back().P_fiber, R * Pa * R.transpose()), 1e-8) << "variant " << variant;
    EXPECT_LT(rel(r.steps.back().P_matrix, R * Pb * R.transpose()), 1e-8) << "variant " << variant;
  }
}

// Mesh refinement for the circular-fiber cell (PDMS matrix K/G = 3077, glass fibers, VF 0.23,
// α = 45°, uniaxial tension to λ = 1.5). Three quasi-uniform meshes, h = L/4, L/8, L/16 (not nested:
// CGAL meshes each size independently), observed order p = log(Δ₁/Δ₂) / log(h₁/h₂).
//  - P2+bubble / P1 (default): O(h²) in the energy norm, so the homogenized stress (an energy
//    derivative) at up to O(h⁴); measured 3.3–3.4 (L/4 … L/32). Required: p > 2.5 and a
//    Richardson-extrapolated error of the finest mesh below 1e-5.
//  - P2/P0: O(h) in the energy norm, stress O(h²) asymptotically; measured 1.2–1.7 on these meshes.
//    Required: p > 1.0 (a locking pressure or straight-sided interfaces would fail it).
// Both must extrapolate to the same limit within 2e-5 (relative). One load step: the P11 of all six
// runs, and so the observed orders (3.29, 1.69), are those of two steps to 8 digits.
TEST(FeRve, MeshRefinementConvergesAtTheExpectedOrder) {
  const Section s = circle_cell();
  const MaterialPtr matrix = preset("pdms"), glass = preset("glass");
  const MixedControl control = uniaxial_ramp(1.5, 1);
  double limit[2];
  for (FePressure pressure : {FePressure::p1_bubble, FePressure::p0}) {
    std::vector<double> h, p;
    for (double div : {4.0, 8.0, 16.0}) {
      SectionMesh mesh = mesh_of(s, s.L1 / div, s.L1 / div);
      h.push_back(std::sqrt(s.L1 * s.L2 / mesh.num_elements()));
      FeSolverOptions o;
      o.pressure = pressure;
      FeRveSolver solver(std::move(mesh), matrix, glass, 45.0, control.frame, o);
      const RveRunResult r = solver.run(control);
      ASSERT_TRUE(r.completed) << r.error;
      p.push_back(r.steps.back().P(0, 0));
    }
    const double order = std::log(std::abs(p[1] - p[0]) / std::abs(p[2] - p[1])) / std::log(h[1] / h[2]);
    const double p_inf = p[2] + (p[2] - p[1]) / (std::pow(h[1] / h[2], order) - 1.0);
    std::printf("FE %s refinement: P11 = %.8f %.8f %.8f (h = %.4f %.4f %.4f), order %.2f, extrapolated %.8f\n",
                to_string(pressure), p[0], p[1], p[2], h[0], h[1], h[2], order, p_inf);
    const bool p1 = pressure == FePressure::p1_bubble;
    EXPECT_GT(order, p1 ? 2.5 : 1.0);
    EXPECT_LT(order, p1 ? 5.0 : 3.5);
    EXPECT_LT(std::abs(p[2] - p_inf) / p_inf, p1 ? 1e-5 : 1e-3);
    limit[p1 ? 0 : 1] = p_inf;
  }
  EXPECT_NEAR(limit[1] / limit[0], 1.0, 2e-5);
}

// FE vs FFT on the chapter-IV PDMS cell (circle, VF 0.23, α = 45°, λ = 1.3): the FFT engine's
// homogenized stress approaches the FE reference as its grid is refined, and at 32² it is within
// 0.1 % (measured: 16² 8.7e-4, 64² 2.9e-4; the FE reference itself is within ~1e-4 of its limit).
TEST(FeRve, AgreesWithFftEngineOnPdmsCell) {
  const Section s = circle_cell();
  const MaterialPtr matrix = preset("pdms"), glass = preset("glass");
  const MixedControl control = uniaxial_ramp(1.3, 2);
  FeRveSolver fe(mesh_of(s, s.L1 / 12, s.L1 / 36), matrix, glass, 45.0, control.frame);
  const RveRunResult ref = fe.run(control);
  ASSERT_TRUE(ref.completed) << ref.error;
  const Mat3 P_fe = ref.steps.back().P;
  std::vector<double> err;
  for (int n : {16, 32}) {
    FftSolverOptions o;
    o.tolerance = 1e-8;
    o.plan.rigor = fft::PlanRigor::estimate;
    FftRveSolver fft(voxelize_section(s, n, n), matrix, glass, 45.0, control.frame, o);
    const RveRunResult r = fft.run(control);
    ASSERT_TRUE(r.completed) << r.error;
    err.push_back(std::abs(r.steps.back().P(0, 0) - P_fe(0, 0)) / P_fe(0, 0));
    std::printf("FFT %d^2 vs FE: P11 %.6f vs %.6f, rel. difference %.2e\n", n, r.steps.back().P(0, 0), P_fe(0, 0),
                err.back());
  }
  EXPECT_LT(err[1], err[0]);
  EXPECT_LT(err[1], 1e-3);
}

// Viscoelastic (QLV) matrix: history per quadrature point, committed only on convergence. A
// homogeneous QLV cell under ramp (λ = 1.5 in 1 s) and hold (to 3 s, τ = 0.5 s) equals the material
// point with the same time steps; the stress relaxes toward the g∞ = 0.5 level during the hold.
TEST(FeRve, ViscoelasticHomogeneousCellEqualsMaterialPoint) {
  GentHGOParams gp{0.65, 5.0, 2000.0, {}, FiberInvariant::full, true};
  const MaterialPtr m = make_material(make_gent_hgo(gp), PronySeries{0.5, {{0.5, 0.5}}});
  MixedControl control = uniaxial_control(PiecewiseLinear{{0.0, 1.0, 3.0}, {1.0, 1.5, 1.5}});
  control.times.clear();
  for (int k = 1; k <= 12; ++k) control.times.push_back(0.25 * k);
  const PointRunResult point = run_material_point(*m, control);
  ASSERT_TRUE(point.completed) << point.error;
  const Section s = circle_cell();
  FeSolverOptions o;
  o.tolerance = 1e-10;
  FeRveSolver solver(mesh_of(s, s.L1 / 4, s.L1 / 8), m, m, 45.0, control.frame, o);
  const RveRunResult r = solver.run(control);
  ASSERT_TRUE(r.completed) << r.error;
  ASSERT_EQ(r.steps.size(), point.steps.size());
  for (std::size_t k = 1; k < r.steps.size(); ++k) EXPECT_LT(rel(r.steps[k].P, point.steps[k].P), 1e-8) << "step " << k;
  EXPECT_LT(r.steps.back().P(0, 0), 0.8 * r.steps[4].P(0, 0));  // relaxed during the hold
}

// No locking at K/G = 1.2e5 (ecoflex + glass, λ = 1.3, α = 45°): the P2+bubble/P1 element on a
// coarse mesh (h = L/4) and the P2/P0 element on a finer one (L/8) agree on the lateral contraction
// F22 and on P11 within 0.3 % (measured 0.1 %; the L/16 P1 solution is 0.81662 / 0.032835). The
// plain displacement P2 element on the L/4 mesh is 2.2 % off in F22 (and needs 96 Newton
// iterations), which is what a locking pressure treatment would show.
TEST(FeRve, NoLockingForNearlyIncompressibleMatrix) {
  const Section s = circle_cell();
  const MaterialPtr matrix = preset("ecoflex"), glass = preset("glass");
  const MixedControl control = uniaxial_ramp(1.3, 3);
  Mat3 F[2], P[2];
  for (int k = 0; k < 2; ++k) {
    FeSolverOptions o;
    o.pressure = k == 0 ? FePressure::p1_bubble : FePressure::p0;
    const double div = k == 0 ? 4.0 : 8.0;
    FeRveSolver solver(mesh_of(s, s.L1 / div, s.L1 / div), matrix, glass, 45.0, control.frame, o);
    const RveRunResult r = solver.run(control);
    ASSERT_TRUE(r.completed) << r.error;
    EXPECT_EQ(r.cutbacks, 0);
    F[k] = r.steps.back().F;
    P[k] = r.steps.back().P;
  }
  EXPECT_NEAR(F[0](1, 1) / F[1](1, 1), 1.0, 3e-3);
  EXPECT_NEAR(P[0](0, 0) / P[1](0, 0), 1.0, 3e-3);
  EXPECT_NEAR(F[0](1, 1), 0.81662, 0.003 * 0.81662);
}

// Ecoflex FFT–FE difference: on the ecoflex + glass cell (shear contrast 226) the FFT engine
// is 1.2e-3 off the FE engine at 32² and still 1.1e-3 at 64². That difference is the FFT engine's
// composite-voxel discretization error, not an incompressibility effect of either engine: with the
// matrix bulk modulus lowered from K/G = 1.2e5 to 100 (same G) the gap at 32² is the same (measured
// 1.24e-3 and 1.25e-3; required within 10 %), and at K/G = 100, where fine grids are cheap, it
// falls at first order with the grid (48² 1.40e-3, 96² 6.8e-4, 192² 3.5e-4, 384² 1.9e-4, 512² 1.5e-4;
// the 256²/512² Richardson limit is 1e-6 from the FE value). FE: P2+bubble/P1 at L/4, 6e-6 from its
// own limit. Required: the 96² gap below 0.6 × the 48² gap, both gaps positive (FFT stiffer). Two load
// steps: hyperelastic phases, so the end state is the eight-step runs' to the solver tolerances.
TEST(FeRve, EcoflexFftGapIsTheVoxelErrorNotIncompressibility) {
  const Section s = circle_cell();
  const MaterialPtr glass = preset("glass");
  MaterialSpec soft = preset_spec("ecoflex");
  soft.gent.K = 100.0 * soft.gent.G;
  const MaterialPtr ecoflex = preset("ecoflex"), ecoflex_kg100 = build_material(soft);
  const MixedControl control = uniaxial_ramp(1.5, 2);
  auto fe_p11 = [&](const MaterialPtr& m) {
    FeRveSolver fe(mesh_of(s, s.L1 / 4, s.L1 / 12), m, glass, 45.0, control.frame);
    const RveRunResult r = fe.run(control);
    EXPECT_TRUE(r.completed) << r.error;
    return r.steps.back().P(0, 0);
  };
  auto fft_p11 = [&](const MaterialPtr& m, int n) {
    FftSolverOptions o;
    o.tolerance = 1e-8;
    o.plan.rigor = fft::PlanRigor::estimate;
    FftRveSolver fft(voxelize_section(s, n, n), m, glass, 45.0, control.frame, o);
    const RveRunResult r = fft.run(control);
    EXPECT_TRUE(r.completed) << r.error;
    return r.steps.back().P(0, 0);
  };
  const double fe_hi = fe_p11(ecoflex), fe_lo = fe_p11(ecoflex_kg100);
  const double gap_hi = fft_p11(ecoflex, 32) / fe_hi - 1.0, gap_lo = fft_p11(ecoflex_kg100, 32) / fe_lo - 1.0;
  const double gap48 = fft_p11(ecoflex_kg100, 48) / fe_lo - 1.0, gap96 = fft_p11(ecoflex_kg100, 96) / fe_lo - 1.0;
  std::printf("FFT - FE at 32^2: K/G 1.2e5 %.3e, K/G 100 %.3e; K/G 100 at 48^2 %.3e, 96^2 %.3e\n", gap_hi, gap_lo,
              gap48, gap96);
  EXPECT_NEAR(gap_hi / gap_lo, 1.0, 0.1);
  EXPECT_GT(gap48, 0.0);
  EXPECT_GT(gap96, 0.0);
  EXPECT_LT(gap96, 0.6 * gap48);
}
