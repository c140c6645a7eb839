// The thin-walled kinematic model of a fiber-reinforced tube (fiber_tube_model.hpp).
#include "softhom/macro/fiber_tube_model.hpp"

#include <Eigen/Dense>
#include <cmath>

namespace softhom::macro {
namespace {

/// Π per unit length and π of the tube at (λ_z, κ), with λ_θ from the (+α) fiber's inextensibility.
double potential(const ThinTube& t, double pressure, double lz, double kappa, double* hoop = nullptr) {
  const double a = t.angle_deg * M_PI / 180.0, ca = std::cos(a), sa = std::sin(a);
  const double along = 1.0 - lz * ca * lz * ca;
  if (!(along > 0.0)) return INFINITY;
  const double lt = (std::sqrt(along) - kappa * ca) / sa;
  if (!(lt > 0.0)) return INFINITY;
  if (hoop) *hoop = lt;
  const double Ri = t.inner_radius, Ro = t.outer_radius, R = 0.5 * (Ri + Ro);
  const double I1 = lt * lt + kappa * kappa + lz * lz + 1.0 / (lt * lt * lz * lz);
  const double wall = (Ro * Ro - Ri * Ri) * 0.5 * t.shear_modulus * (I1 - 3.0);
  const double ri2 = (lt * R) * (lt * R) - (R * R - Ri * Ri) / lz;  // incompressible wall between R_i and R
  return wall - pressure * ri2 * lz;
}

}  // namespace

ThinTubeState thin_tube_state(const ThinTube& t, double pressure) {
  // Unknowns y = (λ_z, κ) (κ ≡ 0 for a double helix): Newton on ∇Π = 0 with central differences,
  // continued from p = 0 in small increments so each solve starts near its solution.
  Eigen::Vector2d y(1.0, 0.0);
  const int dim = t.double_helix ? 1 : 2;
  const int increments = 40;
  const double h = 1e-5;
  auto Pi = [&](const Eigen::Vector2d& v, double p) { return potential(t, p, v[0], v[1]); };
  for (int inc = 1; inc <= increments; ++inc) {
    const double p = pressure * inc / increments;
    for (int iter = 0; iter < 50; ++iter) {
      Eigen::Vector2d g = Eigen::Vector2d::Zero();
      Eigen::Matrix2d H = Eigen::Matrix2d::Identity();
      for (int i = 0; i < dim; ++i) {
        Eigen::Vector2d e = Eigen::Vector2d::Zero();
        e[i] = h;
        g[i] = (Pi(y + e, p) - Pi(y - e, p)) / (2 * h);
        for (int j = 0; j < dim; ++j) {
          Eigen::Vector2d f = Eigen::Vector2d::Zero();
          f[j] = h;
          H(i, j) = (Pi(y + e + f, p) - Pi(y + e - f, p) - Pi(y - e + f, p) + Pi(y - e - f, p)) / (4 * h * h);
        }
      }
      Eigen::Vector2d step = -H.lu().solve(g);
      if (dim == 1) step[1] = 0.0;
      // Halve a step that leaves the constraint's domain or raises Π.
      double s = 1.0;
      while (s > 1e-6 && !(Pi(y + s * step, p) <= Pi(y, p) + 1e-14)) s *= 0.5;
      y += s * step;
      if (step.norm() < 1e-11) break;
    }
  }
  ThinTubeState out;
  out.axial_stretch = y[0];
  potential(t, pressure, y[0], y[1], &out.hoop_stretch);
  const double R = 0.5 * (t.inner_radius + t.outer_radius);
  out.twist_per_length = y[1] / (out.hoop_stretch * R);
  const double a = t.angle_deg * M_PI / 180.0;
  out.fiber_angle_deg = std::atan2(out.hoop_stretch * std::sin(a) + y[1] * std::cos(a), y[0] * std::cos(a)) * 180.0 / M_PI;
  return out;
}

}  // namespace softhom::macro
