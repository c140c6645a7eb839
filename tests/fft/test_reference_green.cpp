// The tabulated reference Green operator (ReferenceGreen) holds the 6 reals of a real symmetric K0(k)⁻¹
// per mode: K0 is real for every discretization (spectral, rotated, hex), and the table gives
// GradientOperator::solve_reference's complex Hermitian K0⁻¹ to round-off.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>

#include "fft/fft_test_helpers.hpp"
#include "softhom/fft/gradient.hpp"

using namespace softhom::fft;

namespace {

using softhom::fft::testing::random_spectrum;

/// Major-symmetric positive definite and anisotropic: every entry of K0 non-zero in general.
Matrix9 anisotropic_C0(std::mt19937& rng) {
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  Matrix9 B;
  for (int a = 0; a < 9; ++a)
    for (int b = 0; b < 9; ++b) B(a, b) = U(rng);
  return B * B.transpose() + 9.0 * Matrix9::Identity();
}

/// K0_ik = Σ_q w_q Σ_jl conj(D_qj) C0_(3i+j)(3k+l) D_ql at one mode, in complex arithmetic (the
/// Hermitian form, as solve_reference() builds it), summed over the first `points` points (all by default).
Eigen::Matrix3cd complex_reference_stiffness(const GradientOperator& op, const Matrix9& C0, std::size_t mode,
                                             int points = -1) {
  Complex D[24];
  op.coefficients(mode, D);
  Eigen::Matrix3cd K0 = Eigen::Matrix3cd::Zero();
  for (int q = 0; q < (points < 0 ? op.points() : points); ++q)
    for (int i = 0; i < 3; ++i)
      for (int k = 0; k < 3; ++k)
        for (int j = 0; j < 3; ++j)
          for (int l = 0; l < 3; ++l)
            K0(i, k) += op.quadrature()[q].weight * std::conj(D[3 * q + j]) * C0(3 * i + j, 3 * k + l) * D[3 * q + l];
  return K0;
}

const Grid kGrids[] = {
    Grid{{8, 6, 1}, {1.0, 0.8, 0.1}},   // section, even sizes (Nyquist planes, hourglass modes)
    Grid{{7, 5, 1}, {1.0, 1.3, 0.1}},   // section, odd sizes
    Grid{{6, 4, 5}, {1.0, 1.0, 1.2}},   // 3D, mixed parities
    Grid{{5, 7, 3}, {1.1, 0.9, 1.0}},   // 3D, odd sizes
};

}  // namespace

// The claim behind the 6-value table: M_jl = Σ_q w_q conj(D_qj) D_ql is real, so K0 built the complex
// way (as solve_reference() builds it) has a zero imaginary part. Spectral: exactly (D_j = i ξ_j).
// Rotated: one point whose D_j share a phase, round-off of the products of e^{ikh} (a few ulps of
// |K0|). Hex: the same round-off, though one Gauss point's products alone are complex (O(1) of their
// modulus, a few % of |K0| on some modes): the imaginary parts cancel between the points ξ and 1 − ξ.
TEST(ReferenceGreen, ReferenceStiffnessIsReal) {
  std::mt19937 rng(5);
  const Matrix9 C0 = anisotropic_C0(rng);
  for (const Grid& g : kGrids)
    for (Discretization d : {Discretization::spectral, Discretization::rotated, Discretization::hex}) {
      const GradientOperator op(g, d);
      double worst = 0.0;        // max over modes of max |Im K0_ik| / max |K0_ik|
      double worst_point = 0.0;  // the same for the first point's share of K0 alone
      for (std::size_t k = 0; k < g.modes(); ++k) {
        const Eigen::Matrix3cd K0 = complex_reference_stiffness(op, C0, k);
        const double scale = K0.cwiseAbs().maxCoeff();
        if (scale > 0.0) worst = std::max(worst, K0.imag().cwiseAbs().maxCoeff() / scale);
        const Eigen::Matrix3cd K0_point = complex_reference_stiffness(op, C0, k, 1);
        const double point_scale = K0_point.cwiseAbs().maxCoeff();
        if (point_scale > 0.0) worst_point = std::max(worst_point, K0_point.imag().cwiseAbs().maxCoeff() / point_scale);
      }
      const std::string where = std::string(to_string(d)) + " " + std::to_string(g.n[0]) + "x" +
                                std::to_string(g.n[1]) + "x" + std::to_string(g.n[2]);
      if (d == Discretization::spectral)
        EXPECT_EQ(worst, 0.0) << where;
      else
        EXPECT_LT(worst, 1e-14) << where;
      if (d == Discretization::hex) {
        EXPECT_GT(worst_point, 1e-2) << where;  // real only as a sum over points
      }
      std::printf("[ info     ] %s: max |Im K0| / |K0| %.1e (first point alone %.1e)\n", where.c_str(), worst, worst_point);
    }
}

// The 6-value table gives solve_reference()'s K0⁻¹ r to round-off: relative 1e-13 per mode in the
// 3-vector norm (the real inverse drops imaginary parts of a few ulps of |K0|, amplified by the
// condition number of K0, ≈ 10 for this C0), on sections and 3D grids with odd sizes, and the kernel
// modes stay exactly 0; 6 values per mode in double and float, and the fused kernels read the same
// table as apply().
TEST(ReferenceGreen, RealSymmetricTableMatchesSolveReference) {
  std::mt19937 rng(9);
  const Matrix9 C0 = anisotropic_C0(rng);
  for (const Grid& g : kGrids)
    for (Discretization d : {Discretization::spectral, Discretization::rotated, Discretization::hex}) {
      const GradientOperator op(g, d);
      const std::size_t nm = g.modes();
      ReferenceGreen green(op), green_f(op);
      green_f.use_single_precision(true);
      green.set(C0);
      green_f.set(C0);
      EXPECT_EQ(green.memory_bytes(), 6 * sizeof(double) * nm);
      EXPECT_EQ(green_f.memory_bytes(), 6 * sizeof(float) * nm);

      const auto r = random_spectrum(3 * nm, rng);
      std::vector<Complex> ref(3 * nm), z(3 * nm);
      op.solve_reference(C0, r.data(), ref.data());
      green.apply(r.data(), z.data());
      int kernel_modes = 0;
      double worst = 0.0;
      for (std::size_t k = 0; k < nm; ++k) {
        double dz = 0.0, zr = 0.0;
        for (int i = 0; i < 3; ++i) {
          dz += std::norm(z[i * nm + k] - ref[i * nm + k]);
          zr += std::norm(ref[i * nm + k]);
        }
        if (zr == 0.0) {
          ++kernel_modes;
          EXPECT_EQ(dz, 0.0);  // the zero mode and the rotated scheme's hourglass modes stay exactly 0
        } else {
          EXPECT_LE(std::sqrt(dz), 1e-13 * std::sqrt(zr)) << to_string(d) << " mode " << k;
          worst = std::max(worst, std::sqrt(dz / zr));
        }
      }
      EXPECT_GE(kernel_modes, 1);  // at least k = 0
      std::printf("[ info     ] %s %dx%dx%d: max |z - z_ref| / |z_ref| per mode %.1e\n", to_string(d), g.n[0], g.n[1],
                  g.n[2], worst);

      // apply_dot, direction_update and cg_update read the same table.
      std::vector<Complex> z2(3 * nm), p = random_spectrum(3 * nm, rng), copy(3 * nm);
      const auto p0 = p;
      const double rz = green.apply_dot(r.data(), z2.data(), 2.0);
      double rz_ref = 0.0;
      for (int i = 0; i < 3; ++i)
        for (std::size_t k = 0; k < nm; ++k)
          rz_ref += g.mode_weight(k) * std::real(std::conj(r[i * nm + k]) * (0.5 * z[i * nm + k]));
      EXPECT_NEAR(rz, rz_ref, 1e-13 * std::abs(rz_ref));
      green.direction_update(r.data(), 0.5, p.data(), copy.data(), 2.0);
      // Same products as apply(), in the same order (an ulp of slack for contracted multiply-adds).
      for (std::size_t a = 0; a < z.size(); ++a) {
        EXPECT_NEAR(std::abs(z2[a] - 0.5 * z[a]), 0.0, 4e-16 * std::abs(z[a]));
        EXPECT_NEAR(std::abs(p[a] - (0.5 * z[a] + 0.5 * p0[a])), 0.0, 4e-16 * (std::abs(z[a]) + std::abs(p0[a])));
        EXPECT_EQ(copy[a], p[a]);
      }
      auto x = random_spectrum(3 * nm, rng), rr = random_spectrum(3 * nm, rng);
      const auto Ap = random_spectrum(3 * nm, rng), rr0 = rr;
      std::vector<Complex> z3(3 * nm), z3_ref(3 * nm), r_after(3 * nm);
      green.cg_update(0.25, p.data(), Ap.data(), x.data(), rr.data(), z3.data());
      for (std::size_t a = 0; a < rr.size(); ++a) r_after[a] = rr0[a] - 0.25 * Ap[a];
      green.apply(r_after.data(), z3_ref.data());
      for (std::size_t a = 0; a < z3.size(); ++a) EXPECT_NEAR(std::abs(z3[a] - z3_ref[a]), 0.0, 4e-16 * std::abs(z3_ref[a]));

      // Float table: the double one rounded (6e-8 per entry, ≤ 3 terms per component; K0⁻¹ of this
      // C0 is well conditioned).
      std::vector<Complex> zf(3 * nm);
      green_f.apply(r.data(), zf.data());
      double zmax = 0.0;
      for (const Complex& c : z) zmax = std::max(zmax, std::abs(c));
      for (std::size_t a = 0; a < z.size(); ++a) EXPECT_NEAR(std::abs(zf[a] - z[a]), 0.0, 5e-7 * zmax) << to_string(d);
    }
}
