// The mixed (u, p) iteration's per-point pressures (rve/src/fft_pressure_iteration.hpp) on their own:
// the linearization and its round-off, the corrected stress and tangent, the compact record's slope,
// the commit and the extrapolated predictor. The whole iteration inside the solver is covered by the
// FftRve and FftRveTransverse tests.
#include <gtest/gtest.h>

#include <cmath>

#include "../rve/src/fft_pressure_iteration.hpp"

namespace softhom::rve {
namespace {

using detail::PressureIteration;

// Ecoflex's volumetric modulus against a shear modulus of 0.017 MPa (K/G = 1.2e5).
constexpr double kBulk = 2040.0;

Mat3 deformation(double s) {
  Mat3 F;
  F << 1.0 + 0.1 * s, 0.03, -0.02, 0.05 * s, 0.97, 0.04, -0.01, 0.02 * s, 1.02;
  return F;
}

PressureIteration one_point_iteration(bool store_slopes) {
  PressureIteration it;
  it.mixed[0] = true;
  it.K[0] = kBulk;
  it.allocate(1, store_slopes);
  return it;
}

// An iteration whose point was evaluated (and so linearized) at Fk, reading its linearization next.
PressureIteration linearized_at(const Mat3& Fk) {
  PressureIteration it = one_point_iteration(true);
  Mat3 P = Mat3::Zero();
  it.correct(0, 0, Fk, P, nullptr, nullptr);
  it.linearized = true;
  return it;
}

// Evaluated where it was linearized, the carried pressure is the law's W_V′(J): q vanishes to double
// round-off although the slope is held in float (s is taken with the rounded slope). The bound: 1e-12
// of W_V″ |F| (≈ 2.6e3 MPa here), far below the float slope's 6e-8.
TEST(FftPressureIteration, LinearizedPressureIsTheLawsAtItsPoint) {
  for (bool store_slopes : {true, false}) {
    detail::CompactTangents compact(8, 0);
    PressureIteration it = one_point_iteration(store_slopes);
    detail::CompactTangents* record = store_slopes ? nullptr : &compact;
    const Mat3 Fk = deformation(1.0);
    Mat3 P = Mat3::Zero();
    it.correct(0, 0, Fk, P, nullptr, record);  // not linearized yet: the law's pressure, q = 0
    it.linearized = true;
    // The compact record holds F in float: evaluate at that F, which is where the slope was taken.
    const Mat3 F = store_slopes ? Fk : compact.F(0);
    P.setZero();
    const double q = it.correct(0, 0, F, P, nullptr, record);
    const detail::VolumetricState vs = detail::volumetric_state(kBulk, F);
    EXPECT_LE(std::abs(q), 1e-12 * vs.ddU * F.norm()) << "store_slopes " << store_slopes;
    EXPECT_NEAR(it.p_trial[0], vs.dU, 1e-6 * std::abs(vs.dU) + 1e-9);
  }
}

// Away from its point the pressure follows the linearized constraint p = W_V′(J_k) + W_V″(J_k) cof F_k :
// (F − F_k) (the slope in float: 1e-6 relative), and P̂ = P + q cof F.
TEST(FftPressureIteration, PressureFollowsTheLinearizedConstraint) {
  const Mat3 Fk = deformation(1.0), F = deformation(1.3);
  PressureIteration it = linearized_at(Fk);
  Mat3 P = Mat3::Zero();
  const double q = it.correct(0, 0, F, P, nullptr, nullptr);
  const detail::VolumetricState vk = detail::volumetric_state(kBulk, Fk), v = detail::volumetric_state(kBulk, F);
  const double p_expected = vk.dU + vk.ddU * ddot(vk.cof, F - Fk);
  EXPECT_NEAR(q + v.dU, p_expected, 1e-6 * vk.ddU * (F - Fk).norm());
  EXPECT_NEAR((P - q * v.cof).norm(), 0.0, 1e-12 * std::abs(q) * v.cof.norm());
  EXPECT_NEAR(it.dP_ratio[0], -q / v.ddU, 1e-6 * std::abs(q / v.ddU));
}

// The tangent's geometric term q ∂cof F/∂F against central differences of q cof F at fixed q
// (step 1e-6: truncation ~1e-12 of cof's second derivative, round-off ~1e-10; bound 1e-7 of |q|).
TEST(FftPressureIteration, GeometricTangentIsTheCofactorDerivative) {
  const Mat3 F = deformation(1.5);
  PressureIteration it = linearized_at(deformation(1.0));
  Mat9 A = Mat9::Zero();
  Mat3 P = Mat3::Zero();
  const double q = it.correct(0, 0, F, P, &A, nullptr);
  ASSERT_GT(std::abs(q), 0.1);
  const auto cof = [](const Mat3& G) { return Mat3(G.determinant() * G.inverse().transpose()); };
  const double h = 1e-6;
  for (int c = 0; c < 9; ++c) {
    Mat3 E = Mat3::Zero();
    E(c / 3, c % 3) = h;
    const Mat3 d = q * (cof(F + E) - cof(F - E)) / (2.0 * h);
    for (int r = 0; r < 9; ++r) EXPECT_NEAR(A(r, c), d(r / 3, r % 3), 1e-7 * std::abs(q)) << r << ", " << c;
  }
}

// Commit: the committed pressure and its increment; the extrapolated predictor then places
// p = p_committed + ratio · Δp whatever F is (the increment in float: 1e-6 relative).
TEST(FftPressureIteration, CommitAndPredictorExtrapolateThePressure) {
  PressureIteration it = one_point_iteration(true);
  Mat3 P = Mat3::Zero();
  it.correct(0, 0, deformation(1.0), P, nullptr, nullptr);
  it.commit(false);
  const double p0 = it.p_committed[0];
  EXPECT_EQ(it.dp_last[0], 0.0f);
  it.correct(0, 0, deformation(1.1), P, nullptr, nullptr);
  it.commit(true);
  const double p1 = it.p_committed[0], dp = p1 - p0;
  ASSERT_GT(std::abs(dp), 1.0);
  EXPECT_NEAR(it.dp_last[0], dp, 1e-6 * std::abs(dp));
  it.predictor_ratio = 0.5;
  const Mat3 F = deformation(1.4);
  const double q = it.correct(0, 0, F, P, nullptr, nullptr);
  EXPECT_NEAR(q + detail::volumetric_state(kBulk, F).dU, p1 + 0.5 * dp, 1e-6 * (std::abs(p1) + std::abs(dp)));
}

}  // namespace
}  // namespace softhom::rve
