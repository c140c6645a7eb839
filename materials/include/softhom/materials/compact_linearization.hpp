#pragma once
// Compact linearization of isotropic hyperelastic laws written in (I1 = tr C, J = det F).
//
// For W(I1, J) the first Piola stress is P = 2 W_1 F + W_J cof F and its tangent
//   A = 2W_1 𝕀 + 4W_11 F⊗F + 2W_1J (F⊗cof + cof⊗F) + W_JJ cof⊗cof + W_J ∂cof/∂F,
//   ∂cof/∂F : δF = [(cof:δF) cof − cof δFᵀ cof] / J,
// so δF ↦ δP needs F and five scalars instead of the 45 independent entries of the 9×9 tangent. Isochoric
// laws W = Ψ(Ī1) + W_V(J), Ī1 = J^(-2/3) I1 (neo-Hookean, Yeoh, Gent without fibers) reduce to it by the
// chain rule (isochoric_compact_linearization). A solver that applies the tangent many times per
// evaluation (the Krylov iteration of the FFT solver) stores F and the scalars per point and applies the
// product on the fly: 14 values instead of 45 per point. Anisotropic, viscoelastic and condensed
// (laminate) tangents have no such form and keep the stored 9×9 tangent.
#include <cmath>

#include "softhom/materials/tensor.hpp"
#include "softhom/materials/volumetric.hpp"

namespace softhom {

/// δP = a1 δF + (a11 f + a1J g) F + (a1J f + aJJ g) cof − b cof δFᵀ cof, with f = F:δF, g = cof:δF.
/// (a1 = 2W_1, a11 = 4W_11, a1J = 2W_1J, aJJ = W_JJ + W_J/J, b = W_J/J.) Writing b = W_J/J instead of
/// W_J keeps the product free of 1/J (a zero record, F = 0, is the zero operator).
struct CompactLinearization {
  double a1 = 0.0, a11 = 0.0, a1J = 0.0, aJJ = 0.0, b = 0.0;
};

/// Cofactor matrix cof F = J F⁻ᵀ (no division).
template <class T>
inline void cofactor(const T F[9], T cof[9]) {
  cof[0] = F[4] * F[8] - F[5] * F[7];
  cof[1] = F[5] * F[6] - F[3] * F[8];
  cof[2] = F[3] * F[7] - F[4] * F[6];
  cof[3] = F[2] * F[7] - F[1] * F[8];
  cof[4] = F[0] * F[8] - F[2] * F[6];
  cof[5] = F[1] * F[6] - F[0] * F[7];
  cof[6] = F[1] * F[5] - F[2] * F[4];
  cof[7] = F[2] * F[3] - F[0] * F[5];
  cof[8] = F[0] * F[4] - F[1] * F[3];
}

/// From the derivatives of W(I1, J): W_1, W_J, W_11, W_1J, W_JJ.
inline CompactLinearization compact_from_derivatives(double W1, double WJ, double W11, double W1J, double WJJ, double J) {
  CompactLinearization L;
  L.a1 = 2.0 * W1;
  L.a11 = 4.0 * W11;
  L.a1J = 2.0 * W1J;
  L.b = WJ / J;
  L.aJJ = WJJ + L.b;
  return L;
}

/// W = Ψ(Ī1) + (K/4)(J² − 1 − 2 ln J) with Ψ′ = W1, Ψ″ = W11 at Ī1 = I1b:
///   W_1 = Ψ′ j, W_11 = Ψ″ j², W_1J = −(2/3)(j/J)(Ψ″ Ī1 + Ψ′), j = J^(-2/3),
///   W_J = −(2/3) Ψ′ Ī1/J + W_V′, W_JJ = (4/9) Ψ″ Ī1²/J² + (10/9) Ψ′ Ī1/J² + W_V″.
inline CompactLinearization isochoric_compact_linearization(double W1, double W11, double I1b, double J, double K) {
  const double j = 1.0 / std::cbrt(J * J);
  const double dU = volumetric_dU(K, J), ddU = volumetric_d2U(K, J);
  const double WJ = -2.0 / 3.0 * W1 * I1b / J + dU;
  const double WJJ = (4.0 / 9.0 * W11 * I1b * I1b + 10.0 / 9.0 * W1 * I1b) / (J * J) + ddU;
  return compact_from_derivatives(W1 * j, WJ, W11 * j * j, -2.0 / 3.0 * j / J * (W11 * I1b + W1), WJJ, J);
}

/// Adds q ∂cof/∂F (the stiffness of a pressure q acting on cof F, e.g. the mixed (u, p) correction).
inline void add_pressure_stiffness(CompactLinearization& L, double q, double J) {
  L.b += q / J;
  L.aJJ += q / J;
}

/// δP for one point (double; tests and reference).
inline Mat3 compact_product(const Mat3& F, const CompactLinearization& L, const Mat3& dF) {
  const Mat3 cof = F.determinant() * F.inverse().transpose();
  const double f = ddot(F, dF), g = ddot(cof, dF);
  return L.a1 * dF + (L.a11 * f + L.a1J * g) * F + (L.a1J * f + L.aJJ * g) * cof - L.b * cof * dF.transpose() * cof;
}

/// The 9×9 tangent the compact form stands for (tests; row-major layout of tensor.hpp).
inline Mat9 compact_tangent_matrix(const Mat3& F, const CompactLinearization& L) {
  Mat9 A;
  for (int c = 0; c < 9; ++c) {
    Mat3 e = Mat3::Zero();
    e(c / 3, c % 3) = 1.0;
    A.col(c) = flatten(compact_product(F, L, e));
  }
  return A;
}

/// Values per point of a stored compact linearization: F (9) and the five scalars.
constexpr int kCompactValues = 14;

/// δP = compact product for a batch of 8 points stored as a structure of arrays: rec[v·8 + l], v < 9 the
/// entries of F (row-major), v = 9…13 (a1, a11, a1J, aJJ, b); dF and dP [9][8] (double). Float records
/// are widened on load; the arithmetic is double. The lane loops vectorize (no branches).
void compact_product_batch(const float* __restrict rec, const double* __restrict dF, double* __restrict dP);

/// Writes one point's record into a batch (lane l of the 8-point block `block`), rounded to float.
inline void store_compact_record(float* block, int lane, const Mat3& F, const CompactLinearization& L) {
  for (int c = 0; c < 9; ++c) block[8 * c + lane] = float(F(c / 3, c % 3));
  const double s[5] = {L.a1, L.a11, L.a1J, L.aJJ, L.b};
  for (int k = 0; k < 5; ++k) block[8 * (9 + k) + lane] = float(s[k]);
}

}  // namespace softhom
