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

  // Spatial gradients g_a = F⁻ᵀ ∇N_a (rows), l = ∂(ln J)/∂u, d = ∂θ/∂u, H = ∂²θ/∂u² (F-bar only).
  std::array<Mat83, 8> gs;
  Vec24 d = Vec24::Zero();
  Mat24 H;
  if (fbar) {
    if (K) H.setZero();
    for (int q = 0; q < 8; ++q) {
      gs[q] = g.dN[q] * F[q].inverse();
      Vec24 l;
      for (int a = 0; a < 8; ++a)
        for (int i = 0; i < 3; ++i) l[3 * a + i] = gs[q](a, i);
      const double c = g.w[q] * J[q] / g.volume;
      d += c * l;
      if (K) {
        H.noalias() += c * l * l.transpose();
        // Q[(a,i),(b,k)] = g_b,i g_a,k  (tr(δF F⁻¹ ΔF F⁻¹))
        for (int a = 0; a < 8; ++a)
          for (int b = 0; b < 8; ++b)
            for (int i = 0; i < 3; ++i)
              for (int k = 0; k < 3; ++k) H(3 * a + i, 3 * b + k) -= c * gs[q](b, i) * gs[q](a, k);
      }
    }
  }

  r.setZero();
  if (K) K->setZero();
  double coef_H = 0.0;
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
      if (K) {
        // Bᵀ A B with B sparse: (Bᵀ A B)(3a+i, 3b+k) = Σ_JL dN_aJ A(3i+J, 3k+L) dN_bL.
        Eigen::Matrix<double, 9, 24> AB;
        for (int row = 0; row < 9; ++row) AB.row(row) = BT_times(g.dN[q], A.row(row).transpose()).transpose();
        for (int col = 0; col < 24; ++col) K->col(col).noalias() += w * BT_times(g.dN[q], AB.col(col));
      }
      continue;
    }
    // δF̄ = α [δF + (1/3)(c·δu) F],  c = d/θ − l.
    Vec24 l;
    for (int a = 0; a < 8; ++a)
      for (int i = 0; i < 3; ++i) l[3 * a + i] = gs[q](a, i);
    const Vec24 c = d / theta - l;
    const Vec9 fv = flatten(F[q]);
    const double s = p.dot(fv);  // P̄ : F
    r.noalias() += w * alpha * (b + (s / 3.0) * c);
    if (!K) continue;
    // M = α (B + (1/3) f cᵀ); K += w Mᵀ A M + geometric terms of F̄(u).
    Eigen::Matrix<double, 9, 24> M;
    for (int row = 0; row < 9; ++row) {
      const int i = row / 3, J = row % 3;
      M.row(row) = (fv[row] / 3.0) * c.transpose();
      for (int a = 0; a < 8; ++a) M(row, 3 * a + i) += g.dN[q](a, J);
    }
    M *= alpha;
    const Eigen::Matrix<double, 9, 24> AM = A * M;
    K->noalias() += w * (M.transpose() * AM);
    const double ws = w * alpha * s;
    K->noalias() += (w * alpha / 3.0) * (b * c.transpose() + c * b.transpose());
    K->noalias() += (ws / 9.0) * c * c.transpose();
    K->noalias() -= (ws / (3.0 * theta * theta)) * d * d.transpose();
    // + (ws/3) Q_q
    for (int a = 0; a < 8; ++a)
      for (int bb = 0; bb < 8; ++bb)
        for (int i = 0; i < 3; ++i)
          for (int k = 0; k < 3; ++k) (*K)(3 * a + i, 3 * bb + k) += (ws / 3.0) * gs[q](bb, i) * gs[q](a, k);
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
      K->noalias() += (V * (volumetric_d2U(Kv, th) - volumetric_d2U(Kv, theta))) * d * d.transpose();
    }
  }
  if (fbar && K) K->noalias() += coef_H * H;
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
