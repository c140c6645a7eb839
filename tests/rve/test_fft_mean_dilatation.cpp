// The mean-dilatation (F̄) voxel of the hex discretization (rve/src/fft_mean_dilatation.hpp): its stresses
// against the closed form of a decoupled law (Q1/P0: the law's volumetric stress taken at the voxel's
// J̄), its Newton tangent against finite differences of those stresses (per voxel and, through the
// homogenized tangent, assembled over a cell), and a homogeneous cell against the closed form.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "../rve/src/fft_mean_dilatation.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/materials/laws.hpp"
#include "softhom/rve/fft_solver.hpp"
#include "softhom/rve/geometry.hpp"
#include "rve/rve_test_helpers.hpp"

using namespace softhom;
using namespace softhom::rve;
using softhom::rve::testing::glass;

namespace {

MaterialPtr gent(double k_over_g) {
  return make_material(make_gent_hgo({0.017, 14.0, 0.017 * k_over_g, {}, FiberInvariant::full, true}));
}

/// nq points of one voxel with independent F_q = I + 0.15 · random (the voxel algebra does not need
/// them to come from one displacement) and Gauss weights 1/nq.
rve::detail::MeanDilatationVoxel random_voxel(int nq, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> d(-0.15, 0.15);
  rve::detail::MeanDilatationVoxel v;
  for (int q = 0; q < nq; ++q) {
    v.F[q] = Mat3::Identity();
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) v.F[q](i, j) += d(rng);
  }
  double w[8];
  for (int q = 0; q < nq; ++q) w[q] = 1.0 / nq;
  EXPECT_TRUE(v.prepare(nq, w));
  return v;
}

/// The voxel's response with the law evaluated at F̄_q.
rve::detail::MeanDilatationResponse respond(const Material& m, const rve::detail::MeanDilatationVoxel& v, bool tangent) {
  Mat3 P[8];
  Mat9 A[8];
  for (int q = 0; q < v.nq; ++q)
    EXPECT_EQ(m.evaluate(v.modified(q), nullptr, nullptr, 0.0, P[q], tangent ? &A[q] : nullptr), MaterialStatus::ok);
  rve::detail::MeanDilatationResponse r;
  rve::detail::mean_dilatation_response(v, P, tangent ? A : nullptr, r);
  return r;
}

}  // namespace

// Q1/P0 for a decoupled law (Gent: W_iso(J^{-1/3} F) + W_V(J), W_V′ = K/2 (J − 1/J)): the discrete energy
// is Σ_q w_q W_iso(F_q) + W_V(J̄), so P_q = P(F_q) + (W_V′(J̄) − W_V′(J_q)) J_q F_q^{-T}. Tolerance 1e-9 of
// max|P|: both sides are the same stress computed along two roundings of K ≈ 2e3 G terms (measured 1e-12).
TEST(FftMeanDilatation, StressIsQ1P0ForADecoupledLaw) {
  const MaterialPtr m = gent(1e3);
  const double K = m->volumetric_modulus();
  ASSERT_GT(K, 0.0);
  for (int nq : {4, 8}) {
    const rve::detail::MeanDilatationVoxel v = random_voxel(nq, 7u + unsigned(nq));
    const rve::detail::MeanDilatationResponse r = respond(*m, v, false);
    const auto dU = [&](double J) { return 0.5 * K * (J - 1.0 / J); };
    for (int q = 0; q < nq; ++q) {
      Mat3 P;
      ASSERT_EQ(m->evaluate(v.F[q], nullptr, nullptr, 0.0, P, nullptr), MaterialStatus::ok);
      const Mat3 expected = P + (dU(v.J_mean) - dU(v.J[q])) * v.J[q] * v.F[q].inverse().transpose();
      EXPECT_LT((r.P[q] - expected).cwiseAbs().maxCoeff(), 1e-9 * expected.cwiseAbs().maxCoeff()) << "nq " << nq << " q " << q;
    }
  }
}

// The voxel Hessian (K_q, a_q, ĝ_q, c, applied as the stencil operator applies it) against central
// differences of the voxel's stresses P_q in every component of every F_p: the Newton operator is the
// derivative of the residual. Step 1e-6 (relative error of central differences ≈ h² |P‴| / |P′| + ε |P| / h
// ≈ 1e-10 + 1e-10 at these F); tolerance 1e-6 of the largest entry. Both a compressible (K/G 10) and a
// nearly incompressible (K/G 1.2e5) matrix, 2D (4 points) and 3D (8 points). Also: the Hessian is
// symmetric, so the residual is the gradient of an energy and CG applies.
TEST(FftMeanDilatation, TangentIsTheDerivativeOfTheStress) {
  for (double kg : {10.0, 1.2e5})
    for (int nq : {4, 8}) {
      const MaterialPtr m = gent(kg);
      const rve::detail::MeanDilatationVoxel v = random_voxel(nq, 11u + unsigned(nq));
      const rve::detail::MeanDilatationResponse r = respond(*m, v, true);
      rve::detail::MeanDilatationCoupling coupling;
      coupling.resize(1, nq);
      coupling.store(0, r);
      // H(9q + a, 9p + b) = ∂P_q,a / ∂F_p,b from the operator (unit ΔF_p,b through add_to_batch).
      const int n = 9 * nq;
      Eigen::MatrixXd H(n, n), H_fd(n, n);
      constexpr int B = 8;
      for (int col = 0; col < n; ++col) {
        double dF[9 * B] = {}, dP[9 * B] = {};
        dF[(col % 9) * B + col / 9] = 1.0;
        for (int q = 0; q < nq; ++q) {
          Vec9 x;
          for (int k = 0; k < 9; ++k) x[k] = dF[k * B + q];
          const Vec9 y = r.K[q] * x;
          for (int k = 0; k < 9; ++k) dP[k * B + q] = y[k];
        }
        coupling.add_to_batch<B>(0, nq, v.w, dF, dP);
        for (int row = 0; row < n; ++row) H(row, col) = dP[(row % 9) * B + row / 9];
        const double h = 1e-6;
        rve::detail::MeanDilatationVoxel vp = v, vm = v;
        vp.F[col / 9](col % 9 / 3, col % 3) += h;
        vm.F[col / 9](col % 9 / 3, col % 3) -= h;
        ASSERT_TRUE(vp.prepare(nq, v.w) && vm.prepare(nq, v.w));
        const rve::detail::MeanDilatationResponse rp = respond(*m, vp, false), rm = respond(*m, vm, false);
        for (int row = 0; row < n; ++row) {
          const int q = row / 9, a = row % 9;
          H_fd(row, col) = (rp.P[q](a / 3, a % 3) - rm.P[q](a / 3, a % 3)) / (2.0 * h);
        }
      }
      // Both are ∂P_q/∂F_p: P_q = ∂Π/∂F_q / w_q and the operator's δP_q is defined by δ²Π = Σ_q w_q δP_q : δF_q.
      const double scale = H_fd.cwiseAbs().maxCoeff();
      EXPECT_LT((H - H_fd).cwiseAbs().maxCoeff(), 1e-6 * scale) << "K/G " << kg << " nq " << nq;
      EXPECT_LT((H - H.transpose()).cwiseAbs().maxCoeff(), 1e-12 * scale) << "K/G " << kg << " nq " << nq;
    }
}

// The uniform-ΔF tangent of the voxel (its share of the reference medium) is the operator applied to a
// uniform ΔF, averaged: to round-off.
TEST(FftMeanDilatation, VoxelTangentIsTheOperatorOnAUniformIncrement) {
  const MaterialPtr m = gent(1.2e5);
  const rve::detail::MeanDilatationVoxel v = random_voxel(4, 3u);
  const rve::detail::MeanDilatationResponse r = respond(*m, v, true);
  rve::detail::MeanDilatationCoupling coupling;
  coupling.resize(1, 4);
  coupling.store(0, r);
  constexpr int B = 8;
  for (int b = 0; b < 9; ++b) {
    double dF[9 * B] = {}, dP[9 * B] = {};
    for (int q = 0; q < 4; ++q) dF[b * B + q] = 1.0;
    for (int q = 0; q < 4; ++q) {
      const Vec9 y = r.K[q].col(b);
      for (int k = 0; k < 9; ++k) dP[k * B + q] = y[k];
    }
    coupling.add_to_batch<B>(0, 4, v.w, dF, dP);
    for (int a = 0; a < 9; ++a) {
      double mean = 0.0;
      for (int q = 0; q < 4; ++q) mean += v.w[q] * dP[a * B + q];
      EXPECT_NEAR(mean, r.voxel_tangent(a, b), 1e-9 * r.voxel_tangent.cwiseAbs().maxCoeff());
    }
  }
}

namespace {

FftSolverOptions mean_dilatation_options() {
  FftSolverOptions o;
  o.discretization = fft::Discretization::hex;
  o.volumetric = VolumetricKinematics::mean_dilatation;
  o.plan.rigor = fft::PlanRigor::estimate;
  return o;
}

/// Every component of F prescribed, I → F_end linearly, `steps` output steps.
MixedControl to(const Mat3& F_end, int steps) {
  MixedControl c;
  for (int k = 0; k < 9; ++k) {
    c.kind[k] = ControlKind::deformation;
    c.value[k] = PiecewiseLinear{{0.0, 1.0}, {k % 4 == 0 ? 1.0 : 0.0, F_end(k / 3, k % 3)}};
  }
  for (int s = 1; s <= steps; ++s) c.times.push_back(double(s) / steps);
  return c;
}

PhaseImage circle(int n) {
  FiberCellSpec spec;
  spec.shape = SectionShape::circle;
  spec.arrangement = Arrangement::square;
  spec.volume_fraction = 0.23;
  spec.radius = 0.2;
  return voxelize_section(generate_section(spec), n, n);
}


}  // namespace

// Assembled: the homogenized tangent C̄ (the solver's Newton operator, voxel coupling included, solved for
// unit macro perturbations) against central differences of P̄ between two solves at F_end ± h e_b, on an
// 8² glass/Gent section (K/G = 1e3, composite voxels) at a sheared, stretched F. h = 1e-5; the solves are
// converged to 1e-11 (P̄ error ≈ 1e-11 · 0.05 MPa, i.e. ≈ 5e-7 relative in the difference quotient of
// C̄ ≈ 0.1 MPa) and the O(h²) term is ≈ 1e-10 relative: tolerance 1e-4 of the column's largest entry.
// A tangent missing the voxel coupling (K_q alone) is off by the bulk modulus, 1e2–1e3× that.
TEST(FftMeanDilatation, HomogenizedTangentMatchesFiniteDifferences) {
  const MaterialPtr matrix = gent(1e3);
  FftSolverOptions o = mean_dilatation_options();
  o.tolerance = 1e-11;
  o.krylov_tolerance = 1e-12;
  Mat3 F = Mat3::Identity();
  F(1, 1) = 1.15;
  F(0, 0) = 1.0 / std::sqrt(1.15);
  F(2, 2) = 1.0 / std::sqrt(1.15);
  F(0, 1) = 0.08;
  F(1, 2) = -0.05;
  FftRveSolver solver(circle(8), matrix, glass(), 90.0, Mat3::Identity(), o);
  const RveRunResult r = solver.run(to(F, 3));
  ASSERT_TRUE(r.completed) << r.error;
  const Mat9 C = solver.homogenized_tangent(1e-12);
  const double h = 1e-5;
  for (int b : {0, 1, 4, 5}) {
    Vec9 dP;
    Mat3 P[2];
    for (int side = 0; side < 2; ++side) {
      Mat3 Fs = F;
      Fs(b / 3, b % 3) += side ? -h : h;
      FftRveSolver s(circle(8), matrix, glass(), 90.0, Mat3::Identity(), o);
      const RveRunResult rs = s.run(to(Fs, 3));
      ASSERT_TRUE(rs.completed) << rs.error;
      P[side] = rs.steps.back().P;
    }
    dP = flatten(P[0] - P[1]) / (2.0 * h);
    const double scale = C.col(b).cwiseAbs().maxCoeff();
    for (int a = 0; a < 9; ++a) EXPECT_NEAR(C(a, b), dP[a], 1e-4 * scale) << "C(" << a << ", " << b << ")";
  }
}

// A homogeneous cell (both phases the Gent matrix, K/G = 1.2e5) under uniaxial stress across the fiber
// (F22 = λ = 1.5, the other stresses zero): every voxel deforms uniformly, α_q = 1, and P22 is the closed
// form of the incompressible law, G (λ − λ⁻²) Jm / (Jm − Ī1 + 3), Ī1 = λ² + 2/λ (0.018725). Tolerance
// 1e-4 relative: the finite bulk modulus moves the lateral stretches by O(G/K) ≈ 1e-5 and the Newton
// tolerance (1e-6) the stress by as much.
TEST(FftMeanDilatation, HomogeneousCellIsTheClosedForm) {
  const double G = 0.017, Jm = 14.0, lambda = 1.5;
  MixedControl c = uniaxial_control(PiecewiseLinear{{0.0, 1.0}, {1.0, lambda}});
  c.times.clear();
  for (int s = 1; s <= 4; ++s) c.times.push_back(s / 4.0);
  for (int k = 0; k < 9; ++k) {
    c.kind[k] = ControlKind::stress;
    c.value[k] = PiecewiseLinear::constant(0.0);
  }
  c.kind[4] = ControlKind::deformation;
  c.value[4] = PiecewiseLinear{{0.0, 1.0}, {1.0, lambda}};
  for (int k : {3, 5, 2}) c.kind[k] = ControlKind::deformation;
  FftSolverOptions o = mean_dilatation_options();
  o.tolerance = 1e-6;
  FftRveSolver s(circle(8), gent(1.2e5), gent(1.2e5), 90.0, Mat3::Identity(), o);
  const RveRunResult r = s.run(c);
  ASSERT_TRUE(r.completed) << r.error;
  const double I1 = lambda * lambda + 2.0 / lambda;
  const double expected = G * (lambda - 1.0 / (lambda * lambda)) * Jm / (Jm - I1 + 3.0);
  EXPECT_NEAR(r.steps.back().P(1, 1), expected, 1e-4 * expected);
  EXPECT_NEAR(r.steps.back().F(0, 0), 1.0 / std::sqrt(lambda), 1e-4);
}

// The variant needs the hex points and the stencil operator: anything else is an InputError naming the key.
TEST(FftMeanDilatation, OtherDiscretizationsAreAnInputError) {
  FftSolverOptions o = mean_dilatation_options();
  o.discretization = fft::Discretization::rotated;
  try {
    FftRveSolver s(circle(8), gent(10.0), glass(), 90.0, Mat3::Identity(), o);
    ADD_FAILURE() << "no error for rotated";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("solver.volumetric"), std::string::npos) << e.what();
  }
  o = mean_dilatation_options();
  o.krylov_operator = KrylovOperator::fourier;
  EXPECT_THROW(FftRveSolver(circle(8), gent(10.0), glass(), 90.0, Mat3::Identity(), o), InputError);
}
