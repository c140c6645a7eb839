// FFT plans and discrete gradients: round trips, exact symbols on trigonometric fields, adjointness.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "softhom/fft/gradient.hpp"
#include "softhom/fft/plan.hpp"

using namespace softhom::fft;

namespace {
constexpr double kTwoPi = 6.283185307179586;

// Real field (one component) → normalised half spectrum via a 1-field plan.
std::vector<Complex> spectrum_of(BatchedFFT& fft, const std::vector<double>& x) {
  std::copy(x.begin(), x.end(), fft.real(0));
  fft.forward();
  const double scale = 1.0 / double(fft.grid().voxels());
  std::vector<Complex> s(fft.spectrum(0), fft.spectrum(0) + fft.grid().modes());
  for (auto& c : s) c *= scale;
  return s;
}
}  // namespace

TEST(FftPlan, RoundTripIsIdentity) {
  Grid g{{6, 5, 4}, {1.0, 2.0, 3.0}};
  BatchedFFT fft(g, 2, {PlanRigor::estimate, 2, {}});
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> U(-1, 1);
  std::vector<double> x(2 * g.voxels());
  for (auto& v : x) v = U(rng);
  std::copy(x.begin(), x.end(), fft.real(0));
  fft.forward();
  for (std::size_t k = 0; k < 2 * g.modes(); ++k) fft.spectrum(0)[k] /= double(g.voxels());
  fft.backward();
  // FFT round-off: a few ulps times log N.
  for (std::size_t i = 0; i < x.size(); ++i) EXPECT_NEAR(fft.real(0)[i], x[i], 1e-14);
}

// u_0 = sin(2π y1/L1) at the nodes (voxel corners for FE schemes, voxel centres for spectral).
// Spectral: ∂1 u0 = (2π/L1) cos exactly at the sample points. Hex/rotated: the centre-point gradient
// of the linear element is the averaged forward difference, which we form directly.
TEST(Gradient, SymbolsMatchDirectDifferences) {
  Grid g{{8, 6, 1}, {2.0, 1.5, 0.25}};
  for (Discretization d : {Discretization::spectral, Discretization::rotated, Discretization::hex}) {
    GradientOperator op(g, d);
    const int nq = op.points();
    EXPECT_EQ(nq, d == Discretization::hex ? 4 : 1);
    BatchedFFT one(g, 1, {PlanRigor::estimate, 1, {}});
    std::vector<double> u(g.voxels());
    auto nodal = [&](int i1, int i2) {
      return std::sin(kTwoPi * i1 / g.n[0]) + 0.5 * std::cos(2 * kTwoPi * i2 / g.n[1]);
    };
    for (int i2 = 0; i2 < g.n[1]; ++i2)
      for (int i1 = 0; i1 < g.n[0]; ++i1) u[i1 + g.n[0] * i2] = nodal(i1, i2);
    std::vector<Complex> uh(3 * g.modes(), 0.0);
    const auto s = spectrum_of(one, u);
    std::copy(s.begin(), s.end(), uh.begin());  // component i = 0
    BatchedFFT grad(g, 9 * nq, {PlanRigor::estimate, 1, {}});
    op.gradient(uh.data(), grad.spectrum(0));
    grad.backward();
    const double h1 = g.spacing(0), h2 = g.spacing(1);
    for (int q = 0; q < nq; ++q) {
      const auto xi = op.quadrature()[q].xi;
      for (int i2 = 0; i2 < g.n[1]; ++i2)
        for (int i1 = 0; i1 < g.n[0]; ++i1) {
          const std::size_t v = i1 + g.n[0] * i2;
          double d1, d2;
          if (d == Discretization::spectral) {
            d1 = kTwoPi / g.size[0] * std::cos(kTwoPi * i1 / g.n[0]);
            d2 = -0.5 * 2 * kTwoPi / g.size[1] * std::sin(2 * kTwoPi * i2 / g.n[1]);
          } else {
            const int j1 = (i1 + 1) % g.n[0], j2 = (i2 + 1) % g.n[1];
            d1 = ((1 - xi[1]) * (nodal(j1, i2) - nodal(i1, i2)) + xi[1] * (nodal(j1, j2) - nodal(i1, j2))) / h1;
            d2 = ((1 - xi[0]) * (nodal(i1, j2) - nodal(i1, i2)) + xi[0] * (nodal(j1, j2) - nodal(j1, i2))) / h2;
          }
          // Round-off of FFTs on O(10) values.
          EXPECT_NEAR(grad.real(9 * q + 0)[v], d1, 1e-12) << to_string(d) << " q" << q;
          EXPECT_NEAR(grad.real(9 * q + 1)[v], d2, 1e-12) << to_string(d) << " q" << q;
          EXPECT_NEAR(grad.real(9 * q + 2)[v], 0.0, 1e-12);  // section: no variation along y3
          EXPECT_NEAR(grad.real(9 * q + 3)[v], 0.0, 1e-12);  // u1 = u2 = 0
        }
    }
  }
}

// ⟨∇u, s⟩ = ⟨u, div s⟩ in the weighted half-spectrum inner product (what makes the Newton operator
// symmetric for CG), and the reference solve inverts K0 on non-kernel modes.
TEST(Gradient, DivergenceIsAdjointAndReferenceSolveInverts) {
  Grid g{{6, 4, 5}, {1.0, 1.0, 1.2}};
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> U(-1, 1);
  for (Discretization d : {Discretization::spectral, Discretization::rotated, Discretization::hex}) {
    GradientOperator op(g, d);
    const int nq = op.points();
    const std::size_t nm = g.modes();
    BatchedFFT f3(g, 3, {PlanRigor::estimate, 1, {}}), fs(g, 9 * nq, {PlanRigor::estimate, 1, {}});
    for (std::size_t i = 0; i < 3 * g.voxels(); ++i) f3.real(0)[i] = U(rng);
    for (std::size_t i = 0; i < 9 * nq * g.voxels(); ++i) fs.real(0)[i] = U(rng);
    f3.forward();
    fs.forward();
    std::vector<Complex> u(f3.spectrum(0), f3.spectrum(0) + 3 * nm), s(fs.spectrum(0), fs.spectrum(0) + 9 * nq * nm);
    std::vector<Complex> gu(9 * nq * nm), ds(3 * nm);
    op.gradient(u.data(), gu.data());
    op.divergence(s.data(), ds.data(), 1.0);
    double lhs = 0.0, rhs = 0.0;
    for (int q = 0; q < nq; ++q)
      for (int c = 0; c < 9; ++c)
        for (std::size_t k = 0; k < nm; ++k)
          lhs += op.quadrature()[q].weight * g.mode_weight(k) *
                 std::real(std::conj(gu[(9 * q + c) * nm + k]) * s[(9 * q + c) * nm + k]);
    for (int i = 0; i < 3; ++i)
      for (std::size_t k = 0; k < nm; ++k) rhs += g.mode_weight(k) * std::real(std::conj(u[i * nm + k]) * ds[i * nm + k]);
    EXPECT_NEAR(lhs, rhs, 1e-10 * std::abs(lhs)) << to_string(d);

    // Isotropic C0: K0⁻¹ (div C0 ∇ u) = u on every mode outside the kernel.
    Matrix9 C0 = Matrix9::Zero();
    const double lam = 2.0, mu = 0.7;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        C0(3 * i + i, 3 * j + j) += lam;
        C0(3 * i + j, 3 * i + j) += mu;
        C0(3 * i + j, 3 * j + i) += mu;
      }
    std::vector<Complex> cgu(gu.size());
    for (int q = 0; q < nq; ++q)
      for (std::size_t k = 0; k < nm; ++k)
        for (int a = 0; a < 9; ++a) {
          Complex acc = 0.0;
          for (int b = 0; b < 9; ++b) acc += C0(a, b) * gu[(9 * q + b) * nm + k];
          cgu[(9 * q + a) * nm + k] = acc;
        }
    std::vector<Complex> r(3 * nm), back(3 * nm);
    op.divergence(cgu.data(), r.data(), 1.0);
    op.solve_reference(C0, r.data(), back.data());
    for (std::size_t k = 0; k < nm; ++k) {
      if (op.laplacian(k) < 1e-12) continue;  // kernel (k = 0, hourglass modes of the rotated scheme)
      for (int i = 0; i < 3; ++i) EXPECT_NEAR(std::abs(back[i * nm + k] - u[i * nm + k]), 0.0, 1e-9) << to_string(d);
    }
  }
}
