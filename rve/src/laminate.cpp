// Rank-one laminate rule of composite voxels (see laminate.hpp).
#include "laminate.hpp"

#include <cmath>
#include <limits>

#include <Eigen/Dense>

namespace softhom::rve::detail {

MaterialStatus laminate_point(const LaminatePoint& pt, const Mat3& F, double f, const Vec3& n, Vec3& a, double dt,
                              Mat3& P, Mat9* A, Mat3 Px[2], Mat3 Fx[2]) {
  Mat9 Ax[2];
  const Material* const* mat = pt.phase;
  const double* const* ho = pt.state_old;
  double* const* hn = pt.state_new;
  const double K_max = pt.K_max;
  Vec3 a_prev = a;
  Eigen::Matrix3d Q;
  bool have_previous = false;
  double r_prev = std::numeric_limits<double>::infinity();
  for (int it = 0; it < 40; ++it) {
    Fx[1] = F + (1.0 - f) * a * n.transpose();
    Fx[0] = F - f * a * n.transpose();
    MaterialStatus s1 = mat[1]->evaluate(Fx[1], ho[1], hn[1], dt, Px[1], &Ax[1]);
    MaterialStatus s0 = s1 == MaterialStatus::ok ? mat[0]->evaluate(Fx[0], ho[0], hn[0], dt, Px[0], &Ax[0]) : s1;
    if (s0 != MaterialStatus::ok || s1 != MaterialStatus::ok) {
      if (!have_previous) return s0 != MaterialStatus::ok ? s0 : s1;
      a = a_prev + 0.5 * (a - a_prev);  // damp the laminate Newton step
      continue;
    }
    const Vec3 r = (Px[1] - Px[0]) * n;
    for (int i = 0; i < 3; ++i)
      for (int k = 0; k < 3; ++k) {
        double s = 0.0;
        for (int j = 0; j < 3; ++j)
          for (int l = 0; l < 3; ++l)
            s += ((1.0 - f) * Ax[1](3 * i + j, 3 * k + l) + f * Ax[0](3 * i + j, 3 * k + l)) * n[j] * n[l];
        Q(i, k) = s;
      }
    // Relative tolerance plus the round-off floor of stresses ~ K (J − 1) (K/G up to 1e5 here).
    const double scale = (Px[1] * n).norm() + (Px[0] * n).norm();
    const double floor = 32.0 * std::numeric_limits<double>::epsilon() * K_max * (1.0 + F.cwiseAbs().maxCoeff());
    const double rn = r.norm();
    if (rn <= 1e-13 * scale + floor) break;
    // Stagnation at round-off level is convergence too.
    if (it >= 3 && rn <= 1e-9 * scale && rn > 0.25 * r_prev) break;
    r_prev = rn;
    if (it == 39) return MaterialStatus::not_finite;  // no traction continuity: treat as a failed call
    a_prev = a;
    have_previous = true;
    a -= Q.inverse() * r;
  }
  P = f * Px[1] + (1.0 - f) * Px[0];
  if (A) {
    const Mat9 D = Ax[1] - Ax[0];
    Eigen::Matrix<double, 3, 9> Tm;   // (D dF) n
    Eigen::Matrix<double, 9, 3> Um;   // D (da ⊗ n)
    for (int i = 0; i < 3; ++i)
      for (int c = 0; c < 9; ++c) {
        double s = 0.0;
        for (int j = 0; j < 3; ++j) s += D(3 * i + j, c) * n[j];
        Tm(i, c) = s;
      }
    for (int c = 0; c < 9; ++c)
      for (int k = 0; k < 3; ++k) {
        double s = 0.0;
        for (int l = 0; l < 3; ++l) s += D(c, 3 * k + l) * n[l];
        Um(c, k) = s;
      }
    *A = f * Ax[1] + (1.0 - f) * Ax[0] - f * (1.0 - f) * Um * Q.inverse() * Tm;
  }
  return MaterialStatus::ok;
}

Vec3 estimate_interface_normal(const PhaseImage& im, std::size_t v) {
  const int n1 = im.n[0], n2 = im.n[1], n3 = im.n[2];
  const int i1 = int(v % n1), i2 = int((v / n1) % n2), i3 = int(v / (std::size_t(n1) * n2));
  auto at = [&](int a, int b, int c) { return im.fiber_fraction[im.index_of(a, b, c)]; };  // periodic; a slab's halo
  Vec3 g(n1 > 1 ? (at(i1 + 1, i2, i3) - at(i1 - 1, i2, i3)) * n1 / im.size[0] : 0.0,
         n2 > 1 ? (at(i1, i2 + 1, i3) - at(i1, i2 - 1, i3)) * n2 / im.size[1] : 0.0,
         n3 > 1 ? (at(i1, i2, i3 + 1) - at(i1, i2, i3 - 1)) * n3 / im.size[2] : 0.0);
  return g.norm() > 0.0 ? Vec3(-g.normalized()) : Vec3::Zero();
}

}  // namespace softhom::rve::detail
