#include "softhom/fe/tet10_element.hpp"

#include "solid_kernel.hpp"

#include <cmath>

namespace softhom::fe {
namespace {

Mat3 cross_matrix(const Vec3& v) {
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
  return detail::solid_kinematics<10, 4, Tet10Geometry, Tet10Kinematics>(g, u, f);
}

MaterialStatus tet10_internal_force(const Tet10Geometry& g, const Tet10Coords& u, const Material& material,
                                    const double* state_old, double* state_new, double dt, Formulation f, Vec30& r,
                                    Mat30* K, Mat3* cauchy_mean, Tet10MixedVolume* mixed) {
  // The hex8 kernel with 10 nodes and 4 points (solid_kernel.hpp; derivation in hex8.hpp).
  return detail::solid_internal_force<10, 4>(g, u, material, state_old, state_new, dt, f, r, K, cauchy_mean, mixed);
}

void tri6_pressure(const Mat63& x, const Vec3& mask, Vec18& a, Mat18* da, double& flux, Vec18* dflux) {
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
  if (dflux) dflux->setZero();
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
    const Vec3 wv = mask.cwiseProduct(xp);
    flux += wv.dot(n);
    for (int k = 0; k < 6; ++k) a.segment<3>(3 * k) += N[k] * n;
    if (dflux)  // see quad4_pressure (n carries the weight w)
      for (int k = 0; k < 6; ++k)
        dflux->segment<3>(3 * k) += N[k] * mask.cwiseProduct(n) + w * (Nxi[k] * x_eta.cross(wv) + Neta[k] * wv.cross(x_xi));
    if (!da) continue;
    const Mat3 sx = w * cross_matrix(x_xi), se = w * cross_matrix(x_eta);
    for (int k = 0; k < 6; ++k)
      for (int m = 0; m < 6; ++m) da->block<3, 3>(3 * k, 3 * m) += N[k] * (Neta[m] * sx - Nxi[m] * se);
  }
}

}  // namespace softhom::fe
