#pragma once
// Green preconditioner with a local bulk stiffness (FftSolverOptions::preconditioner = green_local_bulk).
//
// One homogeneous reference medium cannot follow a bulk stiffness that changes by orders of magnitude
// from phase to phase: a nearly incompressible matrix (PDMS K/G = 3e3, Ecoflex 1.2e5) around
// compressible glass (K = 8.3 MPa). With the matrix's bulk in the reference, the glass's volume changes
// look 100–250× stiffer to the preconditioner than they are, and CG pays for that spread.
//
// The reference here is isotropic in the current configuration of the mean deformation F̄, with a
// homogeneous shear modulus μ0 and a bulk modulus k(x) per voxel: its Piola tangent is the pull-back
// A_ref(x) = J̄ F̄⁻¹ F̄⁻¹ c(x), c(x) = (k(x) − 2μ0/3) 1⊗1 + 2μ0 I. With one point per voxel the
// gradient of mode k is û(k) ⊗ D(k), and the dilatation cof F̄ : ∇u of that mode is η(k)·û(k), η = cof F̄ D.
// The operator of A_ref then splits exactly into two invariant parts:
//   - modes orthogonal to conj(η) (no dilatation): μ0 alone, homogeneous, inverted per mode by the
//     Green operator of the homogeneous medium (k0, μ0) (its shear part);
//   - modes along conj(η): Bᵀ [(k(x) + 4μ0/3)/J̄] B, B = η· the dilatation operator, whose inverse is
//     û = conj(η) θ̂/|η|² with θ = w(x) (ψ + c), w = J̄/(k + 4μ0/3), ψ̂ = η·r̂/|η|², c the constant that
//     gives θ zero mean (a periodic displacement's dilatation has none).
// So M⁻¹ = G0 + conj(η)/|η|² (ŵψ − w0 ψ̂), with G0 the Green operator of (k0, μ0) and w0 its w: one scalar
// field transformed back and forth per application on top of the Green operator. (Exactly, θ would also
// have to vanish at the other frequencies where D = 0, e.g. the rotated scheme's (π, π) checkerboard; only
// the mean is imposed, and θ's components there are dropped.)
// M⁻¹ is symmetric positive semidefinite with the kernel of the Krylov operator, so CG keeps its
// guarantees.
//
// k(x) is read from each voxel's tangent: k = J̄ b:A:b / |b|⁴ with b = cof F̄, which is the bulk modulus
// of an isotropic tangent at F̄ = I and λ + 2μ|C̄⁻¹|²/(tr C̄⁻¹)² of one pulled back at F̄. The reference's
// shear modulus μ0 and its homogeneous bulk k0 are the isotropic projection of the mean tangent.
//
// What it does not see: the volume change of a voxel follows cof F(x), not cof F̄. Where strains vary a
// lot within a nearly incompressible matrix (Ecoflex near a stiff fiber at large stretch) the bulk term
// of the true operator leaves the reference's dilatation modes, and the preconditioner gains little
// (BENCHMARKS.md, "The local bulk modulus in the Green preconditioner").
#include <algorithm>

#include "softhom/materials/tensor.hpp"

namespace softhom::rve::detail {

/// The isotropic tangent λ 1⊗1 + 2μ I (index 3i + j, both minor symmetries written out).
inline Mat9 isotropic_tangent(double lambda, double mu) {
  Mat9 C = Mat9::Zero();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      C(3 * i + i, 3 * j + j) += lambda;
      C(3 * i + j, 3 * i + j) += mu;
      C(3 * i + j, 3 * j + i) += mu;
    }
  return C;
}

/// Isotropic projection of a 9×9 tangent (index 3i + j): with a = Σ C_iikk and b = ½ Σ (C_ijij + C_ijji),
/// an isotropic C has bulk modulus K = a/9 and shear modulus μ = (b − a/3)/10.
struct IsotropicModuli {
  double K = 0.0, mu = 0.0;
};
inline IsotropicModuli isotropic_projection(const Mat9& C) {
  double a = 0.0, b = 0.0;
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) a += C(4 * i, 4 * k);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) b += 0.5 * (C(3 * i + j, 3 * i + j) + C(3 * i + j, 3 * j + i));
  return {a / 9.0, (b - a / 3.0) / 10.0};
}

/// Piola tangent of the isotropic spatial medium (bulk k, shear μ) pulled back at F:
/// A_iIkL = J F⁻¹_Ij F⁻¹_Ll c_ijkl, c = (k − 2μ/3) 1⊗1 + μ (δ_ik δ_jl + δ_il δ_jk).
inline Mat9 isotropic_pull_back(double k, double mu, const Mat3& F) {
  const double J = F.determinant();
  const Mat3 Fi = F.inverse();
  const Mat3 Ci = Fi * Fi.transpose();  // (F⁻¹ F⁻ᵀ)_IL = Σ_j F⁻¹_Ij F⁻¹_Lj
  const double lam = k - 2.0 / 3.0 * mu;
  Mat9 A;
  for (int i = 0; i < 3; ++i)
    for (int I = 0; I < 3; ++I)
      for (int kk = 0; kk < 3; ++kk)
        for (int L = 0; L < 3; ++L)
          A(3 * i + I, 3 * kk + L) = J * (lam * Fi(I, i) * Fi(L, kk) + mu * ((i == kk ? Ci(I, L) : 0.0) + Fi(I, kk) * Fi(L, i)));
  return A;
}

/// The local bulk modulus k = J b:A:b / |b|⁴ of a point from bAb = b:A:b (b = cof F̄ as a 9-vector,
/// b2 = |b|²), clipped at 0 (a point whose tangent is indefinite in dilatation adds no bulk stiffness).
inline double local_bulk_modulus(double bAb, double J, double b2) { return std::max(J * bAb / (b2 * b2), 0.0); }

}  // namespace softhom::rve::detail
