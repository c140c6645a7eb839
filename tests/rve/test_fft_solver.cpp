// FFT RVE solver verification: homogeneous cell = material point, rank-one laminate at finite strain,
// section = extruded 3D grid, Moulinec–Suquet = Newton–CG, viscoelastic matrix.
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cstdio>

#include <iostream>

#include <Eigen/Dense>

#include "rve/rve_test_helpers.hpp"
#include "softhom/materials/driver.hpp"
#include "softhom/materials/laws.hpp"
#include "softhom/rve/fft_solver.hpp"

using namespace softhom;
using namespace softhom::rve;
using softhom::rve::testing::circle_image;
using softhom::rve::testing::full_deformation;
using softhom::rve::testing::layer_image;
using softhom::rve::testing::uniaxial_ramp;
using softhom::rve::testing::rel;
using softhom::rve::testing::neo_hookean;
using softhom::rve::testing::ecoflex;
using softhom::rve::testing::glass;

namespace {

FftSolverOptions fast_options(fft::Discretization d, double tol = 1e-10) {
  FftSolverOptions o;
  o.discretization = d;
  o.tolerance = tol;
  o.plan.rigor = fft::PlanRigor::estimate;  // tests: planning time matters more than FFT speed
  return o;
}


/// One OpenMP thread while in scope (runs compared bit for bit: the sums over the points add in one order).
struct OneThread {
  int threads = omp_get_max_threads();
  OneThread() { omp_set_num_threads(1); }
  ~OneThread() { omp_set_num_threads(threads); }
};

}  // namespace

// A cell whose two phases are the same material (with composite voxels everywhere, so the laminate
// rule is exercised) must reproduce the material-point driver: the fluctuation is exactly zero and
// the macro Newton solves the same mixed control, here rotated by α = 30° into the grid frame.
// Tolerance 1e-8: both solvers converge to ≤ 1e-10 relative stress residual.
TEST(FftRve, HomogeneousCellEqualsMaterialPoint) {
  PhaseImage im = circle_image(8, 0.3);
  const MaterialPtr m = ecoflex();
  const MixedControl control = uniaxial_ramp(3.0, 8);
  PointSolverOptions po;
  po.tolerance = 1e-10;  // its default; tighter stalls at round-off (K/G = 1.2e5)
  const PointRunResult point = run_material_point(*m, control, po);
  ASSERT_TRUE(point.completed) << point.error;
  for (auto d : {fft::Discretization::spectral, fft::Discretization::rotated, fft::Discretization::hex}) {
    FftRveSolver solver(im, m, m, 30.0, control.frame, fast_options(d, 1e-11));
    const RveRunResult r = solver.run(control);
    ASSERT_TRUE(r.completed) << r.error;
    ASSERT_EQ(r.steps.size(), point.steps.size());
    for (std::size_t s = 1; s < r.steps.size(); ++s) {
      EXPECT_LT(rel(r.steps[s].P, point.steps[s].P), 1e-8) << fft::to_string(d) << " step " << s;
      EXPECT_LT(rel(r.steps[s].F, point.steps[s].F), 1e-8) << fft::to_string(d) << " step " << s;
      EXPECT_LT(rel(r.steps[s].sigma, point.steps[s].sigma), 1e-8);
    }
  }
}

// Rank-one laminate of two neo-Hookean layers (normal y1, stiffness ratio 20) under a general
// prescribed F̄: the exact solution is piecewise homogeneous with F_a = F̄ + (1−φ) a⊗n,
// F_b = F̄ − φ a⊗n and (P_a − P_b) n = 0, solved here by Newton to machine precision. The FE-type
// gradients represent it exactly (also with a composite column using the laminate rule), so the
// homogenized P must match to the solver tolerance (1e-10 → 1e-8 relative allows round-off).
TEST(FftRve, RankOneLaminateMatchesSemiAnalytical) {
  const MaterialPtr stiff = neo_hookean(2.0, 10.0), soft = neo_hookean(0.1, 1.0);
  Mat3 F_end;
  F_end << 1.3, 0.15, 0.05, -0.1, 0.85, 0.1, 0.04, -0.06, 1.1;
  const Vec3 n = Vec3::UnitX();
  for (double phi_interface : {-1.0, 0.35}) {
    const int n1 = 10, nf = 4;
    const double phi = (nf + std::max(phi_interface, 0.0)) / n1;
    // Semi-analytical reference.
    Vec3 a = Vec3::Zero();
    Mat3 Pa, Pb, Pbar;
    for (int it = 0; it < 50; ++it) {
      Mat9 Aa, Ab;
      const Mat3 Fa = F_end + (1 - phi) * a * n.transpose(), Fb = F_end - phi * a * n.transpose();
      ASSERT_EQ(stiff->evaluate(Fa, nullptr, nullptr, 0, Pa, &Aa), MaterialStatus::ok);
      ASSERT_EQ(soft->evaluate(Fb, nullptr, nullptr, 0, Pb, &Ab), MaterialStatus::ok);
      const Vec3 r = (Pa - Pb) * n;
      if (r.norm() < 1e-15) break;
      Eigen::Matrix3d Q;
      for (int i = 0; i < 3; ++i)
        for (int k = 0; k < 3; ++k) Q(i, k) = ((1 - phi) * Aa(3 * i, 3 * k) + phi * Ab(3 * i, 3 * k));
      a -= Q.inverse() * r;
    }
    Pbar = phi * Pa + (1 - phi) * Pb;
    const PhaseImage im = layer_image(n1, 3, nf, phi_interface);
    // Grid rotated (α = 0 → R maps grid y1 to load e1 up to the fixed −e3 / e2 swap): give F̄ in the load frame.
    for (auto d : {fft::Discretization::rotated, fft::Discretization::hex}) {
      FftRveSolver solver(im, soft, stiff, 0.0, Mat3::Identity(), fast_options(d));
      const Mat3 R = grid_rotation(0.0);
      const MixedControl control = full_deformation(R * F_end * R.transpose(), 4);
      const RveRunResult r = solver.run(control);
      ASSERT_TRUE(r.completed) << r.error;
      const Mat3 P_grid = R.transpose() * r.steps.back().P * R;
      EXPECT_LT(rel(P_grid, Pbar), 1e-8) << fft::to_string(d) << " phi_interface " << phi_interface;
    }
    // Spectral: Gibbs oscillations, but the homogenized stress is still within a few per cent.
    FftRveSolver spectral(im, soft, stiff, 0.0, Mat3::Identity(), fast_options(fft::Discretization::spectral, 1e-8));
    const Mat3 R = grid_rotation(0.0);
    const RveRunResult rs = spectral.run(full_deformation(R * F_end * R.transpose(), 4));
    ASSERT_TRUE(rs.completed) << rs.error;
    EXPECT_LT(rel(R.transpose() * rs.steps.back().P * R, Pbar), 0.05);
  }
}

// Straight fibers: the 2D section grid with full 3D kinematics equals the 3D grid of the extruded
// section (the FE gradients of a y3-independent field coincide). Tolerance: solver tolerance 1e-10.
TEST(FftRve, SectionEqualsExtruded3D) {
  const PhaseImage section = circle_image(12, 0.27);
  PhaseImage cube = section;
  const int n3 = 3;
  cube.n[2] = n3;
  cube.size[2] = n3 * section.size[2];
  cube.fiber_fraction.clear();
  cube.normal.clear();
  for (int k = 0; k < n3; ++k) {
    cube.fiber_fraction.insert(cube.fiber_fraction.end(), section.fiber_fraction.begin(), section.fiber_fraction.end());
    cube.normal.insert(cube.normal.end(), section.normal.begin(), section.normal.end());
  }
  const MixedControl control = uniaxial_ramp(1.3, 2);
  for (auto d : {fft::Discretization::rotated, fft::Discretization::hex, fft::Discretization::spectral}) {
    // Compressible matrix (K/G = 10) keeps this check fast; ecoflex is covered by the scenes.
    FftRveSolver s2(section, neo_hookean(0.1, 1.0), glass(), 45.0, control.frame, fast_options(d));
    FftRveSolver s3(cube, neo_hookean(0.1, 1.0), glass(), 45.0, control.frame, fast_options(d));
    const RveRunResult r2 = s2.run(control), r3 = s3.run(control);
    ASSERT_TRUE(r2.completed && r3.completed) << r2.error << r3.error;
    EXPECT_LT(rel(r2.steps.back().P, r3.steps.back().P), 1e-8) << fft::to_string(d);
    EXPECT_GT(r2.steps.back().P(0, 0), 0.0);
  }
}

// The Moulinec–Suquet baseline and Newton–CG solve the same discrete problem (low contrast, so the
// fixed point converges quickly): equal homogenized stress within the tolerances (1e-7).
TEST(FftRve, MoulinecSuquetAgreesWithNewton) {
  const PhaseImage im = circle_image(16, 0.3);
  const MixedControl control = uniaxial_ramp(1.2, 2);
  const MaterialPtr m = neo_hookean(1.0, 5.0), f = neo_hookean(5.0, 20.0);
  FftSolverOptions o = fast_options(fft::Discretization::spectral, 1e-9);
  FftRveSolver newton(im, m, f, 20.0, control.frame, o);
  o.scheme = FftScheme::moulinec_suquet;
  FftRveSolver ms(im, m, f, 20.0, control.frame, o);
  const RveRunResult rn = newton.run(control), rm = ms.run(control);
  ASSERT_TRUE(rn.completed && rm.completed) << rn.error << rm.error;
  EXPECT_LT(rel(rm.steps.back().P, rn.steps.back().P), 1e-6);
}

// The mixed (pressure) Newton iteration changes the path, not the discrete problem: on an ecoflex
// (K/G = 1.2e5) + glass cell both iterations converge to the same homogenized stress (1e-6: both
// stop at a relative residual of 1e-8, and the stress error is bounded by a modest multiple of it),
// and the mixed one needs fewer Newton iterations (the plain one loses its steps to the K θ² pressure
// of finite rotations; measured 2x or more on this cell).
TEST(FftRve, MixedPressureIterationSameSolutionFewerNewtonSteps) {
  const PhaseImage im = circle_image(12, 0.27);
  const MixedControl control = uniaxial_ramp(1.2, 2);
  FftSolverOptions o = fast_options(fft::Discretization::rotated, 1e-8);
  FftRveSolver mixed(im, ecoflex(), glass(), 45.0, control.frame, o);
  o.mixed_pressure = false;
  FftRveSolver plain(im, ecoflex(), glass(), 45.0, control.frame, o);
  const RveRunResult rm = mixed.run(control), rp = plain.run(control);
  ASSERT_TRUE(rm.completed && rp.completed) << rm.error << rp.error;
  EXPECT_LT(rel(rm.steps.back().P, rp.steps.back().P), 1e-6);
  EXPECT_LT(rm.newton_iterations, rp.newton_iterations);
  EXPECT_GT(rm.steps.back().P(0, 0), 0.0);
  std::cout << "[ mixed ] Newton " << rm.newton_iterations << " (plain " << rp.newton_iterations
            << "), Krylov " << rm.krylov_iterations << " (plain " << rp.krylov_iterations
            << "), cut-backs " << rm.cutbacks << " (plain " << rp.cutbacks << ")\n";
}

// The mixed iteration keeps one linearization of the pressure per point, which every line-search trial
// overwrites (a material failure: part of it); the last accepted iterate's is recomputed before a trial
// that follows a rejected one. Reference: the same run recomputing it before every trial, which gives the
// same iterates bit for bit if the recomputation is what the accepted evaluation stored and no needed
// restore is missed (evaluating a trial with a rejected trial's linearization converges to the same
// stress by another path). On a cell whose large steps make the line search backtrack and the steps cut
// back after material failures, with the slopes recomputed from the compact records and stored; both
// converge to the same stress (1e-6, as in MixedPressureIterationSameSolutionFewerNewtonSteps).
TEST(FftRve, MixedPressureRestoresTheLinearizationAfterRejectedTrials) {
  // Bit for bit: one thread, so that the sums over the points add in one order in both runs.
  const OneThread one_thread;
  const PhaseImage im = circle_image(12, 0.27);
  const MixedControl control = uniaxial_ramp(1.5, 2);
  Mat3 P_compact = Mat3::Zero();
  for (const bool compact : {true, false}) {
    FftSolverOptions o = fast_options(fft::Discretization::rotated, 1e-8);
    o.compact_tangent = compact;
    FftRveSolver one(im, ecoflex(), glass(), 45.0, control.frame, o);
    o.relinearize_every_trial = true;
    FftRveSolver reference(im, ecoflex(), glass(), 45.0, control.frame, o);
    const RveRunResult r = one.run(control), ref = reference.run(control);
    ASSERT_TRUE(r.completed && ref.completed) << r.error << ref.error;
    EXPECT_GT(r.cutbacks, 0) << "compact " << compact;
    EXPECT_EQ(r.newton_iterations, ref.newton_iterations) << "compact " << compact;
    EXPECT_EQ(r.krylov_iterations, ref.krylov_iterations) << "compact " << compact;
    EXPECT_EQ(r.cutbacks, ref.cutbacks) << "compact " << compact;
    EXPECT_EQ(rel(r.steps.back().P, ref.steps.back().P), 0.0) << "compact " << compact;
    if (compact) P_compact = r.steps.back().P;
    else EXPECT_LT(rel(P_compact, r.steps.back().P), 1e-6);
    std::cout << "[ mixed ] " << (compact ? "recomputed" : "stored") << " slopes: Newton " << r.newton_iterations
              << ", Krylov " << r.krylov_iterations << ", cut-backs " << r.cutbacks << "\n";
  }
}

// Small-strain limit, square array of circular fibers: longitudinal (antiplane) shear. With u3(y1, y2)
// the problem is the 2D conductivity problem with μ as conductivity, for which Rayleigh's method gives
// the published formula of Perrins, McKenzie & McPhedran (Proc. R. Soc. A 369, 1979) for the square
// array (T = (1 + c)/(1 − c), c = μf/μm):
//   μL/μm = 1 − 2f / (T + f − 0.305827 f⁴ T / (T² − 1.402958 f⁸) − 0.013362 f⁸),
// accurate to far better than 0.1 % at f = 0.4. The FFT result (64², rotated, composite voxels) must
// lie inside the 2D Hashin–Shtrikman bounds and within 1 % of that value; shear strain 1e-4
// keeps the finite-strain response linear to ~1e-4.
TEST(FftRve, SmallStrainLongitudinalShearMatchesRayleighSquareArray) {
  const double f = 0.4, mu_m = 1.0, mu_f = 10.0, gamma = 1e-4;
  const PhaseImage im = circle_image(64, std::sqrt(f / 3.14159265358979323846), 8);
  const double alpha = 30.0;
  const Mat3 R = grid_rotation(alpha);
  Mat3 F_grid = Mat3::Identity();
  F_grid(2, 0) = gamma;  // u3 = γ y1: antiplane shear along the fiber axis y3
  const MixedControl control = full_deformation(R * F_grid * R.transpose(), 1);
  FftRveSolver solver(im, neo_hookean(mu_m, 3.0 * mu_m), neo_hookean(mu_f, 3.0 * mu_f), alpha, control.frame,
                      fast_options(fft::Discretization::rotated, 1e-9));
  const RveRunResult r = solver.run(control);
  ASSERT_TRUE(r.completed) << r.error;
  const Mat3 P_grid = R.transpose() * r.steps.back().P * R;
  const double mu_fft = P_grid(2, 0) / gamma;
  const double c = mu_f / mu_m, T = (1.0 + c) / (1.0 - c), f4 = std::pow(f, 4), f8 = f4 * f4;
  const double mu_rayleigh = mu_m * (1.0 - 2.0 * f / (T + f - 0.305827 * f4 * T / (T * T - 1.402958 * f8) - 0.013362 * f8));
  const double hs_lower = mu_m + f / (1.0 / (mu_f - mu_m) + (1.0 - f) / (2.0 * mu_m));
  const double hs_upper = mu_f + (1.0 - f) / (1.0 / (mu_m - mu_f) + f / (2.0 * mu_f));
  std::cout << "[ antiplane ] muL: FFT " << mu_fft << ", Rayleigh/Perrins " << mu_rayleigh << ", HS [" << hs_lower
            << ", " << hs_upper << "], achieved VF " << solver.achieved_volume_fraction() << "\n";
  EXPECT_GT(mu_fft, hs_lower);
  EXPECT_LT(mu_fft, hs_upper);
  EXPECT_NEAR(mu_fft / mu_rayleigh, 1.0, 0.01);
}

// The real-space stencil Krylov operator (default for rotated/hex) and the Fourier-space one solve
// the same linear systems (equal to round-off, tests/fft StencilGradient.*), so the converged runs agree
// to the solver tolerance (1e-10 → 1e-8 on P) with the same Newton counts up to one (the inexact CG
// solves see different round-off; on the ecoflex section only to within a factor), a section with the nearly incompressible ecoflex matrix (mixed (u, p)
// iteration, composite voxels) and a small 3D cell, rotated and hex.
TEST(FftRve, StencilKrylovOperatorMatchesFourier) {
  const PhaseImage section = circle_image(12, 0.27);
  PhaseImage cube = section;
  cube.n[2] = 2;
  cube.size[2] = 2 * section.size[2];
  cube.fiber_fraction.insert(cube.fiber_fraction.end(), section.fiber_fraction.begin(), section.fiber_fraction.end());
  cube.normal.insert(cube.normal.end(), section.normal.begin(), section.normal.end());
  const MixedControl control = uniaxial_ramp(1.3, 2);
  for (auto d : {fft::Discretization::rotated, fft::Discretization::hex})
    for (int dim : {2, 3}) {
      const PhaseImage& im = dim == 2 ? section : cube;
      const MaterialPtr m = dim == 2 ? ecoflex() : neo_hookean(0.1, 1.0);
      FftSolverOptions os = fast_options(d), of = fast_options(d);
      of.krylov_operator = KrylovOperator::fourier;
      FftRveSolver s(im, m, glass(), 45.0, control.frame, os), f(im, m, glass(), 45.0, control.frame, of);
      const RveRunResult rs = s.run(control), rf = f.run(control);
      ASSERT_TRUE(rs.completed && rf.completed) << rs.error << rf.error;
      EXPECT_LT(rel(rs.steps.back().P, rf.steps.back().P), 1e-8) << fft::to_string(d) << " " << dim << "D";
      // Ecoflex (K/G = 1.2e5): the Newton path amplifies round-off (the same run with another FFTW plan
      // varies by a few per cent), so only the count's order is checked there.
      const int dn = std::abs(rs.newton_iterations - rf.newton_iterations);
      if (dim == 3)
        EXPECT_LE(dn, 1) << fft::to_string(d);
      else
        EXPECT_LE(dn, rf.newton_iterations / 2) << fft::to_string(d);
      std::printf("[ info     ] %s %dD Newton/Krylov stencil %d/%d fourier %d/%d, P11 %.12g %.12g\n", fft::to_string(d), dim,
                  rs.newton_iterations, rs.krylov_iterations, rf.newton_iterations,
                  rf.krylov_iterations, rs.steps.back().P(0, 0), rf.steps.back().P(0, 0));
      EXPECT_GT(rs.steps.back().P(0, 0), 0.0);
    }
}

// Uniaxial compression of the ecoflex + glass cell (circle, VF 0.23, α = 60°) to λ = 0.6 passes a
// bifurcation near λ ≈ 0.64 (fiber micro-buckling): there the tangent at the equilibrium is indefinite
// and CG meets negative curvature next to the solution. With MINRES the Newton iteration converges on
// the principal branch without cut-backs (16² scene: 145 Newton, no cut-back, measured; the shifted
// iteration needs 490 Newton and 7 cut-backs, and at 32² it stalls for good). On the principal branch
// the out-of-plane shears stay at the level of the image's asymmetry (2.2e-4 measured here), far below
// the buckled branch the shifted iteration drifts to (F31 → −0.17 at λ = 0.6): bound 1e-3. The steps
// past the bifurcation are logged as unstable.
TEST(FftRve, CompressionPastMicroBucklingConvergesOnPrincipalBranchWithMinres) {
  const PhaseImage im = circle_image(16, std::sqrt(0.23 / 3.14159265358979323846));
  const MixedControl control = uniaxial_ramp(0.6, 16);
  FftSolverOptions o = fast_options(fft::Discretization::rotated, 1e-6);
  ASSERT_EQ(o.indefinite_solver, IndefiniteSolver::minres);  // the default
  FftRveSolver solver(im, ecoflex(), glass(), 60.0, control.frame, o);
  const RveRunResult r = solver.run(control);
  ASSERT_TRUE(r.completed) << r.error;
  EXPECT_EQ(r.cutbacks, 0);
  EXPECT_GT(r.minres_solves, 0);
  EXPECT_LT(r.newton_iterations, 250);
  const Mat3& F = r.steps.back().F;
  EXPECT_NEAR(F(0, 0), 0.6, 1e-12);
  EXPECT_LT(std::abs(F(2, 0)) + std::abs(F(2, 1)) + std::abs(F(0, 2)) + std::abs(F(1, 2)), 1e-3);
  EXPECT_LT(r.steps.back().P(0, 0), 0.0);
  bool logged = false;
  for (const auto& line : r.log) logged = logged || line.find("branch is unstable") != std::string::npos;
  EXPECT_TRUE(logged);
  std::cout << "[ minres ] Newton " << r.newton_iterations << ", Krylov " << r.krylov_iterations
            << ", MINRES solves " << r.minres_solves << ", P11 " << r.steps.back().P(0, 0) << "\n";
}

// Chapter-IV campaign: ecoflex + square glass fibers (0.07 mm, VF 0.23, generated section,
// 32², rotated, tolerance 1e-6), α = 30°, uniaxial tension. With the corner pixels' laminate normals
// tie-broken by round-off (different at mirror-image corners) the cell lost its mirror symmetry about
// the plate normal: the out-of-plane shears F31, F32 drifted to 1e-4 by λ = 1.5, a spurious soft mode
// made the tangent singular at λ ≈ 1.522 and the run stopped there after 12 cut-backs (MINRES Newton
// steps 1000× the ordinary ones, localised at a fiber corner). With the interface-mean normals the
// cell is symmetric and the run passes λ = 1.6 without cut-backs or indefinite solves. Bounds: F31,
// F32 at the round-off of the 1e-6 Newton tolerance (measured ≤ 3e-9 up to λ = 1.8; they were 1e-4);
// P11(1.6) against the conforming FE engine on the same section (T6, 27 670 elements, corner-graded:
// 0.044659) within 1.5 % (measured −0.42 %: the 32² voxel error; 64² gives 0.044633).
TEST(FftRve, SquareFiberEcoflexTensionStaysSymmetricPastFormerStall) {
  FiberCellSpec spec;
  spec.shape = SectionShape::rectangle;
  spec.width = spec.height = 0.07;
  spec.volume_fraction = 0.23;
  const PhaseImage im = voxelize_section(generate_section(spec), 32, 32);
  const MixedControl control = uniaxial_ramp(1.6, 12);  // Δλ = 0.05 as in the campaign
  FftSolverOptions o = fast_options(fft::Discretization::rotated, 1e-6);
  FftRveSolver solver(im, ecoflex(), glass(), 30.0, control.frame, o);
  const RveRunResult r = solver.run(control);
  ASSERT_TRUE(r.completed) << r.error;
  EXPECT_EQ(r.cutbacks, 0);
  EXPECT_EQ(r.minres_solves, 0);
  for (const RveStep& s : r.steps) {
    EXPECT_LT(std::abs(s.F(2, 0)), 1e-7) << "t = " << s.t;
    EXPECT_LT(std::abs(s.F(2, 1)), 1e-7) << "t = " << s.t;
  }
  EXPECT_NEAR(r.steps.back().F(0, 0), 1.6, 1e-12);
  EXPECT_NEAR(r.steps.back().P(0, 0), 0.044659, 0.015 * 0.044659);
  std::cout << "[ square ] Newton " << r.newton_iterations << ", Krylov " << r.krylov_iterations
            << ", P11(1.6) " << r.steps.back().P(0, 0) << ", F31 " << r.steps.back().F(2, 0) << "\n";
}

// The streamed evaluation (material points inside the stencil pass, no 9-field buffer) against the
// stored 9-field path it replaces. The Krylov operator is the same to the bit (the same gather of the
// nodal forces); the residual's divergence is the real-space gather instead of the Fourier one, equal to
// round-off. A compressible 3D cell 8 × 8 × 16 with the fiber inclined to the grid then takes the same
// Newton / Krylov counts and reaches the same stress to 1e-12 (measured 4e-15). Mixed (u, p) cells
// amplify round-off: their float pressures and slopes flip a last bit on a round-off difference (6e-8 of
// the pressure correction), which Newton corrects to its tolerance 1e-8, and ecoflex (K/G = 1.2e5) is as
// sensitive as a change of FFT plan (±5–10 % Krylov, BENCHMARKS.md "Iteration cost and solver options"): the same
// stress to the tolerance and counts within 10 % on a PDMS-like section (K/G = 3e3) and on an
// ecoflex/glass 16 × 16 × 4 cell; the stress alone on the ecoflex/glass section with a step size that
// makes the line search backtrack and the steps cut back, whose path depends on round-off (there the
// linearization restore of the streamed path is checked bit for bit against recomputing it before every
// trial). On the 3D cell, a nodal-force sum that adds the cancelling bulk
// stress terms per voxel instead of per corner row of a node takes 1.5× the Krylov iterations there
// (measured 4 531 against 2 954). Field output (P re-evaluated at the converged F): its mean is the
// step's stress.
TEST(FftRve, StreamedEvaluationEqualsStoredFields) {
  const OneThread one_thread;
  PhaseImage cube = circle_image(8, 0.3);
  cube.n = {8, 8, 16};
  cube.size[2] = 2.0;
  {
    const std::vector<double> f = cube.fiber_fraction;
    const std::vector<Eigen::Vector3d> nrm = cube.normal;
    for (int k = 1; k < 16; ++k) {
      cube.fiber_fraction.insert(cube.fiber_fraction.end(), f.begin(), f.end());
      cube.normal.insert(cube.normal.end(), nrm.begin(), nrm.end());
    }
  }
  struct Case {
    const char* name;
    PhaseImage image;
    MaterialPtr matrix;
    MixedControl control;
    bool exact;  // well-conditioned: equal counts
    double P_tolerance;
    bool cuts_back = false;
  };
  PhaseImage eco_cube = circle_image(16, 0.27);
  eco_cube.n[2] = 4;
  eco_cube.size[2] = 4.0 / 16.0;
  {
    const std::vector<double> f = eco_cube.fiber_fraction;
    const std::vector<Eigen::Vector3d> nrm = eco_cube.normal;
    for (int k = 1; k < 4; ++k) {
      eco_cube.fiber_fraction.insert(eco_cube.fiber_fraction.end(), f.begin(), f.end());
      eco_cube.normal.insert(eco_cube.normal.end(), nrm.begin(), nrm.end());
    }
  }
  const Case cases[] = {{"ecoflex/glass 16^2", circle_image(16, 0.27), ecoflex(), uniaxial_ramp(1.5, 2), false, 1e-8, true},
                        {"ecoflex/glass 16x16x4", eco_cube, ecoflex(), uniaxial_ramp(1.2, 2), false, 1e-8},
                        {"PDMS-like/glass 16^2", circle_image(16, 0.27), neo_hookean(1.0, 3000.0), uniaxial_ramp(1.3, 2), false, 1e-9},
                        {"neo-Hooke/glass 8x8x16", cube, neo_hookean(1.0, 20.0), uniaxial_ramp(1.3, 3), true, 1e-12}};
  for (const Case& c : cases) {
    RveRunResult runs[3];
    Mat3 field_mean[3];
    for (int variant = 0; variant < 3; ++variant) {
      FftSolverOptions o = fast_options(fft::Discretization::rotated, 1e-8);
      o.stream_evaluation = variant != 1;
      o.relinearize_every_trial = variant == 2;
      FftRveSolver solver(c.image, c.matrix, glass(), 35.0, c.control.frame, o);
      const auto arrays = solver.memory_breakdown();
      const bool has_fields = std::any_of(arrays.begin(), arrays.end(), [](const auto& a) { return a.first == "fft_buffers"; });
      EXPECT_EQ(has_fields, variant == 1) << c.name;
      runs[variant] = solver.run(
          c.control,
          [&](const RveStep&, const RveFields* f) {
            if (!f) return;
            Mat3 m = Mat3::Zero();
            const std::size_t n = f->P.size() / 9;
            for (std::size_t v = 0; v < n; ++v)
              for (int k = 0; k < 9; ++k) m(k / 3, k % 3) += f->P[9 * v + k] / double(n);
            field_mean[variant] = m;
          },
          [&](double t) { return t >= 1.0 - 1e-12; });
      ASSERT_TRUE(runs[variant].completed) << c.name << ": " << runs[variant].error;
    }
    const RveRunResult &streamed = runs[0], &stored = runs[1], &relinearized = runs[2];
    if (c.exact) {
      EXPECT_EQ(streamed.newton_iterations, stored.newton_iterations) << c.name;
      EXPECT_EQ(streamed.krylov_iterations, stored.krylov_iterations) << c.name;
      EXPECT_EQ(streamed.cutbacks, stored.cutbacks) << c.name;
      EXPECT_LT(rel(streamed.steps.back().P, stored.steps.back().P), c.P_tolerance) << c.name;
    } else {
      if (c.cuts_back) {
        // Cut-backs make the path itself depend on round-off (7–16 % Krylov apart measured): the stress only.
        EXPECT_GT(streamed.cutbacks, 0) << c.name;
      } else {
        EXPECT_NEAR(streamed.newton_iterations, stored.newton_iterations, 0.1 * stored.newton_iterations) << c.name;
        EXPECT_NEAR(streamed.krylov_iterations, stored.krylov_iterations, 0.1 * stored.krylov_iterations) << c.name;
      }
      EXPECT_LT(rel(streamed.steps.back().P, stored.steps.back().P), c.P_tolerance) << c.name;
    }
    // The restore of the accepted linearization: bit for bit as recomputing it before every trial.
    EXPECT_EQ(streamed.newton_iterations, relinearized.newton_iterations) << c.name;
    EXPECT_EQ(rel(streamed.steps.back().P, relinearized.steps.back().P), 0.0) << c.name;
    // Field output: the mean of the re-evaluated P is the step's P (the mean of the residual's P_full;
    // the re-evaluation differs by the float rounding of the pressure correction, ≪ 1e-9).
    for (int variant : {0, 1})
      EXPECT_LT(rel(field_mean[variant], runs[variant].steps.back().P), 1e-9) << c.name << " variant " << variant;
    std::cout << "[ streamed ] " << c.name << ": Newton " << streamed.newton_iterations << ", Krylov "
              << streamed.krylov_iterations << ", cut-backs " << streamed.cutbacks << ", |ΔP|/|P| "
              << rel(streamed.steps.back().P, stored.steps.back().P) << "\n";
  }
}

// The progress callback (FftSolverOptions::on_newton_iteration) sees every Newton iteration of every
// sub-step in order: per output step, its iterations 0, 1, … with the residual history the step
// reports, and a Krylov count that ends at the step's (no cut-back on this cell, one sub-step each).
TEST(FftRve, NewtonIterationCallbackFollowsTheResidualHistory) {
  struct Call {
    double t;
    int iteration;
    double residual;
    int krylov;
  };
  std::vector<Call> calls;
  FftSolverOptions o;
  o.tolerance = 1e-8;
  o.plan.rigor = fft::PlanRigor::estimate;
  o.on_newton_iteration = [&calls](double t, int it, double r, int k) { calls.push_back({t, it, r, k}); };
  const MixedControl control = uniaxial_ramp(1.2, 2);
  FftRveSolver solver(circle_image(8, 0.3), make_material(make_neo_hookean({1.0, 10.0})),
                      make_material(make_neo_hookean({5.0, 50.0})), 0.0, control.frame, o);
  const RveRunResult r = solver.run(control);
  ASSERT_TRUE(r.completed) << r.error;
  ASSERT_EQ(r.cutbacks, 0);
  std::size_t next = 0;
  for (std::size_t s = 1; s < r.steps.size(); ++s) {
    const RveStep& step = r.steps[s];
    ASSERT_GE(step.residuals.size(), 2u);
    for (std::size_t i = 0; i < step.residuals.size(); ++i, ++next) {
      ASSERT_LT(next, calls.size());
      EXPECT_EQ(calls[next].t, step.t);
      EXPECT_EQ(calls[next].iteration, int(i));
      EXPECT_EQ(calls[next].residual, step.residuals[i]);
    }
    EXPECT_EQ(calls[next - 1].krylov, step.krylov_iterations);  // one sub-step: all its solves
    EXPECT_GT(calls[next - 1].krylov, 0);
  }
  EXPECT_EQ(next, calls.size());  // no call outside the steps' histories
}
