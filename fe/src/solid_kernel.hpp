#pragma once
// Isoparametric solid kernels shared by hex8 (8 nodes, 2×2×2 points) and tet10 (10 nodes, 4 points):
// kinematics with the mean-dilatation F-bar and the internal force/tangent of the plain, F-bar and
// condensed three-field (u, θ, p) forms. The derivation is in hex8.hpp (Hex8 MixedVolume); only the
// node count NN and the point count NQ differ between the elements.
#include <array>
#include <cmath>

#include <Eigen/Core>

#include "softhom/fe/hex8.hpp"

namespace softhom::fe::detail {

template <int NN>
using NodeGrad = Eigen::Matrix<double, NN, 3>;
template <int NN>
using NodeVec = Eigen::Matrix<double, 3 * NN, 1>;
template <int NN>
using NodeMat = Eigen::Matrix<double, 3 * NN, 3 * NN>;
template <int NN>
using Blocks = std::array<Eigen::Matrix<double, NN, NN>, 9>;

/// vec(δF) = B δu with vec row-major (3i + J) and δu node-major (3a + i): B(3i+J, 3a+i) = ∂N_a/∂X_J.
/// Bᵀ p written out so that the sparse structure of B is exploited.
template <int NN>
inline NodeVec<NN> BT_times(const NodeGrad<NN>& dN, const Vec9& p) {
  NodeVec<NN> out;
  for (int a = 0; a < NN; ++a)
    for (int i = 0; i < 3; ++i)
      out[3 * a + i] = dN(a, 0) * p[3 * i] + dN(a, 1) * p[3 * i + 1] + dN(a, 2) * p[3 * i + 2];
  return out;
}

/// Accumulates wBᵀ A B into nine NN×NN blocks, KB[3i + k](a, b) = K(3a + i, 3b + k), without forming B:
/// (Bᵀ A B)(3a+i, 3b+k) = Σ_JL dN_aJ A(3i+J, 3k+L) dN_bL. Two small dense products per (i, k) cost
/// a third of the dense 9×3NN product with M and write contiguously.
template <int NN>
inline void add_BtAB(const NodeGrad<NN>& dN, const Mat9& A, double w, Blocks<NN>& KB) {
  for (int i = 0; i < 3; ++i) {
    // E(a, 3k + L) = Σ_J dN_aJ A(3i + J, 3k + L)
    const Eigen::Matrix<double, NN, 9> E = (w * dN).lazyProduct(A.block<3, 9>(3 * i, 0));
    for (int k = 0; k < 3; ++k)
      KB[3 * i + k].noalias() += E.template block<NN, 3>(0, 3 * k).lazyProduct(dN.transpose());
  }
}

/// K += KB in the node-major layout.
template <int NN>
inline void scatter_blocks(const Blocks<NN>& KB, NodeMat<NN>& K) {
  for (int b = 0; b < NN; ++b)
    for (int k = 0; k < 3; ++k)
      for (int a = 0; a < NN; ++a)
        for (int i = 0; i < 3; ++i) K(3 * a + i, 3 * b + k) += KB[3 * i + k](a, b);
}

/// Deformation gradients at the points (F̄ for fbar) and the volume ratio θ; `Kinematics` has
/// std::array<Mat3, NQ> F, theta, ok.
template <int NN, int NQ, class Geometry, class Kinematics>
Kinematics solid_kinematics(const Geometry& g, const NodeGrad<NN>& u, Formulation f) {
  Kinematics k;
  std::array<double, NQ> J{};
  double v = 0.0;
  for (int q = 0; q < NQ; ++q) {
    k.F[q] = Mat3::Identity() + u.transpose() * g.dN[q];
    J[q] = k.F[q].determinant();
    if (!(J[q] > 0.0)) return k;
    v += g.w[q] * J[q];
  }
  k.theta = v / g.volume;
  if (f == Formulation::fbar)
    for (int q = 0; q < NQ; ++q) k.F[q] *= std::cbrt(k.theta / J[q]);
  k.ok = true;
  return k;
}

/// Internal force and consistent tangent (see hex8_internal_force). `Geometry` has dN[NQ] (NN×3),
/// w[NQ], volume; `Mixed` has bulk, theta, p (in) and theta_u, shift, shift_u, d (out).
template <int NN, int NQ, class Geometry, class Mixed>
MaterialStatus solid_internal_force(const Geometry& g, const NodeGrad<NN>& u, const Material& material,
                                    const double* state_old, double* state_new, double dt, Formulation f,
                                    NodeVec<NN>& r, NodeMat<NN>* K, Mat3* cauchy_mean, Mixed* mixed) {
  const int ns = material.state_size();
  const bool fbar = f == Formulation::fbar;
  std::array<Mat3, NQ> F;
  std::array<double, NQ> J;
  double volume_current = 0.0;
  for (int q = 0; q < NQ; ++q) {
    F[q] = Mat3::Identity() + u.transpose() * g.dN[q];
    J[q] = F[q].determinant();
    if (!(J[q] > 0.0)) return MaterialStatus::inverted;
    volume_current += g.w[q] * J[q];
  }
  const double theta = volume_current / g.volume;

  // Spatial gradients g_a = F⁻ᵀ ∇N_a (rows of gs), l = ∂(ln J)/∂u = vec(gs) node-major, d = ∂θ/∂u.
  // H = ∂²θ/∂u² = Σ_q c_q (l_q l_qᵀ − Q_q), Q_q[(a,i),(b,k)] = g_b,i g_a,k, is never formed: its
  // coefficient is known only after the loop, so the per-point matrices l lᵀ and Q are added once at
  // the end with their combined weights.
  std::array<NodeGrad<NN>, NQ> gs;
  std::array<double, NQ> cq{};
  NodeVec<NN> d = NodeVec<NN>::Zero();
  if (fbar) {
    for (int q = 0; q < NQ; ++q) {
      gs[q] = g.dN[q] * F[q].inverse();
      cq[q] = g.w[q] * J[q] / g.volume;
      for (int a = 0; a < NN; ++a)
        for (int i = 0; i < 3; ++i) d[3 * a + i] += cq[q] * gs[q](a, i);
    }
  }

  r.setZero();
  Blocks<NN> KB;
  std::array<double, NQ> q_coef{};  // coefficient of Q_q from the geometric term of F̄ (ws/3)
  if (K) {
    K->setZero();
    for (auto& m : KB) m.setZero();
  }
  double coef_H = 0.0, coef_dd = 0.0;
  Mat3 P;
  Mat9 A;
  for (int q = 0; q < NQ; ++q) {
    const double alpha = fbar ? std::cbrt(theta / J[q]) : 1.0;
    const Mat3 Fbar = alpha * F[q];
    const MaterialStatus st = material.evaluate(Fbar, ns ? state_old + q * ns : nullptr,
                                                ns ? state_new + q * ns : nullptr, dt, P, K ? &A : nullptr);
    if (st != MaterialStatus::ok) return st;
    if (cauchy_mean) {
      if (q == 0) cauchy_mean->setZero();
      *cauchy_mean += (g.w[q] / g.volume) * cauchy_from_piola(Fbar, P);
    }
    const Vec9 p = flatten(P);
    const NodeVec<NN> b = BT_times<NN>(g.dN[q], p);  // Bᵀ vec(P̄)
    const double w = g.w[q];
    if (!fbar) {
      r.noalias() += w * b;
      if (K) add_BtAB<NN>(g.dN[q], A, w, KB);
      continue;
    }
    // δF̄ = α [δF + (1/3)(c·δu) F],  c = d/θ − l.
    NodeVec<NN> c;
    for (int a = 0; a < NN; ++a)
      for (int i = 0; i < 3; ++i) c[3 * a + i] = d[3 * a + i] / theta - gs[q](a, i);
    const Vec9 fv = flatten(F[q]);
    const double s = p.dot(fv);  // P̄ : F
    r.noalias() += w * alpha * (b + (s / 3.0) * c);
    if (!K) continue;
    // K += w Mᵀ A M + geometric terms of F̄(u), M = α (B + (1/3) f cᵀ):
    //   Mᵀ A M = α² [Bᵀ A B + (1/3)(Bᵀ A f) cᵀ + (1/3) c (Bᵀ Aᵀ f)ᵀ + (1/9)(fᵀ A f) c cᵀ],
    // plus (wα/3)(b cᵀ + c bᵀ) + (ws/9) c cᵀ − (ws/(3θ²)) d dᵀ + (ws/3) Q_q + (ws/(3θ)) H.
    // All c-terms form one rank-2 update c u2ᵀ + u1 cᵀ.
    const double wa2 = w * alpha * alpha;
    add_BtAB<NN>(g.dN[q], A, wa2, KB);
    const Vec9 Af = A * fv, Atf = A.transpose() * fv;
    const double phi = fv.dot(Af);
    const double ws = w * alpha * s;
    const NodeVec<NN> common = (w * alpha / 3.0) * b + (0.5 * (ws + wa2 * phi) / 9.0) * c;
    const NodeVec<NN> u1 = (wa2 / 3.0) * BT_times<NN>(g.dN[q], Af) + common;
    const NodeVec<NN> u2 = (wa2 / 3.0) * BT_times<NN>(g.dN[q], Atf) + common;
    K->noalias() += u1 * c.transpose() + c * u2.transpose();
    coef_dd -= ws / (3.0 * theta * theta);
    q_coef[q] = ws / 3.0;
    coef_H += ws / (3.0 * theta);
  }
  if (fbar && mixed) {
    // Swap the F-bar volumetric terms V U′(θ_e) d, V (U″(θ_e) d dᵀ + U′(θ_e) H) for the condensed
    // three-field ones (see MixedVolume).
    const double V = g.volume, Kv = mixed->bulk, th = mixed->theta;
    const double p_tilde = volumetric_dU(Kv, th) + volumetric_d2U(Kv, th) * (theta - th);
    mixed->shift = V * (p_tilde - volumetric_dU(Kv, theta));
    mixed->shift_u = V * (p_tilde - mixed->p);
    mixed->theta_u = theta;
    mixed->d = d;
    r.noalias() += mixed->shift * d;
    if (K) {
      coef_H += V * (mixed->p - volumetric_dU(Kv, theta));
      coef_dd += V * (volumetric_d2U(Kv, th) - volumetric_d2U(Kv, theta));
    }
  }
  if (!K) return MaterialStatus::ok;
  scatter_blocks<NN>(KB, *K);
  if (!fbar) return MaterialStatus::ok;
  K->noalias() += coef_dd * d * d.transpose();
  // Σ_q [(q_coef_q − coef_H c_q) Q_q + coef_H c_q l_q l_qᵀ]: blocks (a, b) get γ g_b g_aᵀ + δ g_a g_bᵀ.
  for (int q = 0; q < NQ; ++q) {
    const double gamma = q_coef[q] - coef_H * cq[q], delta = coef_H * cq[q];
    const NodeGrad<NN>& G = gs[q];
    for (int b = 0; b < NN; ++b)
      for (int a = 0; a < NN; ++a)
        (*K).template block<3, 3>(3 * a, 3 * b).noalias() +=
            gamma * G.row(b).transpose() * G.row(a) + delta * G.row(a).transpose() * G.row(b);
  }
  return MaterialStatus::ok;
}

}  // namespace softhom::fe::detail
