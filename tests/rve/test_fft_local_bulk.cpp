// The Green preconditioner with a local bulk modulus (FftSolverOptions::preconditioner =
// green_local_bulk, rve/src/fft_local_bulk.hpp): its reference medium, its exactness where the cell
// differs only in bulk, the same converged stress as the Green preconditioner with fewer iterations on a
// PDMS/glass section, the automatic choice, and the input errors.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "../rve/src/fft_local_bulk.hpp"
#include "rve/rve_test_helpers.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/materials/laws.hpp"
#include "softhom/rve/fft_solver.hpp"

using namespace softhom;
using namespace softhom::rve;
using softhom::rve::testing::circle_image;
using softhom::rve::testing::full_deformation;
using softhom::rve::testing::uniaxial_ramp;
using softhom::rve::testing::ecoflex;
using softhom::rve::testing::glass;

namespace {

Mat3 some_deformation() {
  Mat3 F;
  F << 1.3, 0.2, -0.1, 0.05, 0.85, 0.15, -0.08, 0.1, 0.95;
  return F;
}

MaterialPtr pdms() { return make_material(make_gent_hgo({0.65, 5.0, 2000.0, {}, FiberInvariant::full, true})); }

/// circle_image with every voxel given to its majority phase (no composite voxels).
PhaseImage binary_circle(int n, double r) {
  PhaseImage im = circle_image(n, r);
  for (std::size_t v = 0; v < im.fiber_fraction.size(); ++v) {
    im.fiber_fraction[v] = im.fiber_fraction[v] >= 0.5 ? 1.0 : 0.0;
    im.normal[v].setZero();
  }
  return im;
}

struct Solve {
  Mat3 P;
  int newton = 0, krylov = 0;
  Preconditioner used = Preconditioner::automatic;
};

Solve solve(const PhaseImage& im, const MaterialPtr& matrix, const MaterialPtr& fiber, const MixedControl& control,
            Preconditioner pc, double tolerance) {
  FftSolverOptions o;
  o.preconditioner = pc;
  o.tolerance = tolerance;
  o.plan.rigor = fft::PlanRigor::estimate;
  FftRveSolver s(im, matrix, fiber, 30.0, control.frame, o);
  const RveRunResult r = s.run(control);
  EXPECT_TRUE(r.completed) << r.error;
  return {r.steps.back().P, r.newton_iterations, r.krylov_iterations, s.preconditioner()};
}

}  // namespace

TEST(FftLocalBulk, ReferenceMediumAtTheIdentityIsTheIsotropicTangent) {
  const double k = 7.0, mu = 1.5;
  const Mat9 A = rve::detail::isotropic_pull_back(k, mu, Mat3::Identity());
  EXPECT_LE((A - rve::detail::isotropic_tangent(k - 2.0 / 3.0 * mu, mu)).cwiseAbs().maxCoeff(), 1e-14 * k);
  const rve::detail::IsotropicModuli iso = rve::detail::isotropic_projection(rve::detail::isotropic_tangent(3.0, 0.4));
  EXPECT_NEAR(iso.K, 3.0 + 2.0 / 3.0 * 0.4, 1e-14);
  EXPECT_NEAR(iso.mu, 0.4, 1e-14);
}

// The pull-back maps δF to J (c : δF F⁻¹) F⁻ᵀ (the spatial medium acting on the spatial velocity
// gradient, pulled back to a Piola stress rate), and the local bulk modulus read from it is
// λ + 2μ |C⁻¹|² / (tr C⁻¹)², which is k at F = I.
TEST(FftLocalBulk, ReferenceMediumIsTheSpatialMediumPulledBack) {
  const double k = 40.0, mu = 2.0, lambda = k - 2.0 / 3.0 * mu;
  const Mat3 F = some_deformation(), Fi = F.inverse();
  const double J = F.determinant();
  const Mat9 A = rve::detail::isotropic_pull_back(k, mu, F);
  Mat3 dF;
  dF << 0.3, -0.2, 0.1, 0.7, 0.05, -0.4, 0.2, 0.6, -0.3;
  const Mat3 L = dF * Fi;
  const Mat3 s = lambda * L.trace() * Mat3::Identity() + mu * (L + L.transpose());
  const Mat3 expected = J * s * Fi.transpose();
  Vec9 x;
  for (int c = 0; c < 9; ++c) x[c] = dF(c / 3, c % 3);
  const Vec9 y = A * x;
  for (int c = 0; c < 9; ++c) EXPECT_NEAR(y[c], expected(c / 3, c % 3), 1e-12 * expected.cwiseAbs().maxCoeff()) << c;
  const Mat3 cof = J * Fi.transpose();
  Vec9 b;
  for (int c = 0; c < 9; ++c) b[c] = cof(c / 3, c % 3);
  const Mat3 Ci = Fi * Fi.transpose();
  const double tr = Ci.trace(), expected_k = lambda + 2.0 * mu * Ci.squaredNorm() / (tr * tr);
  EXPECT_NEAR(rve::detail::local_bulk_modulus(b.dot(A * b), J, b.squaredNorm()), expected_k, 1e-12 * k);
  EXPECT_EQ(rve::detail::local_bulk_modulus(-1.0, J, b.squaredNorm()), 0.0);  // clipped
}

// Two phases with the same shear modulus and bulk moduli 1000× apart, every voxel pure, every component
// of F prescribed, a strain of 1e-5: the Newton operator is then the reference operator of the local-bulk
// preconditioner up to O(1e-5), so each CG solve needs one iteration (two allowed for round-off and the
// dilatation of the (π, π) mode, which the correction leaves out). The Green preconditioner, one bulk
// modulus for both phases, is not exact: measured (12², tolerance 1e-10) 2 Newton / 3 Krylov against
// 3 / 12. The stresses agree to the Newton tolerance (|P| ≈ 1e-5 here, the difference ≈ 1e-12).
TEST(FftLocalBulk, ExactWhereThePhasesDifferInBulkOnly) {
  const PhaseImage im = binary_circle(12, 0.3);
  const MaterialPtr soft_bulk = make_material(make_neo_hookean({1.0, 2.0}));
  const MaterialPtr stiff_bulk = make_material(make_neo_hookean({1.0, 2000.0}));
  Mat3 F = Mat3::Identity();
  F(0, 0) = 1.0 + 1e-5;
  F(0, 1) = 0.5e-5;
  const MixedControl control = full_deformation(F, 1);
  const Solve local = solve(im, stiff_bulk, soft_bulk, control, Preconditioner::green_local_bulk, 1e-10);
  const Solve green = solve(im, stiff_bulk, soft_bulk, control, Preconditioner::green, 1e-10);
  std::printf("[ info     ] local bulk %d Newton / %d Krylov, green %d / %d\n", local.newton, local.krylov, green.newton,
              green.krylov);
  EXPECT_LE(local.krylov, 2 * local.newton);
  EXPECT_GE(green.krylov, 2 * local.krylov);
  EXPECT_LE((local.P - green.P).cwiseAbs().maxCoeff(), 1e-6 * green.P.cwiseAbs().maxCoeff());
}

// PDMS (K/G = 3e3) around glass, composite voxels, uniaxial stress: the same converged stress as with
// the Green preconditioner (tolerance 1e-10 on both, compared to 1e-8 as in the Jacobi–Green test) in
// fewer Krylov iterations (measured 16², λ = 1.3 in 2 steps: 15 Newton / 562 Krylov against 16 / 918,
// 0.61×; the isotropic reference medium at F̄ without the local bulk takes 15 / 680, 0.74×, and fails the
// bound).
TEST(FftLocalBulk, SameStressFewerIterationsOnAPdmsGlassSection) {
  const PhaseImage im = circle_image(16, 0.27);
  const MixedControl control = uniaxial_ramp(1.3, 2);
  const Solve local = solve(im, pdms(), glass(), control, Preconditioner::green_local_bulk, 1e-10);
  const Solve green = solve(im, pdms(), glass(), control, Preconditioner::green, 1e-10);
  std::printf("[ info     ] local bulk %d Newton / %d Krylov, green %d / %d, P11 %.10f / %.10f\n", local.newton,
              local.krylov, green.newton, green.krylov, local.P(0, 0), green.P(0, 0));
  EXPECT_LE((local.P - green.P).cwiseAbs().maxCoeff(), 1e-8 * green.P.cwiseAbs().maxCoeff()) << local.P << "\n" << green.P;
  EXPECT_LT(double(local.krylov), 0.67 * green.krylov);
  EXPECT_LE(local.newton, green.newton + 2);
}

// auto: the local bulk for PDMS/glass (bulk moduli 240× apart, shear moduli 5.9×), green for
// Ecoflex/glass (240× and 226×) and wherever the local bulk does not apply (hex).
TEST(FftLocalBulk, AutoTakesTheLocalBulkWhereTheBulkModuliSpreadFurther) {
  const PhaseImage im = circle_image(8, 0.27);
  auto chosen = [&](const MaterialPtr& matrix, fft::Discretization d) {
    FftSolverOptions o;
    o.discretization = d;
    o.plan.rigor = fft::PlanRigor::estimate;
    return FftRveSolver(im, matrix, glass(), 30.0, Mat3::Identity(), o).preconditioner();
  };
  EXPECT_EQ(chosen(pdms(), fft::Discretization::rotated), Preconditioner::green_local_bulk);
  EXPECT_EQ(chosen(ecoflex(), fft::Discretization::rotated), Preconditioner::green);
  EXPECT_EQ(chosen(pdms(), fft::Discretization::hex), Preconditioner::green);
  EXPECT_STREQ(to_string(Preconditioner::green_local_bulk), "green-local-bulk");
}

TEST(FftLocalBulk, OtherDiscretizationsAreAnInputErrorNamingTheKey) {
  const PhaseImage im = circle_image(8, 0.27);
  for (auto d : {fft::Discretization::hex, fft::Discretization::spectral}) {
    FftSolverOptions o;
    o.discretization = d;
    o.preconditioner = Preconditioner::green_local_bulk;
    try {
      FftRveSolver s(im, pdms(), glass(), 30.0, Mat3::Identity(), o);
      ADD_FAILURE() << "no error for " << fft::to_string(d);
    } catch (const InputError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("solver.preconditioner"), std::string::npos) << what;
      EXPECT_NE(what.find("green-local-bulk"), std::string::npos) << what;
      EXPECT_NE(what.find("rotated"), std::string::npos) << what;
    }
  }
}

// The storage the solver plans before allocating is the storage it allocates (the memory refusal and
// summary.json's bytes per voxel follow the arrays): the weights and the one-field transform.
TEST(FftLocalBulk, PlannedBytesFollowTheStorage) {
  const PhaseImage im = circle_image(16, 0.27);
  FftSolverOptions o;
  o.preconditioner = Preconditioner::green_local_bulk;
  o.plan.rigor = fft::PlanRigor::estimate;
  FftRveSolver s(im, pdms(), glass(), 30.0, Mat3::Identity(), o);
  std::size_t composites = 0, local_bulk = 0;
  for (const auto& [array, bytes] : s.memory_breakdown()) {
    if (array == "composites") composites = bytes;
    if (array == "local_bulk") local_bulk = bytes;
  }
  EXPECT_EQ(s.memory_bytes(), s.planned_memory_bytes() + composites);
  // 4 B of weight per voxel and the in-place half spectrum: 16 · 16 · 9 complex doubles.
  EXPECT_EQ(local_bulk, 4u * 256u + 16u * 16u * 9u);
}
