#include "softhom/fe/hex8.hpp"

#include <cmath>

namespace softhom::fe {
namespace {

constexpr double kSign[8][3] = {{-1, -1, -1}, {1, -1, -1}, {1, 1, -1}, {-1, 1, -1},
                                {-1, -1, 1},  {1, -1, 1},  {1, 1, 1},  {-1, 1, 1}};
const double kGauss = 1.0 / std::sqrt(3.0);

Vec3 gauss_point(int g) { return kGauss * Vec3(kSign[g][0], kSign[g][1], kSign[g][2]); }

/// ∂N_a/∂ξ_J at ξ (8x3).
Mat83 shape_derivatives(const Vec3& xi) {
  Mat83 d;
  for (int a = 0; a < 8; ++a) {
    const double f0 = 1.0 + kSign[a][0] * xi[0], f1 = 1.0 + kSign[a][1] * xi[1], f2 = 1.0 + kSign[a][2] * xi[2];
    d(a, 0) = 0.125 * kSign[a][0] * f1 * f2;
    d(a, 1) = 0.125 * f0 * kSign[a][1] * f2;
    d(a, 2) = 0.125 * f0 * f1 * kSign[a][2];
  }
  return d;
}

/// vec(δF) = B δu with vec row-major (3i + J) and δu node-major (3a + i): B(3i+J, 3a+i) = ∂N_a/∂X_J.
/// Products with B are written out so that the sparse structure is exploited.
inline Vec24 BT_times(const Mat83& dN, const Vec9& p) {
  Vec24 out;
  for (int a = 0; a < 8; ++a)
    for (int i = 0; i < 3; ++i)
      out[3 * a + i] = dN(a, 0) * p[3 * i] + dN(a, 1) * p[3 * i + 1] + dN(a, 2) * p[3 * i + 2];
  return out;
}

}  // namespace

Eigen::Matrix<double, 8, 1> hex8_shape(const Vec3& xi) {
  Eigen::Matrix<double, 8, 1> N;
  for (int a = 0; a < 8; ++a)
    N[a] = 0.125 * (1 + kSign[a][0] * xi[0]) * (1 + kSign[a][1] * xi[1]) * (1 + kSign[a][2] * xi[2]);
  return N;
}

Hex8Geometry hex8_geometry(const Mat83& X) {
  Hex8Geometry g;
  g.valid = true;
  for (int q = 0; q < 8; ++q) {
    const Mat83 dxi = shape_derivatives(gauss_point(q));
    const Mat3 Jm = X.transpose() * dxi;  // ∂X_I/∂ξ_J
    const double det = Jm.determinant();
    if (!(det > 0.0)) g.valid = false;
    g.w[q] = det;  // Gauss weights are 1 for the 2-point rule
    g.dN[q] = det > 0.0 ? Mat83(dxi * Jm.inverse()) : Mat83::Zero();
    g.volume += det;
  }
  return g;
}

Hex8Kinematics hex8_kinematics(const Hex8Geometry& g, const Mat83& u, Formulation f) {
  Hex8Kinematics k;
  std::array<double, 8> J{};
  double v = 0.0;
  for (int q = 0; q < 8; ++q) {
    k.F[q] = Mat3::Identity() + u.transpose() * g.dN[q];
    J[q] = k.F[q].determinant();
    if (!(J[q] > 0.0)) return k;
    v += g.w[q] * J[q];
  }
  k.theta = v / g.volume;
  if (f == Formulation::fbar)
    for (int q = 0; q < 8; ++q) k.F[q] *= std::cbrt(k.theta / J[q]);
  k.ok = true;
  return k;
}

namespace {

/// Accumulates wBᵀ A B into nine 8x8 blocks, KB[3i + k](a, b) = K(3a + i, 3b + k), without forming B:
/// (Bᵀ A B)(3a+i, 3b+k) = Σ_JL dN_aJ A(3i+J, 3k+L) dN_bL. Two small dense products per (i, k) cost
/// 2.4k multiply-adds per Gauss point instead of 7k for the dense 9x24 M, and write contiguously.
inline void add_BtAB(const Mat83& dN, const Mat9& A, double w, std::array<Eigen::Matrix<double, 8, 8>, 9>& KB) {
  for (int i = 0; i < 3; ++i) {
    // E(a, 3k + L) = Σ_J dN_aJ A(3i + J, 3k + L)
    const Eigen::Matrix<double, 8, 9> E = (w * dN).lazyProduct(A.block<3, 9>(3 * i, 0));
    for (int k = 0; k < 3; ++k) KB[3 * i + k].noalias() += E.block<8, 3>(0, 3 * k).lazyProduct(dN.transpose());
  }
}

/// K += KB in the node-major layout.
inline void scatter_blocks(const std::array<Eigen::Matrix<double, 8, 8>, 9>& KB, Mat24& K) {
  for (int b = 0; b < 8; ++b)
    for (int k = 0; k < 3; ++k)
      for (int a = 0; a < 8; ++a)
        for (int i = 0; i < 3; ++i) K(3 * a + i, 3 * b + k) += KB[3 * i + k](a, b);
}

}  // namespace

MaterialStatus hex8_internal_force(const Hex8Geometry& g, const Mat83& u, const Material& material,
                                   const double* state_old, double* state_new, double dt, Formulation f,
                                   Vec24& r, Mat24* K, Mat3* cauchy_mean, MixedVolume* mixed) {
  const int ns = material.state_size();
  const bool fbar = f == Formulation::fbar;
  std::array<Mat3, 8> F;
  std::array<double, 8> J;
  double volume_current = 0.0;
  for (int q = 0; q < 8; ++q) {
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
  std::array<Mat83, 8> gs;
  std::array<double, 8> cq{};
  Vec24 d = Vec24::Zero();
  if (fbar) {
    for (int q = 0; q < 8; ++q) {
      gs[q] = g.dN[q] * F[q].inverse();
      cq[q] = g.w[q] * J[q] / g.volume;
      for (int a = 0; a < 8; ++a)
        for (int i = 0; i < 3; ++i) d[3 * a + i] += cq[q] * gs[q](a, i);
    }
  }

  r.setZero();
  std::array<Eigen::Matrix<double, 8, 8>, 9> KB;
  std::array<double, 8> q_coef{};  // coefficient of Q_q from the geometric term of F̄ (ws/3)
  if (K) {
    K->setZero();
    for (auto& m : KB) m.setZero();
  }
  double coef_H = 0.0, coef_dd = 0.0;
  Mat3 P;
  Mat9 A;
  for (int q = 0; q < 8; ++q) {
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
    const Vec24 b = BT_times(g.dN[q], p);  // Bᵀ vec(P̄)
    const double w = g.w[q];
    if (!fbar) {
      r.noalias() += w * b;
      if (K) add_BtAB(g.dN[q], A, w, KB);
      continue;
    }
    // δF̄ = α [δF + (1/3)(c·δu) F],  c = d/θ − l.
    Vec24 c;
    for (int a = 0; a < 8; ++a)
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
    add_BtAB(g.dN[q], A, wa2, KB);
    const Vec9 Af = A * fv, Atf = A.transpose() * fv;
    const double phi = fv.dot(Af);
    const double ws = w * alpha * s;
    const Vec24 common = (w * alpha / 3.0) * b + (0.5 * (ws + wa2 * phi) / 9.0) * c;
    const Vec24 u1 = (wa2 / 3.0) * BT_times(g.dN[q], Af) + common;
    const Vec24 u2 = (wa2 / 3.0) * BT_times(g.dN[q], Atf) + common;
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
  scatter_blocks(KB, *K);
  if (!fbar) return MaterialStatus::ok;
  K->noalias() += coef_dd * d * d.transpose();
  // Σ_q [(q_coef_q − coef_H c_q) Q_q + coef_H c_q l_q l_qᵀ]: blocks (a, b) get γ g_b g_aᵀ + δ g_a g_bᵀ.
  for (int q = 0; q < 8; ++q) {
    const double gamma = q_coef[q] - coef_H * cq[q], delta = coef_H * cq[q];
    const Mat83& G = gs[q];
    for (int b = 0; b < 8; ++b)
      for (int a = 0; a < 8; ++a)
        (*K).block<3, 3>(3 * a, 3 * b).noalias() +=
            gamma * G.row(b).transpose() * G.row(a) + delta * G.row(a).transpose() * G.row(b);
  }
  return MaterialStatus::ok;
}

void quad4_pressure(const Mat43& x, const Vec3& mask, Vec12& a, Mat12* da, double& flux) {
  static const double s[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
  a.setZero();
  if (da) da->setZero();
  flux = 0.0;
  for (int gi = 0; gi < 2; ++gi)
    for (int gj = 0; gj < 2; ++gj) {
      const double xi = (gi ? 1 : -1) * kGauss, eta = (gj ? 1 : -1) * kGauss;
      Eigen::Matrix<double, 4, 1> N, Nxi, Neta;
      for (int k = 0; k < 4; ++k) {
        N[k] = 0.25 * (1 + s[k][0] * xi) * (1 + s[k][1] * eta);
        Nxi[k] = 0.25 * s[k][0] * (1 + s[k][1] * eta);
        Neta[k] = 0.25 * (1 + s[k][0] * xi) * s[k][1];
      }
      const Vec3 xp = x.transpose() * N, x_xi = x.transpose() * Nxi, x_eta = x.transpose() * Neta;
      const Vec3 n = x_xi.cross(x_eta);  // area vector density (weights are 1)
      flux += mask.cwiseProduct(xp).dot(n);
      for (int k = 0; k < 4; ++k) a.segment<3>(3 * k) += N[k] * n;
      if (!da) continue;
      auto skew = [](const Vec3& v) {
        Mat3 m;
        m << 0, -v[2], v[1], v[2], 0, -v[0], -v[1], v[0], 0;
        return m;
      };
      const Mat3 sx = skew(x_xi), se = skew(x_eta);
      for (int k = 0; k < 4; ++k)
        for (int m = 0; m < 4; ++m)
          da->block<3, 3>(3 * k, 3 * m) += N[k] * (Neta[m] * sx - Nxi[m] * se);
    }
}

}  // namespace softhom::fe
