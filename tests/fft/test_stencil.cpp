// Real-space stencil operator (stencil.hpp) against the Fourier operators it replaces in the Krylov loop.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "softhom/fft/gradient.hpp"
#include "softhom/fft/plan.hpp"
#include "softhom/fft/stencil.hpp"

using namespace softhom::fft;

namespace {

// Symmetric 9×9 "tangent" per point, packed as the solver does (upper triangle, row by row).
void sym_product(const double* S, const double* x, double* y) {
  for (int a = 0; a < 9; ++a) y[a] = 0.0;
  int idx = 0;
  for (int a = 0; a < 9; ++a) {
    y[a] += S[idx++] * x[a];
    for (int b = a + 1; b < 9; ++b, ++idx) {
      y[a] += S[idx] * x[b];
      y[b] += S[idx] * x[a];
    }
  }
}

double max_abs(const std::vector<Complex>& x) {
  double m = 0.0;
  for (const auto& c : x) m = std::max(m, std::abs(c));
  return m;
}

}  // namespace

// K x = Dᴴ A (F̄ + D x) through the Fourier path (gradient per mode, 9·nq-field FFTs, divergence per
// mode) and through the stencil path (3 fields back, gradient/tangent/nodal forces in real space, 3
// fields forward) on a random real displacement and random tangents: equal to round-off, and so are
// the ⟨x, Kx⟩ products (Parseval on the real fields) and the gradients themselves. Even grids exercise
// the Nyquist modes, odd ones the plain half spectrum; sections and 3D; rotated and hex.
TEST(StencilGradient, KrylovOperatorEqualsFourierOperator) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> U(-1, 1);
  for (const Grid& g : {Grid{{8, 6, 1}, {1.0, 0.8, 0.1}}, Grid{{7, 5, 1}, {1.3, 1.0, 0.2}},
                        Grid{{6, 4, 5}, {1.0, 1.0, 1.2}}, Grid{{5, 6, 3}, {0.7, 1.0, 0.9}},
                        // n1 ≥ 8: the rotated gradient's SIMD path along i1 (batches inside a row, the
                        // periodic wrap of the last batch; n1 = 12, 19: batches across rows, scalar path)
                        Grid{{16, 6, 1}, {1.0, 0.8, 0.1}}, Grid{{12, 5, 1}, {1.1, 0.9, 0.1}},
                        Grid{{16, 4, 3}, {1.0, 0.5, 0.6}}, Grid{{19, 3, 4}, {1.2, 0.4, 0.5}}})
    for (Discretization d : {Discretization::rotated, Discretization::hex}) {
      const std::string label = std::string(to_string(d)) + " " + std::to_string(g.n[0]) + "x" +
                                std::to_string(g.n[1]) + "x" + std::to_string(g.n[2]);
      GradientOperator op(g, d);
      ASSERT_TRUE(StencilGradient::supported(op));
      StencilGradient st(op);
      const int nq = op.points(), nc = op.columns();
      const std::size_t N = g.voxels(), nm = g.modes(), NP = N * nq;
      std::vector<double> T(45 * NP);
      for (auto& t : T) t = U(rng);
      double dFbar[9];
      for (double& x : dFbar) x = U(rng);

      // Random real displacement → normalised half spectrum (Hermitian-consistent, as the CG vectors).
      BatchedFFT f3(g, 3, {PlanRigor::estimate, 1, {}});
      for (std::size_t i = 0; i < 3 * N; ++i) f3.real(0)[i] = U(rng);
      f3.forward();
      std::vector<Complex> uh(f3.spectrum(0), f3.spectrum(0) + 3 * nm);
      for (auto& c : uh) c /= double(N);

      // Fourier path (the solver's apply()).
      BatchedFFT fs(g, 9 * nq, {PlanRigor::estimate, 1, {}}, nc);
      op.gradient(uh.data(), fs.spectrum(0), false);
      fs.backward();
      std::vector<double> grad_fourier(9 * NP, 0.0);
      for (std::size_t v = 0; v < N; ++v)
        for (int q = 0; q < nq; ++q) {
          double dF[9], dP[9];
          for (int c = 0; c < 9; ++c) {
            const double gc = c % 3 < nc ? fs.real(9 * q + c)[v] : 0.0;
            grad_fourier[9 * (v * nq + q) + c] = gc;
            dF[c] = dFbar[c] + gc;
          }
          sym_product(&T[45 * (v * nq + q)], dF, dP);
          for (int c = 0; c < 9; ++c)
            if (c % 3 < nc) fs.real(9 * q + c)[v] = dP[c];
        }
      fs.forward();
      std::vector<Complex> Ku_fourier(3 * nm);
      const double dot_fourier = op.divergence_dot(fs.spectrum(0), Ku_fourier.data(), 1.0 / double(N), uh.data());

      // Stencil path.
      std::copy(uh.begin(), uh.end(), f3.spectrum(0));
      f3.backward();  // the real nodal displacement
      std::vector<double> store(std::size_t(st.stored_values()) * N), grad_stencil(9 * NP, 0.0);
#pragma omp parallel
      st.gradient_pass(f3.real(0), store.data(), [&](std::size_t p0, int count, const double* grad, double* stress) {
        constexpr int B = StencilGradient::kBatch;
        EXPECT_EQ(p0 % B, 0u);
        for (int l = 0; l < count; ++l) {
          double dF[9], dP[9];
          for (int c = 0; c < 9; ++c) {
            grad_stencil[9 * (p0 + l) + c] = grad[c * B + l];
            dF[c] = dFbar[c] + grad[c * B + l];
          }
          sym_product(&T[45 * (p0 + l)], dF, dP);
          for (int c = 0; c < 9; ++c) stress[c * B + l] = dP[c];
        }
      });
      const double dot_stencil = st.divergence_pass(store.data(), f3.real(0), f3.real(0)) / double(N);
      f3.forward();
      std::vector<Complex> Ku_stencil(f3.spectrum(0), f3.spectrum(0) + 3 * nm);
      for (auto& c : Ku_stencil) c /= double(N);

      // The same stencil path on an in-place transform (real rows padded inside the spectrum buffer,
      // the solver's one-process layout): the same operator and ⟨x, Kx⟩ to round-off of the FFTs.
      BatchedFFT f3p(g, 3, {PlanRigor::estimate, 1, {}}, 3, true);
      ASSERT_TRUE(f3p.padded_rows());
      EXPECT_EQ(f3p.real_row_pitch(), 2u * std::size_t(g.half_n1())) << label;
      EXPECT_EQ(static_cast<void*>(f3p.real(0)), static_cast<void*>(f3p.spectrum(0)));
      StencilGradient stp(op);
      stp.set_padded_fields(f3p.real_row_pitch(), f3p.real_stride());
      std::copy(uh.begin(), uh.end(), f3p.spectrum(0));
      f3p.backward();
      std::vector<double> store_p(store.size());
#pragma omp parallel
      stp.gradient_pass(f3p.real(0), store_p.data(), [&](std::size_t p0, int count, const double* grad, double* stress) {
        constexpr int B = StencilGradient::kBatch;
        for (int l = 0; l < count; ++l) {
          double dF[9], dP[9];
          for (int c = 0; c < 9; ++c) dF[c] = dFbar[c] + grad[c * B + l];
          sym_product(&T[45 * (p0 + l)], dF, dP);
          for (int c = 0; c < 9; ++c) stress[c * B + l] = dP[c];
        }
      });
      const double dot_padded = stp.divergence_pass(store_p.data(), f3p.real(0), f3p.real(0)) / double(N);
      f3p.forward();
      double diff_padded = 0.0;
      for (std::size_t i = 0; i < 3 * nm; ++i)
        diff_padded = std::max(diff_padded, std::abs(f3p.spectrum(0)[i] / double(N) - Ku_stencil[i]));
      EXPECT_LE(diff_padded, 1e-12 * max_abs(Ku_stencil)) << label;
      EXPECT_NEAR(dot_padded, dot_stencil, 1e-12 * std::abs(dot_stencil)) << label;

      // Round-off: both are O(10²) flops per output on O(1) data, plus the FFTs (ε log N).
      double grad_scale = 0.0, grad_diff = 0.0;
      for (std::size_t i = 0; i < grad_fourier.size(); ++i) {
        grad_scale = std::max(grad_scale, std::abs(grad_fourier[i]));
        grad_diff = std::max(grad_diff, std::abs(grad_fourier[i] - grad_stencil[i]));
      }
      EXPECT_GT(grad_scale, 0.1) << label;
      EXPECT_LE(grad_diff, 1e-12 * grad_scale) << label;
      double diff = 0.0;
      for (std::size_t i = 0; i < Ku_fourier.size(); ++i) diff = std::max(diff, std::abs(Ku_fourier[i] - Ku_stencil[i]));
      const double scale = max_abs(Ku_fourier);
      EXPECT_GT(scale, 0.1) << label;
      EXPECT_LE(diff, 1e-12 * scale) << label;
      EXPECT_NEAR(dot_stencil, dot_fourier, 1e-12 * std::abs(dot_fourier)) << label;
    }
}

// The stencil coefficients are the trilinear shape-function derivatives: they sum to zero over the
// corners (rigid translations have no gradient) and reproduce a linear field's gradient exactly.
TEST(StencilGradient, ReproducesLinearFieldsAndRejectsSpectral) {
  const Grid g{{4, 6, 5}, {2.0, 3.0, 1.0}};
  for (Discretization d : {Discretization::rotated, Discretization::hex}) {
    GradientOperator op(g, d);
    StencilGradient st(op);
    for (int q = 0; q < st.points(); ++q)
      for (int j = 0; j < 3; ++j) {
        double sum = 0.0, lin[3] = {0.0, 0.0, 0.0};
        for (int c = 0; c < 8; ++c) {
          sum += st.coefficient(q, c, j);
          for (int m = 0; m < 3; ++m) lin[m] += st.coefficient(q, c, j) * ((c >> m) & 1) * g.spacing(m);
        }
        EXPECT_NEAR(sum, 0.0, 1e-12);
        for (int m = 0; m < 3; ++m) EXPECT_NEAR(lin[m], m == j ? 1.0 : 0.0, 1e-12);
      }
  }
  EXPECT_FALSE(StencilGradient::supported(GradientOperator(g, Discretization::spectral)));
  EXPECT_THROW(StencilGradient(GradientOperator(g, Discretization::spectral)), std::invalid_argument);
}

// The streamed pass (gradient → body → adjoint in place, slice by slice, two slices of stresses instead
// of the grid's) against gradient_pass() + divergence_pass(): the same nodal forces to the bit and ⟨u, f⟩
// to round-off (summed in another order) on sections and 3D
// grids (rows of 8, 12 and 16 voxels: SIMD batches, batches over rows; 4-voxel rows: a batch spans two
// rows), dense and padded rows, 1, 2, 3 and more threads than slices (uneven slices per thread, the
// carry between threads, the periodic wrap of the last slice). With `gradient` off the pass is the
// divergence of what body() writes.
TEST(StencilGradient, StreamedPassEqualsStoredPasses) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> U(-1, 1);
  for (const Grid& g : {Grid{{8, 6, 1}, {1.0, 0.8, 0.1}}, Grid{{16, 5, 1}, {1.1, 0.9, 0.1}},
                        Grid{{6, 4, 5}, {1.0, 1.0, 1.2}}, Grid{{16, 4, 3}, {1.0, 0.5, 0.6}},
                        Grid{{4, 2, 7}, {0.5, 1.0, 0.7}}, Grid{{12, 2, 3}, {1.2, 0.4, 0.5}}})
    for (bool padded : {false, true})
      for (int threads : {1, 2, 3, 8}) {
        const std::string label = std::to_string(g.n[0]) + "x" + std::to_string(g.n[1]) + "x" + std::to_string(g.n[2]) +
                                  (padded ? " padded" : " dense") + ", " + std::to_string(threads) + " threads";
        GradientOperator op(g, Discretization::rotated);
        StencilGradient st(op);
        ASSERT_TRUE(st.streams()) << label;
        const std::size_t N = g.voxels();
        std::vector<double> T(45 * ((N + 7) / 8 * 8));
        for (auto& t : T) t = U(rng);
        BatchedFFT f3(g, 3, {PlanRigor::estimate, 1, {}}, 3, padded);
        if (f3.padded_rows()) st.set_padded_fields(f3.real_row_pitch(), f3.real_stride());
        for (std::size_t v = 0; v < N; ++v)
          for (int i = 0; i < 3; ++i) f3.real(i)[f3.real_index(v)] = U(rng);
        const std::size_t values = 3 * f3.real_stride();
        const std::vector<double> u(f3.real(0), f3.real(0) + values);
        auto body = [&](std::size_t p0, int count, const double* grad, double* stress) {
          constexpr int B = StencilGradient::kBatch;
          for (int l = 0; l < count; ++l) {
            double dF[9], dP[9];
            for (int c = 0; c < 9; ++c) dF[c] = 0.3 * double(c) + (grad ? grad[c * B + l] : double(p0 + l) * 0.01);
            sym_product(&T[45 * (p0 + l)], dF, dP);
            for (int c = 0; c < 9; ++c) stress[c * B + l] = dP[c];
          }
        };
        for (bool gradient : {true, false}) {
          // Stored passes.
          std::copy(u.begin(), u.end(), f3.real(0));
          std::vector<double> store(std::size_t(st.stored_values()) * N);
          if (gradient) {
#pragma omp parallel num_threads(threads)
            st.gradient_pass(f3.real(0), store.data(), body);
          } else {
            // the divergence alone: the stresses body() writes for zero gradient input
            std::vector<double> zero(values, 0.0);
            StencilGradient sz(op);
            if (f3.padded_rows()) sz.set_padded_fields(f3.real_row_pitch(), f3.real_stride());
#pragma omp parallel num_threads(threads)
            sz.gradient_pass(zero.data(), store.data(), [&](std::size_t p0, int count, const double*, double* stress) {
              body(p0, count, nullptr, stress);
            });
          }
          const double dot_stored = st.divergence_pass(store.data(), f3.real(0), f3.real(0));
          std::vector<double> f_stored(values);
          for (std::size_t v = 0; v < N; ++v)
            for (int i = 0; i < 3; ++i) f_stored[i * f3.real_stride() + f3.real_index(v)] = f3.real(i)[f3.real_index(v)];
          // Streamed.
          std::copy(u.begin(), u.end(), f3.real(0));
          std::vector<double> scratch(st.stream_scratch_values(threads));
          double dot_streamed = 0.0;
#pragma omp parallel num_threads(threads) reduction(+ : dot_streamed)
          dot_streamed += st.streamed_pass(f3.real(0), scratch.data(), body, gradient, true);
          double scale = 0.0, diff = 0.0;
          for (std::size_t v = 0; v < N; ++v)
            for (int i = 0; i < 3; ++i) {
              const std::size_t k = i * f3.real_stride() + f3.real_index(v);
              scale = std::max(scale, std::abs(f_stored[k]));
              diff = std::max(diff, std::abs(f_stored[k] - f3.real(0)[k]));
            }
          EXPECT_GT(scale, 0.1) << label;
          // The same gather in the same order (the cancelling terms' round-off is that of the stored
          // passes, which the Krylov iteration of a K/G = 1e5 matrix is sensitive to): equal to the bit.
          EXPECT_EQ(diff, 0.0) << label << (gradient ? "" : ", divergence only");
          EXPECT_NEAR(dot_streamed, dot_stored, 1e-12 * std::abs(dot_stored)) << label;
        }
      }
}
