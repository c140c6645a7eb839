// The fibers' 1D laws (fibers.hpp) and the host's uniaxial stress along a fiber (the volume correction).
#include <Eigen/Dense>
#include <cmath>

#include "softhom/fe/fibers.hpp"

namespace softhom::fe {

FiberForce fiber_force(const FiberLaw& law, double stretch) {
  if (law.cable && stretch < 1.0) return {};  // a slack cable carries nothing and resists nothing
  const double EA = law.modulus * law.area;
  switch (law.kind) {
    case FiberLawKind::linear: return {EA * (stretch - 1.0), EA};
    case FiberLawKind::neo_hookean: {
      const double l2 = stretch * stretch;
      return {EA / 3.0 * (stretch - 1.0 / l2), EA / 3.0 * (1.0 + 2.0 / (l2 * stretch))};
    }
  }
  return {};
}

namespace {

/// Two unit vectors completing T to an orthonormal frame.
std::array<Vec3, 2> lateral_frame(const Vec3& T) {
  const Vec3 seed = std::abs(T[0]) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
  const Vec3 n1 = T.cross(seed).normalized();
  return {n1, T.cross(n1)};
}

/// Row of the flattened tensor a ⊗ b (index 3 i + j).
Eigen::Matrix<double, 9, 1> dyad(const Vec3& a, const Vec3& b) {
  Eigen::Matrix<double, 9, 1> v;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) v[3 * i + j] = a[i] * b[j];
  return v;
}

}  // namespace

MaterialStatus uniaxial_nominal_stress(const Material& material, const Vec3& T, double stretch, FiberForce& out) {
  std::vector<double> state(std::size_t(material.state_size()), 0.0), scratch(state.size(), 0.0);
  if (!state.empty()) material.init_state(state.data());
  return uniaxial_nominal_stress(material, T, stretch, out, state.empty() ? nullptr : state.data(),
                                 scratch.empty() ? nullptr : scratch.data(), 0.0);
}

MaterialStatus uniaxial_nominal_stress(const Material& material, const Vec3& T, double stretch, FiberForce& out,
                                       const double* state_old, double* state_new, double dt) {
  const auto [n1, n2] = lateral_frame(T);
  const Eigen::Matrix<double, 9, 1> dT = dyad(T, T), d1 = dyad(n1, n1), d2 = dyad(n2, n2);
  Eigen::Vector2d y = Eigen::Vector2d::Constant(1.0 / std::sqrt(stretch));  // incompressible start
  Mat3 P;
  Mat9 A;
  const double scale = material.initial_shear_modulus() + material.initial_bulk_modulus();
  // Newton on the lateral stretches; once the residual is small one more step (quadratic convergence
  // takes it to round-off), then stop.
  bool polished = false;
  for (int iter = 0; iter < 60; ++iter) {
    const Mat3 F = stretch * T * T.transpose() + y[0] * n1 * n1.transpose() + y[1] * n2 * n2.transpose();
    const MaterialStatus s = material.evaluate(F, state_old, state_new, dt, P, &A);
    if (s != MaterialStatus::ok) return s;
    Eigen::Matrix<double, 9, 1> p;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) p[3 * i + j] = P(i, j);
    const Eigen::Vector2d g(d1.dot(p), d2.dot(p));
    Eigen::Matrix2d J;
    J << d1.dot(A * d1), d1.dot(A * d2), d2.dot(A * d1), d2.dot(A * d2);
    const Eigen::Vector2d b(d1.dot(A * dT), d2.dot(A * dT));
    const bool converged = polished || g.norm() <= 1e-15 * scale;
    if (converged || iter == 59) {
      // dP_TT/dλ with the lateral stretches following: A_TT − a_Lᵀ J⁻¹ b (a_L = ∂P_TT/∂y).
      const Eigen::Vector2d aL(dT.dot(A * d1), dT.dot(A * d2));
      out.force = dT.dot(p);
      out.stiffness = dT.dot(A * dT) - aL.dot(J.lu().solve(b));
      return converged ? MaterialStatus::ok : MaterialStatus::not_finite;
    }
    polished = g.norm() <= 1e-9 * scale;
    y -= J.lu().solve(g);
    if (!(y.minCoeff() > 0.0)) return MaterialStatus::inverted;
  }
  return MaterialStatus::not_finite;
}

}  // namespace softhom::fe
