#pragma once
// Shared verification helpers for the material tests: central-difference tangents and energy
// gradients, a relative-norm comparison that prints both matrices on failure (the idea of muSpectre's
// MaterialEvaluator), and random deformation gradients.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <random>
#include <sstream>
#include <string>

#include <Eigen/Geometry>

#include "softhom/materials/hyperelastic.hpp"
#include "softhom/materials/material.hpp"

namespace softhom::test {

/// Central-difference step for a tangent: h = 1e-6 ‖F‖. Truncation error O(h² P''') ≈ 1e-12 relative,
/// rounding error ≈ ε ‖P‖ / h ≈ 1e-10 relative: both far below the 1e-6 tolerance of the checks.
inline double fd_step(const Mat3& F) { return 1e-6 * F.norm(); }

/// Central-difference ∂P/∂F of a stress function, column 3k+L = (P(F + h e_kL) − P(F − h e_kL)) / 2h.
/// `ok` becomes false if any perturbed evaluation fails.
inline Mat9 fd_tangent(const std::function<bool(const Mat3&, Mat3&)>& stress, const Mat3& F, double h,
                       bool& ok) {
  Mat9 A;
  ok = true;
  for (int k = 0; k < 3; ++k)
    for (int L = 0; L < 3; ++L) {
      Mat3 Fp = F, Fm = F, Pp, Pm;
      Fp(k, L) += h;
      Fm(k, L) -= h;
      ok = stress(Fp, Pp) && ok;
      ok = stress(Fm, Pm) && ok;
      A.col(voigt9(k, L)) = flatten(Pp - Pm) / (2.0 * h);
    }
  return A;
}

/// FD tangent of a Material at fixed (state_old, dt): the algorithmic tangent of one step. `h` = 0
/// selects fd_step(F). With `richardson`, (4 D(h/2) − D(h))/3: truncation O(h⁴) instead of O(h²), for
/// strongly curved responses (near the Gent limit).
inline Mat9 fd_tangent(const Material& m, const Mat3& F, const double* state_old, double dt, bool& ok,
                       double h = 0.0, bool richardson = false) {
  std::vector<double> scratch(std::size_t(m.state_size()) + 1);
  const auto stress = [&](const Mat3& G, Mat3& P) {
    return m.evaluate(G, state_old, scratch.data(), dt, P, nullptr) == MaterialStatus::ok;
  };
  if (!(h > 0.0)) h = fd_step(F);
  if (!richardson) return fd_tangent(stress, F, h, ok);
  bool ok2 = true;
  const Mat9 coarse = fd_tangent(stress, F, h, ok), fine = fd_tangent(stress, F, 0.5 * h, ok2);
  ok = ok && ok2;
  return (4.0 * fine - coarse) / 3.0;
}

/// Central-difference ∂W/∂F of an elastic law's energy (the first Piola stress of a hyperelastic law).
/// Default h = 1e-6 ‖F‖: the truncation error h² W‴/6 must stay small against G although W‴ ~ K
/// (1e-12 K ≈ 1e-7 G for K/G = 1e5); the rounding error ε W / h ≈ 1e-10 W is small against |P| ~ W/|F|.
/// `h` = 0 selects that default.
inline Mat3 fd_energy_gradient(const ElasticLaw& law, const Mat3& F, double h = 0.0, bool richardson = false) {
  if (!(h > 0.0)) h = 1e-6 * F.norm();
  if (richardson) return (4.0 * fd_energy_gradient(law, F, 0.5 * h) - fd_energy_gradient(law, F, h)) / 3.0;
  Mat3 P;
  for (int k = 0; k < 3; ++k)
    for (int L = 0; L < 3; ++L) {
      Mat3 Fp = F, Fm = F;
      Fp(k, L) += h;
      Fm(k, L) -= h;
      const double Wp = law.energy(Fp.transpose() * Fp, Fp.determinant());
      const double Wm = law.energy(Fm.transpose() * Fm, Fm.determinant());
      P(k, L) = (Wp - Wm) / (2.0 * h);
    }
  return P;
}

/// ‖A − B‖_F / max(‖A‖_F, floor): relative to the analytic A, or to `floor` (a natural scale of the
/// quantity, e.g. G for a stress) where A itself vanishes (the reference state).
template <class MatA, class MatB>
double relative_error(const MatA& A, const MatB& B, double floor = 0.0) {
  const double n = std::max(A.norm(), floor);
  return n > 0.0 ? (A - B).norm() / n : (A - B).norm();
}

/// GoogleTest predicate: relative_error(analytic, reference, floor) ≤ tol, printing both matrices and
/// their difference on failure. `worst` (optional) accumulates the largest error seen.
template <class MatA, class MatB>
::testing::AssertionResult matrices_close(const MatA& analytic, const MatB& reference, double tol,
                                          const std::string& what, double* worst = nullptr,
                                          double floor = 0.0) {
  const double e = relative_error(analytic, reference, floor);
  if (worst && (e > *worst || !std::isfinite(e))) *worst = e;
  if (e <= tol) return ::testing::AssertionSuccess();
  std::ostringstream s;
  const Eigen::IOFormat fmt(6, 0, " ", "\n", "  [", "]");
  s << what << ": relative error " << e << " > " << tol << "\nanalytic:\n"
    << analytic.format(fmt) << "\nreference (finite differences):\n"
    << reference.format(fmt) << "\ndifference:\n"
    << (analytic - reference).format(fmt);
  return ::testing::AssertionFailure() << s.str();
}

inline std::string matrix_string(const Mat3& F) {
  std::ostringstream s;
  s.precision(17);
  s << "F = [" << F.row(0) << "; " << F.row(1) << "; " << F.row(2) << "]";
  return s.str();
}

/// Uniformly distributed rotation (normalised Gaussian quaternion).
inline Mat3 random_rotation(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::Quaterniond q(n(rng), n(rng), n(rng), n(rng));
  q.normalize();
  return q.toRotationMatrix();
}

/// F = R1 diag(λ) R2 with isochoric stretches λ_i = exp(e_i), e_i uniform in ±spread (then made
/// isochoric), scaled to det F = J.
inline Mat3 random_F(std::mt19937& rng, double J, double spread) {
  std::uniform_real_distribution<double> u(-spread, spread);
  Vec3 e(u(rng), u(rng), u(rng));
  e.array() -= e.mean();
  const Vec3 lambda = e.array().exp() * std::cbrt(J);
  return random_rotation(rng) * lambda.asDiagonal() * random_rotation(rng);
}

/// Uniformly distributed J in [0.7, 1.5], the range the requirements ask to cover.
inline double random_J(std::mt19937& rng) { return std::uniform_real_distribution<double>(0.7, 1.5)(rng); }

}  // namespace softhom::test
