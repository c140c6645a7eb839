#include "softhom/fe/hex8.hpp"

#include "solid_kernel.hpp"

#include <cmath>

namespace softhom::fe {
namespace {

constexpr double kSign[8][3] = {{-1, -1, -1}, {1, -1, -1}, {1, 1, -1}, {-1, 1, -1},
                                {-1, -1, 1},  {1, -1, 1},  {1, 1, 1},  {-1, 1, 1}};
const double kGauss = 1.0 / std::sqrt(3.0);

Vec3 gauss_point(int g) { return kGauss * Vec3(kSign[g][0], kSign[g][1], kSign[g][2]); }

}  // namespace

Mat83 hex8_shape_derivatives(const Vec3& xi) {
  Mat83 d;
  for (int a = 0; a < 8; ++a) {
    const double f0 = 1.0 + kSign[a][0] * xi[0], f1 = 1.0 + kSign[a][1] * xi[1], f2 = 1.0 + kSign[a][2] * xi[2];
    d(a, 0) = 0.125 * kSign[a][0] * f1 * f2;
    d(a, 1) = 0.125 * f0 * kSign[a][1] * f2;
    d(a, 2) = 0.125 * f0 * f1 * kSign[a][2];
  }
  return d;
}

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
    const Mat83 dxi = hex8_shape_derivatives(gauss_point(q));
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
  return detail::solid_kinematics<8, 8, Hex8Geometry, Hex8Kinematics>(g, u, f);
}

MaterialStatus hex8_internal_force(const Hex8Geometry& g, const Mat83& u, const Material& material,
                                   const double* state_old, double* state_new, double dt, Formulation f,
                                   Vec24& r, Mat24* K, Mat3* cauchy_mean, MixedVolume* mixed) {
  return detail::solid_internal_force<8, 8>(g, u, material, state_old, state_new, dt, f, r, K, cauchy_mean, mixed);
}

void quad4_pressure(const Mat43& x, const Vec3& mask, Vec12& a, Mat12* da, double& flux, Vec12* dflux) {
  static const double s[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
  a.setZero();
  if (da) da->setZero();
  if (dflux) dflux->setZero();
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
      const Vec3 wv = mask.cwiseProduct(xp);
      flux += wv.dot(n);
      for (int k = 0; k < 4; ++k) a.segment<3>(3 * k) += N[k] * n;
      if (dflux)  // δ(w·(x_ξ × x_η)) = δw·n + δx_ξ·(x_η × w) + δx_η·(w × x_ξ)
        for (int k = 0; k < 4; ++k)
          dflux->segment<3>(3 * k) += N[k] * mask.cwiseProduct(n) + Nxi[k] * x_eta.cross(wv) + Neta[k] * wv.cross(x_xi);
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
