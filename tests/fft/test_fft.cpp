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

// Section plans that transform only the i1/i2 columns give the same spectra as the full plan on
// those fields and leave the i3 columns alone (the solver's 6-of-9-field transforms).
TEST(FftPlan, ColumnSubsetMatchesFullPlan) {
  const Grid g{{8, 6, 1}, {1.0, 1.0, 0.2}};
  const int fields = 18;  // two 3×3 tensors (two quadrature points)
  BatchedFFT full(g, fields, {PlanRigor::estimate, 1, {}}), part(g, fields, {PlanRigor::estimate, 1, {}}, 2);
  EXPECT_EQ(part.transformed_fields(), 12);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> U(-1, 1);
  for (std::size_t i = 0; i < fields * g.voxels(); ++i) full.real(0)[i] = part.real(0)[i] = U(rng);
  for (std::size_t i = 0; i < fields * g.modes(); ++i) part.spectrum(0)[i] = Complex(7.0, -7.0);  // marker
  full.forward();
  part.forward();
  for (int f = 0; f < fields; ++f)
    for (std::size_t k = 0; k < g.modes(); ++k) {
      if (f % 3 < 2)
        EXPECT_NEAR(std::abs(part.spectrum(f)[k] - full.spectrum(f)[k]), 0.0, 1e-13) << f;
      else
        EXPECT_EQ(part.spectrum(f)[k], Complex(7.0, -7.0)) << f;  // untouched
    }
  for (std::size_t i = 0; i < fields * g.voxels(); ++i) part.real(0)[i] = -1.0;
  part.backward();
  for (int f = 0; f < fields; ++f)
    for (std::size_t v = 0; v < g.voxels(); ++v)
      if (f % 3 < 2)  // c2r of the r2c spectrum: voxels() times the field
        EXPECT_NEAR(part.real(f)[v], double(g.voxels()) * full.real(f)[v], 1e-12) << f;
      else
        EXPECT_EQ(part.real(f)[v], -1.0);
  EXPECT_THROW(BatchedFFT(g, 4, {PlanRigor::estimate, 1, {}}, 2), std::invalid_argument);
}

// The tabulated Green operator and the fused CG kernels equal the plain operators they replace
// (round-off only), on a 3D grid and on a section, for every discretization.
TEST(Gradient, TabulatedGreenAndFusedKernelsMatchPlainOperators) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> U(-1, 1);
  Matrix9 C0 = Matrix9::Zero();
  {
    Eigen::Matrix<double, 9, 9> B;
    for (int a = 0; a < 9; ++a)
      for (int b = 0; b < 9; ++b) B(a, b) = U(rng);
    C0 = B * B.transpose() + 9.0 * Matrix9::Identity();  // symmetric positive definite, anisotropic
  }
  for (const Grid& g : {Grid{{6, 4, 5}, {1.0, 1.0, 1.2}}, Grid{{8, 6, 1}, {1.0, 0.8, 0.1}}})
    for (Discretization d : {Discretization::spectral, Discretization::rotated, Discretization::hex}) {
      GradientOperator op(g, d);
      const int nq = op.points(), nc = op.columns();
      EXPECT_EQ(nc, g.is_section() ? 2 : 3);
      const std::size_t nm = g.modes();
      auto random_spectrum = [&](std::size_t n) {
        std::vector<Complex> x(n);
        for (auto& c : x) c = Complex(U(rng), U(rng));
        return x;
      };
      auto wdot = [&](const std::vector<Complex>& a, const std::vector<Complex>& b) {
        double s = 0.0;
        for (int i = 0; i < 3; ++i)
          for (std::size_t k = 0; k < nm; ++k) s += g.mode_weight(k) * std::real(std::conj(a[i * nm + k]) * b[i * nm + k]);
        return s;
      };
      const auto r = random_spectrum(3 * nm);
      std::vector<Complex> ref(3 * nm), z(3 * nm);
      op.solve_reference(C0, r.data(), ref.data());
      ReferenceGreen green(op);
      green.set(C0);
      const double rz = green.apply_dot(r.data(), z.data(), 2.0);
      for (std::size_t i = 0; i < z.size(); ++i) EXPECT_NEAR(std::abs(2.0 * z[i] - ref[i]), 0.0, 1e-12 * (1.0 + std::abs(ref[i])));
      EXPECT_NEAR(rz, wdot(r, z), 1e-12 * std::abs(rz));

      // p ← z + β p and ∇p in one pass.
      auto p = random_spectrum(3 * nm);
      const auto p0 = p;
      std::vector<Complex> grad(9 * nq * nm, 0.0), grad_ref(9 * nq * nm, 0.0);
      op.gradient_of_update(z.data(), 0.5, p.data(), grad.data());
      std::vector<Complex> p_ref(3 * nm);
      for (std::size_t i = 0; i < p.size(); ++i) p_ref[i] = z[i] + 0.5 * p0[i];
      op.gradient(p_ref.data(), grad_ref.data());
      for (std::size_t i = 0; i < p.size(); ++i) EXPECT_EQ(p[i], p_ref[i]);
      for (int f = 0; f < 9 * nq; ++f)
        for (std::size_t k = 0; k < nm; ++k)
          if (f % 3 < nc) {
            EXPECT_NEAR(std::abs(grad[f * nm + k] - grad_ref[f * nm + k]), 0.0, 1e-12);
          }
      // Div with ⟨p, Div s⟩.
      const auto s = random_spectrum(9 * nq * nm);
      std::vector<Complex> div(3 * nm), div_ref(3 * nm);
      op.divergence(s.data(), div_ref.data(), 0.25);
      const double pd = op.divergence_dot(s.data(), div.data(), 0.25, p.data());
      for (std::size_t i = 0; i < div.size(); ++i) EXPECT_EQ(div[i], div_ref[i]);
      EXPECT_NEAR(pd, wdot(p, div_ref), 1e-12 * (1.0 + std::abs(pd)));
      // x += α p, r −= α Ap, z = G r / scale, ⟨r, z⟩.
      auto x = random_spectrum(3 * nm), rr = r;
      const auto x0 = x, Ap = random_spectrum(3 * nm);
      std::vector<Complex> z2(3 * nm), z_ref(3 * nm);
      const double rz2 = green.cg_update(0.3, p.data(), Ap.data(), x.data(), rr.data(), z2.data(), 1.5);
      std::vector<Complex> r_ref(3 * nm);
      for (std::size_t i = 0; i < r_ref.size(); ++i) {
        r_ref[i] = r[i] - 0.3 * Ap[i];
        EXPECT_NEAR(std::abs(x[i] - (x0[i] + 0.3 * p[i])), 0.0, 1e-15);
        EXPECT_NEAR(std::abs(rr[i] - r_ref[i]), 0.0, 1e-15);
      }
      green.apply(r_ref.data(), z_ref.data(), 1.5);
      for (std::size_t i = 0; i < z2.size(); ++i) EXPECT_NEAR(std::abs(z2[i] - z_ref[i]), 0.0, 1e-14 * (1.0 + std::abs(z_ref[i])));
      EXPECT_NEAR(rz2, wdot(r_ref, z_ref), 1e-12 * std::abs(rz2));
    }
}
