// Block form of the Fourier gradient and divergence (GradientOperator::gradient_block, divergence_block),
// through which the FFT solver with the stencil Krylov operator transforms ∇ũ and P 3 fields at a time,
// and the float table of the reference Green operator (ReferenceGreen::use_single_precision).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "softhom/fft/field_buffer.hpp"
#include "fft/fft_test_helpers.hpp"
#include "softhom/fft/gradient.hpp"

using namespace softhom::fft;

namespace {

using softhom::fft::testing::random_spectrum;

}  // namespace

// The blocks (point q, row i) assemble gradient() and divergence(): the gradient to the bit (the same
// products), the divergence to round-off of the regrouped sum over points, to the bit for one point.
TEST(GradientBlocks, AssembleGradientAndDivergence) {
  std::mt19937 rng(7);
  for (const Grid& g : {Grid{{6, 4, 5}, {1.0, 1.0, 1.2}}, Grid{{8, 6, 1}, {1.0, 0.8, 0.1}}})
    for (Discretization d : {Discretization::spectral, Discretization::rotated, Discretization::hex}) {
      const GradientOperator op(g, d);
      const int nq = op.points(), nc = op.columns();
      const std::size_t nm = g.modes();
      const auto u = random_spectrum(3 * nm, rng);
      std::vector<Complex> grad(9 * nq * nm, 0.0), block(3 * nm, 0.0);
      op.gradient(u.data(), grad.data(), false);
      for (int q = 0; q < nq; ++q)
        for (int i = 0; i < 3; ++i) {
          op.gradient_block(u.data() + i * nm, q, block.data());
          for (int j = 0; j < nc; ++j)
            for (std::size_t k = 0; k < nm; ++k)
              EXPECT_EQ(block[j * nm + k], grad[(9 * q + 3 * i + j) * nm + k]) << to_string(d);
        }
      const auto s = random_spectrum(9 * nq * nm, rng);
      std::vector<Complex> div(3 * nm), div_blocks(3 * nm);
      op.divergence(s.data(), div.data(), 0.25);
      for (int q = 0; q < nq; ++q)
        for (int i = 0; i < 3; ++i)
          op.divergence_block(s.data() + (9 * q + 3 * i) * nm, q, div_blocks.data() + i * nm, 0.25, q > 0);
      for (std::size_t a = 0; a < div.size(); ++a) {
        if (nq == 1)
          EXPECT_EQ(div_blocks[a], div[a]) << to_string(d);
        else  // ≤ 24 terms of O(|D| ≤ 4/h) regrouped: a few ulps of the sum
          EXPECT_NEAR(std::abs(div_blocks[a] - div[a]), 0.0, 1e-13 * (1.0 + std::abs(div[a]))) << to_string(d);
      }
    }
}

// The float table is the double one rounded: z agrees to the float rounding of the 6 entries (relative
// 6e-8 each, ≤ 3 terms per component: 5e-7 of |G| |r| with margin), and ⟨r, z⟩ stays positive
// (a positive definite preconditioner) for a reference medium with K/G = 1e4 (above the ecoflex mean
// tangent's ≈ 2e3).
TEST(GradientBlocks, FloatGreenTableIsTheRoundedDoubleTable) {
  std::mt19937 rng(11);
  const double mu = 1.0, lambda = 1e4;
  Matrix9 C0 = Matrix9::Zero();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      C0(3 * i + i, 3 * j + j) += lambda;
      C0(3 * i + j, 3 * i + j) += mu;
      C0(3 * i + j, 3 * j + i) += mu;
    }
  const Grid g{{8, 6, 4}, {1.0, 1.0, 1.0}};
  for (Discretization d : {Discretization::rotated, Discretization::hex}) {
    const GradientOperator op(g, d);
    const std::size_t nm = g.modes();
    ReferenceGreen gd(op), gf(op);
    gf.use_single_precision(true);
    gd.set(C0);
    gf.set(C0);
    EXPECT_EQ(2 * gf.memory_bytes(), gd.memory_bytes());
    const auto r = random_spectrum(3 * nm, rng);
    std::vector<Complex> zd(3 * nm), zf(3 * nm);
    gd.apply(r.data(), zd.data());
    const double rz = gf.apply_dot(r.data(), zf.data());
    EXPECT_GT(rz, 0.0);
    double zmax = 0.0;
    for (const Complex& z : zd) zmax = std::max(zmax, std::abs(z));
    for (std::size_t a = 0; a < zd.size(); ++a) EXPECT_NEAR(std::abs(zf[a] - zd[a]), 0.0, 5e-7 * zmax) << to_string(d);
  }
}

// Real fields only: the FieldTransform layout, no transform.
TEST(GradientBlocks, FieldBufferHasNoTransform) {
  FieldBuffer b(9, 10, 5);
  EXPECT_EQ(b.fields(), 9);
  EXPECT_EQ(b.transformed_fields(), 0);
  EXPECT_EQ(b.real(3) - b.real(0), 30);
  EXPECT_EQ(b.real(8)[9 + 5], 0.0);  // the spare values after the fields exist and are zeroed
  EXPECT_THROW(b.forward(), std::logic_error);
  EXPECT_THROW(b.backward(), std::logic_error);
}
