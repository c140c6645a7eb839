#include "softhom/fe/tet10_element.hpp"

#include <cmath>

namespace softhom::fe {
namespace {

/// vec(δF) = B δu (row-major vec, node-major δu): Bᵀ p written out to use the sparsity of B.
inline Vec30 BT_times(const Tet10Grad& dN, const Vec9& p) {
  Vec30 out;
  for (int a = 0; a < 10; ++a)
    for (int i = 0; i < 3; ++i)
      out[3 * a + i] = dN(a, 0) * p[3 * i] + dN(a, 1) * p[3 * i + 1] + dN(a, 2) * p[3 * i + 2];
  return out;
}

/// K(3a+i, 3b+k) += c g_b,i g_a,k: the second variation of ln J, tr(δF F⁻¹ ΔF F⁻¹), in spatial gradients.
inline void add_q(Mat30& K, double c, const Tet10Grad& gs) {
  for (int b = 0; b < 10; ++b)
    for (int a = 0; a < 10; ++a)
      K.block<3, 3>(3 * a, 3 * b).noalias() += c * gs.row(b).transpose() * gs.row(a);
}

Mat3 skew(const Vec3& v) {
  Mat3 m;
  m << 0, -v[2], v[1], v[2], 0, -v[0], -v[1], v[0], 0;
  return m;
}

}  // namespace

Tet10Geometry tet10_geometry(const Tet10Coords& X) {
  Tet10Geometry g;
  g.valid = true;
  const auto rule = tet_rule_degree2();
  for (int q = 0; q < 4; ++q) {
    const Tet10Grad dxi = tet10_shape_derivatives(rule[q].xi);
    const Mat3 Jm = X.transpose() * dxi;  // ∂X_I/∂ξ_J
    const double det = Jm.determinant();
    if (!(det > 0.0)) g.valid = false;
    g.w[q] = rule[q].w * det;
    g.dN[q] = det > 0.0 ? Tet10Grad(dxi * Jm.inverse()) : Tet10Grad::Zero();
    g.volume += g.w[q];
  }
  return g;
}

Tet10Kinematics tet10_kinematics(const Tet10Geometry& g, const Tet10Coords& u, Formulation f) {
  Tet10Kinematics k;
  std::array<double, 4> J{};
  double v = 0.0;
  for (int q = 0; q < 4; ++q) {
    k.F[q] = Mat3::Identity() + u.transpose() * g.dN[q];
    J[q] = k.F[q].determinant();
    if (!(J[q] > 0.0)) return k;
    v += g.w[q] * J[q];
  }
  k.theta = v / g.volume;
  if (f == Formulation::fbar)
    for (int q = 0; q < 4; ++q) k.F[q] *= std::cbrt(k.theta / J[q]);
  k.ok = true;
  return k;
}

MaterialStatus tet10_internal_force(const Tet10Geometry& g, const Tet10Coords& u, const Material& material,
                                    const double* state_old, double* state_new, double dt, Formulation f, Vec30& r,
                                    Mat30* K, Mat3* cauchy_mean, Tet10MixedVolume* mixed) {
  // The hex8 kernel (hex8.cpp) with 10 nodes and 4 points; see hex8.hpp for the derivation.
  const int ns = material.state_size();
  const bool fbar = f == Formulation::fbar;
  std::array<Mat3, 4> F;
  std::array<double, 4> J;
  double volume_current = 0.0;
  for (int q = 0; q < 4; ++q) {
    F[q] = Mat3::Identity() + u.transpose() * g.dN[q];
    J[q] = F[q].determinant();
    if (!(J[q] > 0.0)) return MaterialStatus::inverted;
    volume_current += g.w[q] * J[q];
  }
  const double theta = volume_current / g.volume;

  // Spatial gradients g_a = F⁻ᵀ ∇N_a (rows), l = ∂(ln J)/∂u, d = ∂θ/∂u, H = ∂²θ/∂u².
  std::array<Tet10Grad, 4> gs;
  std::array<Vec30, 4> ls;
  Vec30 d = Vec30::Zero();
  Mat30 H;
  if (fbar) {
    if (K) H.setZero();
    for (int q = 0; q < 4; ++q) {
      gs[q] = g.dN[q] * F[q].inverse();
      for (int a = 0; a < 10; ++a)
        for (int i = 0; i < 3; ++i) ls[q][3 * a + i] = gs[q](a, i);
      const double c = g.w[q] * J[q] / g.volume;
      d += c * ls[q];
      if (K) {
        H.noalias() += c * ls[q] * ls[q].transpose();
        add_q(H, -c, gs[q]);
      }
    }
  }

  r.setZero();
  if (K) K->setZero();
  double coef_H = 0.0;
  Mat3 P;
  Mat9 A;
  for (int q = 0; q < 4; ++q) {
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
    const Vec30 b = BT_times(g.dN[q], p);
    const double w = g.w[q];
    if (!fbar) {
      r.noalias() += w * b;
      if (K) {
        Eigen::Matrix<double, 9, 30> AB;
        for (int row = 0; row < 9; ++row) AB.row(row) = BT_times(g.dN[q], A.row(row).transpose()).transpose();
        for (int col = 0; col < 30; ++col) K->col(col).noalias() += w * BT_times(g.dN[q], AB.col(col));
      }
      continue;
    }
    // δF̄ = α [δF + (1/3)(c·δu) F],  c = d/θ − l.
    const Vec30 c = d / theta - ls[q];
    const Vec9 fv = flatten(F[q]);
    const double s = p.dot(fv);  // P̄ : F
    r.noalias() += w * alpha * (b + (s / 3.0) * c);
    if (!K) continue;
    Eigen::Matrix<double, 9, 30> M;
    for (int row = 0; row < 9; ++row) {
      const int i = row / 3, Jc = row % 3;
      M.row(row) = (fv[row] / 3.0) * c.transpose();
      for (int a = 0; a < 10; ++a) M(row, 3 * a + i) += g.dN[q](a, Jc);
    }
    M *= alpha;
    const Eigen::Matrix<double, 9, 30> AM = A * M;
    K->noalias() += w * (M.transpose() * AM);
    const double ws = w * alpha * s;
    K->noalias() += (w * alpha / 3.0) * (b * c.transpose() + c * b.transpose());
    K->noalias() += (ws / 9.0) * c * c.transpose();
    K->noalias() -= (ws / (3.0 * theta * theta)) * d * d.transpose();
    add_q(*K, ws / 3.0, gs[q]);
    coef_H += ws / (3.0 * theta);
  }
  if (fbar && mixed) {
    const double V = g.volume, Kv = mixed->bulk, th = mixed->theta;
    const double p_tilde = volumetric_dU(Kv, th) + volumetric_d2U(Kv, th) * (theta - th);
    mixed->shift = V * (p_tilde - volumetric_dU(Kv, theta));
    mixed->shift_u = V * (p_tilde - mixed->p);
    mixed->theta_u = theta;
    mixed->d = d;
    r.noalias() += mixed->shift * d;
    if (K) {
      coef_H += V * (mixed->p - volumetric_dU(Kv, theta));
      K->noalias() += (V * (volumetric_d2U(Kv, th) - volumetric_d2U(Kv, theta))) * d * d.transpose();
    }
  }
  if (fbar && K) K->noalias() += coef_H * H;
  return MaterialStatus::ok;
}

void tri6_pressure(const Mat63& x, const Vec3& mask, Vec18& a, Mat18* da, double& flux) {
  // Dunavant's 6-point degree-4 rule (weights for unit area; the reference triangle has area 1/2):
  // N_a (quadratic) × n (quadratic in ξ) is degree 4, so a_a and the flux are integrated exactly.
  static const double kPts[6][3] = {
      {0.108103018168070, 0.445948490915965, 0.445948490915965}, {0.445948490915965, 0.108103018168070, 0.445948490915965},
      {0.445948490915965, 0.445948490915965, 0.108103018168070}, {0.816847572980459, 0.091576213509771, 0.091576213509771},
      {0.091576213509771, 0.816847572980459, 0.091576213509771}, {0.091576213509771, 0.091576213509771, 0.816847572980459}};
  static const double kW[6] = {0.223381589678011, 0.223381589678011, 0.223381589678011,
                               0.109951743655322, 0.109951743655322, 0.109951743655322};
  a.setZero();
  if (da) da->setZero();
  flux = 0.0;
  for (int g = 0; g < 6; ++g) {
    const double L0 = kPts[g][0], L1 = kPts[g][1], L2 = kPts[g][2], w = 0.5 * kW[g];
    Eigen::Matrix<double, 6, 1> N, Nxi, Neta;
    N << L0 * (2 * L0 - 1), L1 * (2 * L1 - 1), L2 * (2 * L2 - 1), 4 * L0 * L1, 4 * L1 * L2, 4 * L2 * L0;
    // ξ = L1, η = L2, L0 = 1 − ξ − η.
    Nxi << -(4 * L0 - 1), 4 * L1 - 1, 0.0, 4 * (L0 - L1), 4 * L2, -4 * L2;
    Neta << -(4 * L0 - 1), 0.0, 4 * L2 - 1, -4 * L1, 4 * L1, 4 * (L0 - L2);
    const Vec3 xp = x.transpose() * N, x_xi = x.transpose() * Nxi, x_eta = x.transpose() * Neta;
    const Vec3 n = w * x_xi.cross(x_eta);
    flux += mask.cwiseProduct(xp).dot(n);
    for (int k = 0; k < 6; ++k) a.segment<3>(3 * k) += N[k] * n;
    if (!da) continue;
    const Mat3 sx = w * skew(x_xi), se = w * skew(x_eta);
    for (int k = 0; k < 6; ++k)
      for (int m = 0; m < 6; ++m) da->block<3, 3>(3 * k, 3 * m) += N[k] * (Neta[m] * sx - Nxi[m] * se);
  }
}

}  // namespace softhom::fe
