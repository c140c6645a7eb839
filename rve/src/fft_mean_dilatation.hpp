#pragma once
// Mean-dilatation (F̄, Q1/P0) form of the hex discretization of the FFT engine
// (FftSolverOptions::volumetric = mean_dilatation).
//
// The hex scheme has nq = 2^d Gauss points per voxel; with a nearly incompressible matrix each of them
// enforces J_q ≈ 1, too many constraints for the trilinear displacement: the scheme locks (K/G = 1.2e5).
// Here every point of a voxel sees the voxel's volume ratio instead of its own:
//
//   F̄_q = α_q F_q,   α_q = (J̄ / J_q)^{1/3},   J̄ = Σ_q w_q J_q
//
// (w_q the Gauss weights of the voxel, Σ_q w_q = 1; 2^d Gauss points integrate det of the multilinear
// map exactly, so J̄ is the voxel's current volume over its reference volume), and the discrete energy is
// Π = Σ_voxels Σ_q w_q W(F̄_q). Residual and Newton tangent are its exact gradient and Hessian, so the
// Newton operator stays symmetric and CG applies. For a decoupled law W = W_iso(J^{-1/3} F) + U(J) this
// is Σ_q w_q W_iso(F_q) + U(J̄): the classical Q1/P0 element (one pressure per voxel, de Souza Neto,
// Perić & Owen's F-bar in its variationally consistent form). On a homogeneous deformation α_q = 1 and
// nothing changes.
//
// With θ = ln J̄, g_q = F_q^{-T}, ĝ_q = (J_q/J̄) g_q (so δθ = Σ_q w_q ĝ_q : δF_q), P̄_q = P(F̄_q), A_q =
// ∂P/∂F(F̄_q), s_q = P̄_q : F̄_q and s̄ = Σ_q w_q s_q:
//
//   δΠ = Σ_q w_q P_q : δF_q,   P_q = α_q P̄_q − (s_q/3) g_q + (s̄/3) ĝ_q,
//
//   δ²Π = Σ_q w_q δF_q : K_q : ΔF_q + Σ_q w_q (a_q : δF_q) Δθ + δθ Σ_q w_q (a_q : ΔF_q) + c δθ Δθ,
//
//   K_q = α² Qᵀ A Q − (α/3)(g ⊗ P̄ + P̄ ⊗ g) + (s/9) g ⊗ g + (s/3) Λ + (s̄ r/3)(g ⊗ g − Λ),
//   a_q = (α²/3) Qᵀ A f + (α/3) P̄ − (s/9) g,
//   c   = Σ_q w_q (α_q² f_q : A_q : f_q + s_q)/9 − s̄/3,
//
// (per point: f = F_q, Q = I − f ⊗ g/3, r = J_q/J̄, Λ : X = (F⁻¹ X F⁻¹)ᵀ, i.e. −∂g/∂F), all symmetric.
// K_q takes the place of the point tangent (same packed storage, same SIMD product); the coupling of the
// voxel's points, δP_q += a_q Δθ + ĝ_q (Σ_p w_p a_p : ΔF_p + c Δθ) with Δθ = Σ_p w_p ĝ_p : ΔF_p, is two
// 9-vectors per point and one number per voxel (MeanDilatationCoupling), applied on the stencil
// operator's batches, which hold whole voxels. The bulk stiffness of a nearly incompressible phase sits in
// c (one number per voxel) and leaves K_q (Q projects the dilatation out of A): the float tangents of the
// stencil operator no longer carry it.
//
// Composite voxels: the laminate rule is the point's constitutive law (a condensed energy, stationary in
// the jump vector), so F̄_q is handed to it as to any law: both phases of the point see the voxel's mean
// dilatation, which is what the matrix side needs and a compressible fiber tolerates (a voxel's F̄ error
// in it is of the order of the voxel error of the discretization itself).
#include <cmath>
#include <cstddef>
#include <vector>

#include "softhom/materials/tensor.hpp"

namespace softhom::rve::detail {

/// The kinematics of one voxel: the compatible F_q (set by the caller), weights, J_q, J̄ and α_q.
struct MeanDilatationVoxel {
  static constexpr int kMaxPoints = 8;
  int nq = 0;
  double w[kMaxPoints] = {};
  Mat3 F[kMaxPoints];
  double J[kMaxPoints] = {}, alpha[kMaxPoints] = {};
  double J_mean = 1.0;
  int evaluated = 0;  ///< points whose material response has been stored (P̄, A) by the caller

  /// J_q, J̄, α_q from F[0..nq) and the weights (Σ = 1). False when a point or the voxel is inverted.
  bool prepare(int points, const double* weights) {
    nq = points;
    evaluated = 0;
    J_mean = 0.0;
    for (int q = 0; q < nq; ++q) {
      w[q] = weights[q];
      J[q] = F[q].determinant();
      if (!(J[q] > 0.0)) return false;
      J_mean += w[q] * J[q];
    }
    for (int q = 0; q < nq; ++q) alpha[q] = std::cbrt(J_mean / J[q]);
    return true;
  }
  /// F̄_q = α_q F_q, the deformation the law sees at point q.
  Mat3 modified(int q) const { return alpha[q] * F[q]; }
};

/// Stress and Newton tangent of one voxel (see the file comment).
struct MeanDilatationResponse {
  Mat3 P[MeanDilatationVoxel::kMaxPoints];
  Mat9 K[MeanDilatationVoxel::kMaxPoints];
  Vec9 a[MeanDilatationVoxel::kMaxPoints], g[MeanDilatationVoxel::kMaxPoints];  // g: ĝ_q = (J_q/J̄) F_q^{-T}
  double c = 0.0;
  /// Σ_q w_q K_q + ā ⊗ ḡ + ḡ ⊗ ā + c ḡ ⊗ ḡ (ā = Σ w a, ḡ = Σ w ĝ): the voxel's tangent for a uniform
  /// ΔF, its contribution to the mean tangent of the reference medium.
  Mat9 voxel_tangent = Mat9::Zero();
};

/// X ↦ (F⁻¹ X F⁻¹)ᵀ as a 9×9 matrix (row-major flattening): −∂(F^{-T})/∂F.
inline Mat9 inverse_transpose_derivative(const Mat3& Finv) {
  Mat9 L;
  for (int k = 0; k < 3; ++k)
    for (int a = 0; a < 3; ++a)
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) L(3 * k + a, 3 * i + j) = Finv(a, i) * Finv(j, k);
  return L;
}

/// From the law's P̄_q = P(F̄_q) (and A_q when `A` is non-null) of every point of `v`: the voxel's
/// stresses P_q and (with A) K_q, a_q, ĝ_q, c.
inline void mean_dilatation_response(const MeanDilatationVoxel& v, const Mat3* Pbar, const Mat9* A,
                                     MeanDilatationResponse& out) {
  double s[MeanDilatationVoxel::kMaxPoints];
  double s_mean = 0.0;
  for (int q = 0; q < v.nq; ++q) {
    s[q] = v.alpha[q] * ddot(Pbar[q], v.F[q]);
    s_mean += v.w[q] * s[q];
  }
  Vec9 a_mean = Vec9::Zero(), g_mean = Vec9::Zero();
  Mat9 K_mean = Mat9::Zero();
  double c = -s_mean / 3.0;
  for (int q = 0; q < v.nq; ++q) {
    const Mat3 Finv = v.F[q].inverse();
    const Vec9 g = flatten(Finv.transpose());
    const double r = v.J[q] / v.J_mean, al = v.alpha[q];
    out.g[q] = r * g;
    out.P[q] = al * Pbar[q] + (s_mean * r - s[q]) / 3.0 * Finv.transpose();
    if (!A) continue;
    const Vec9 f = flatten(v.F[q]), p = flatten(Pbar[q]);
    const Mat9 Q = Mat9::Identity() - f * g.transpose() / 3.0;
    const Mat9& Aq = A[q];
    const Mat9 L = inverse_transpose_derivative(Finv);
    Mat9 K = al * al * (Q.transpose() * Aq * Q);
    K.noalias() -= al / 3.0 * (g * p.transpose() + p * g.transpose());
    K.noalias() += (s[q] / 9.0 + s_mean * r / 3.0) * (g * g.transpose());
    K += (s[q] - s_mean * r) / 3.0 * L;
    out.K[q] = K;
    out.a[q] = al * al / 3.0 * (Q.transpose() * (Aq * f)) + al / 3.0 * p - s[q] / 9.0 * g;
    c += v.w[q] * (al * al * f.dot(Aq * f) + s[q]) / 9.0;
    K_mean += v.w[q] * K;
    a_mean += v.w[q] * out.a[q];
    g_mean += v.w[q] * out.g[q];
  }
  if (!A) return;
  out.c = c;
  out.voxel_tangent = K_mean + a_mean * g_mean.transpose() + g_mean * a_mean.transpose() + c * g_mean * g_mean.transpose();
}

/// The voxel coupling of the Newton operator: a_q, ĝ_q per point (18 doubles), c per voxel.
class MeanDilatationCoupling {
 public:
  void resize(std::size_t voxels, int points_per_voxel) {
    nq_ = points_per_voxel;
    ag_.assign(18 * voxels * std::size_t(points_per_voxel), 0.0);
    c_.assign(voxels, 0.0);
  }
  bool empty() const { return c_.empty(); }
  std::size_t memory_bytes() const { return (ag_.size() + c_.size()) * sizeof(double); }
  void store(std::size_t voxel, const MeanDilatationResponse& r) {
    double* o = &ag_[18 * voxel * std::size_t(nq_)];
    for (int q = 0; q < nq_; ++q)
      for (int k = 0; k < 9; ++k) {
        o[18 * q + k] = r.a[q][k];
        o[18 * q + 9 + k] = r.g[q][k];
      }
    c_[voxel] = r.c;
  }
  /// dP_q += a_q Δθ + ĝ_q (Σ_p w_p a_p : ΔF_p + c Δθ), Δθ = Σ_p w_p ĝ_p : ΔF_p, for `count` points from
  /// p0 (whole voxels: p0 and count multiples of nq) in the structure-of-arrays layout of a stencil
  /// batch, dF[c·B + l], dP[c·B + l].
  template <int B>
  void add_to_batch(std::size_t p0, int count, const double* w, const double* dF, double* dP) const {
    for (int l0 = 0; l0 < count; l0 += nq_) {
      const std::size_t voxel = (p0 + std::size_t(l0)) / std::size_t(nq_);
      const double* ag = &ag_[18 * voxel * std::size_t(nq_)];
      double dtheta = 0.0, dbeta = 0.0;
      for (int q = 0; q < nq_; ++q) {
        double ga = 0.0, gg = 0.0;
        for (int k = 0; k < 9; ++k) {
          ga += ag[18 * q + k] * dF[k * B + l0 + q];
          gg += ag[18 * q + 9 + k] * dF[k * B + l0 + q];
        }
        dbeta += w[q] * ga;
        dtheta += w[q] * gg;
      }
      const double h = dbeta + c_[voxel] * dtheta;
      for (int q = 0; q < nq_; ++q)
        for (int k = 0; k < 9; ++k) dP[k * B + l0 + q] += ag[18 * q + k] * dtheta + ag[18 * q + 9 + k] * h;
    }
  }

 private:
  int nq_ = 1;
  std::vector<double> ag_;  // per point: a_q (9), ĝ_q (9)
  std::vector<double> c_;   // per voxel
};

}  // namespace softhom::rve::detail
