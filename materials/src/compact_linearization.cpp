// The batched compact product (compact_linearization.hpp): lane loops over 8 points, so that every
// statement is one SIMD operation on the lanes; an x86-64-v3 (AVX2 + FMA) clone is chosen at run time.
#include "softhom/materials/compact_linearization.hpp"

namespace softhom {
namespace {

constexpr int B = 8;

[[gnu::always_inline]] inline void batch(const float* __restrict rec, const double* __restrict dF, double* __restrict dP) {
  double F[9][B], cof[9][B], f[B], g[B];
#pragma GCC unroll 9
  for (int c = 0; c < 9; ++c)
    for (int l = 0; l < B; ++l) F[c][l] = double(rec[c * B + l]);
  // cof F (row-major): cyclic 2×2 minors
#pragma GCC unroll 3
  for (int i = 0; i < 3; ++i)
#pragma GCC unroll 3
    for (int j = 0; j < 3; ++j) {
      const int i1 = (i + 1) % 3, i2 = (i + 2) % 3, j1 = (j + 1) % 3, j2 = (j + 2) % 3;
      for (int l = 0; l < B; ++l) cof[3 * i + j][l] = F[3 * i1 + j1][l] * F[3 * i2 + j2][l] - F[3 * i1 + j2][l] * F[3 * i2 + j1][l];
    }
  for (int l = 0; l < B; ++l) {
    f[l] = 0.0;
    g[l] = 0.0;
  }
#pragma GCC unroll 9
  for (int c = 0; c < 9; ++c)
    for (int l = 0; l < B; ++l) {
      f[l] += F[c][l] * dF[c * B + l];
      g[l] += cof[c][l] * dF[c * B + l];
    }
  const float* a1 = rec + 9 * B;
  const float* a11 = rec + 10 * B;
  const float* a1J = rec + 11 * B;
  const float* aJJ = rec + 12 * B;
  const float* b = rec + 13 * B;
  double sF[B], sC[B];
  for (int l = 0; l < B; ++l) {
    sF[l] = double(a11[l]) * f[l] + double(a1J[l]) * g[l];
    sC[l] = double(a1J[l]) * f[l] + double(aJJ[l]) * g[l];
  }
  // M = cof δFᵀ (M_ik = Σ_l cof_il δF_kl), then (M cof)_ij
  double M[9][B];
#pragma GCC unroll 3
  for (int i = 0; i < 3; ++i)
#pragma GCC unroll 3
    for (int k = 0; k < 3; ++k)
      for (int l = 0; l < B; ++l)
        M[3 * i + k][l] = cof[3 * i][l] * dF[(3 * k) * B + l] + cof[3 * i + 1][l] * dF[(3 * k + 1) * B + l] +
                          cof[3 * i + 2][l] * dF[(3 * k + 2) * B + l];
#pragma GCC unroll 3
  for (int i = 0; i < 3; ++i)
#pragma GCC unroll 3
    for (int j = 0; j < 3; ++j)
      for (int l = 0; l < B; ++l) {
        const double t = M[3 * i][l] * cof[j][l] + M[3 * i + 1][l] * cof[3 + j][l] + M[3 * i + 2][l] * cof[6 + j][l];
        const int c = 3 * i + j;
        dP[c * B + l] = double(a1[l]) * dF[c * B + l] + sF[l] * F[c][l] + sC[l] * cof[c][l] - double(b[l]) * t;
      }
}

}  // namespace

__attribute__((target_clones("arch=x86-64-v3", "default"))) void compact_product_batch(
    const float* __restrict rec, const double* __restrict dF, double* __restrict dP) {
  batch(rec, dF, dP);
}

}  // namespace softhom
