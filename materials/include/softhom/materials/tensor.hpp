#pragma once
// Fixed-size tensor algebra for material kernels.
//
// Index convention used everywhere in softhom: a second-order tensor A is stored as a 3x3 matrix and,
// flattened, component (i, j) sits at position 3*i + j (row-major: A11, A12, A13, A21, ...). A fourth-
// order tensor T_ijkl is a 9x9 matrix with row 3*i + j and column 3*k + l, so that dP = T : dF reads
// vec(dP) = T * vec(dF). The material tangent is A = dP/dF in this layout.
#include <Eigen/Core>
#include <Eigen/LU>

namespace softhom {

using Mat3 = Eigen::Matrix3d;
using Vec3 = Eigen::Vector3d;
using Mat9 = Eigen::Matrix<double, 9, 9>;
using Vec9 = Eigen::Matrix<double, 9, 1>;

constexpr int voigt9(int i, int j) { return 3 * i + j; }

/// Row-major flattening of a 3x3 tensor (see the file comment).
inline Vec9 flatten(const Mat3& A) {
  Vec9 v;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) v[voigt9(i, j)] = A(i, j);
  return v;
}
inline Mat3 unflatten(const Vec9& v) {
  Mat3 A;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) A(i, j) = v[voigt9(i, j)];
  return A;
}

/// T += s * (A ⊗ B), (A ⊗ B)_ijkl = A_ij B_kl.
inline void add_dyad(Mat9& T, double s, const Mat3& A, const Mat3& B) {
  const Vec9 a = flatten(A), b = flatten(B);
  T.noalias() += (s * a) * b.transpose();
}

/// T += s * (A ⊙ A) with the symmetrised product (A ⊙ A)_ijkl = (A_ik A_jl + A_il A_jk)/2, for symmetric A.
/// This is the derivative d(A X A)/dX restricted to symmetric X, e.g. -dC⁻¹/dC = C⁻¹ ⊙ C⁻¹.
inline void add_sym_product(Mat9& T, double s, const Mat3& A) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k)
        for (int l = 0; l < 3; ++l)
          T(voigt9(i, j), voigt9(k, l)) += 0.5 * s * (A(i, k) * A(j, l) + A(i, l) * A(j, k));
}

/// Double contraction A : B.
inline double ddot(const Mat3& A, const Mat3& B) { return (A.array() * B.array()).sum(); }

/// Contraction of a 4th-order tensor with a 2nd-order one on the right: (T : X)_ij = T_ijkl X_kl.
inline Mat3 contract(const Mat9& T, const Mat3& X) { return unflatten(T * flatten(X)); }

/// Push a material tangent to the first Piola form.
/// Given S (2nd Piola-Kirchhoff) and CC = 2 dS/dC (minor-symmetric 9x9), returns
///   A_iJkL = dP_iJ/dF_kL = δ_ik S_JL + F_iM CC_MJNL F_kN       (P = F S).
inline void piola_tangent_from_material(const Mat3& F, const Mat3& S, const Mat9& CC, Mat9& A) {
  // G(i J, N L) = Σ_M F_iM CC_MJNL  (contract the first index of CC with F)
  Mat9 G;
  for (int i = 0; i < 3; ++i)
    for (int J = 0; J < 3; ++J)
      G.row(voigt9(i, J)) = F(i, 0) * CC.row(voigt9(0, J)) + F(i, 1) * CC.row(voigt9(1, J)) +
                            F(i, 2) * CC.row(voigt9(2, J));
  for (int k = 0; k < 3; ++k)
    for (int L = 0; L < 3; ++L)
      A.col(voigt9(k, L)) = F(k, 0) * G.col(voigt9(0, L)) + F(k, 1) * G.col(voigt9(1, L)) +
                            F(k, 2) * G.col(voigt9(2, L));
  for (int i = 0; i < 3; ++i)
    for (int J = 0; J < 3; ++J)
      for (int L = 0; L < 3; ++L) A(voigt9(i, J), voigt9(i, L)) += S(J, L);
}

/// Cauchy stress from the first Piola stress: σ = J⁻¹ P Fᵀ.
inline Mat3 cauchy_from_piola(const Mat3& F, const Mat3& P) { return P * F.transpose() / F.determinant(); }

}  // namespace softhom
