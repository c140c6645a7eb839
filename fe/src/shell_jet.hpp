#pragma once
// Second-order forward differentiation for the shell kinematics: a value with its gradient and Hessian
// with respect to the 18 coordinates of a patch. The strains are short algebraic expressions (a cross
// product, a norm, dot products), so carrying exact second derivatives through them is cheaper and
// safer than writing each term of ∂²κ/∂x² out by hand.
#include <cmath>

#include <Eigen/Core>

namespace softhom::fe::detail {

struct Jet {
  using G = Eigen::Matrix<double, 18, 1>;
  using H = Eigen::Matrix<double, 18, 18>;
  double v = 0.0;
  G g = G::Zero();
  H h = H::Zero();

  Jet() = default;
  Jet(double value) : v(value) {}  // NOLINT: constants mix with jets
  /// The coordinate `index` itself.
  static Jet variable(double value, int index) {
    Jet j(value);
    j.g[index] = 1.0;
    return j;
  }
};

inline Jet operator+(const Jet& a, const Jet& b) {
  Jet r;
  r.v = a.v + b.v;
  r.g = a.g + b.g;
  r.h = a.h + b.h;
  return r;
}
inline Jet operator-(const Jet& a, const Jet& b) {
  Jet r;
  r.v = a.v - b.v;
  r.g = a.g - b.g;
  r.h = a.h - b.h;
  return r;
}
inline Jet operator*(double s, const Jet& a) {
  Jet r;
  r.v = s * a.v;
  r.g = s * a.g;
  r.h = s * a.h;
  return r;
}
inline Jet operator*(const Jet& a, double s) { return s * a; }
inline Jet operator*(const Jet& a, const Jet& b) {
  Jet r;
  r.v = a.v * b.v;
  r.g = a.v * b.g + b.v * a.g;
  r.h = a.v * b.h + b.v * a.h + a.g * b.g.transpose() + b.g * a.g.transpose();
  return r;
}
inline Jet& operator+=(Jet& a, const Jet& b) {
  a.v += b.v;
  a.g += b.g;
  a.h += b.h;
  return a;
}
/// f(a) by the chain rule, with f, f′, f″ at a.v.
inline Jet chain(const Jet& a, double f, double d1, double d2) {
  Jet r;
  r.v = f;
  r.g = d1 * a.g;
  r.h = d1 * a.h + d2 * a.g * a.g.transpose();
  return r;
}
inline Jet sqrt(const Jet& a) {
  const double s = std::sqrt(a.v);
  return chain(a, s, 0.5 / s, -0.25 / (s * a.v));
}
inline Jet reciprocal(const Jet& a) {
  const double r = 1.0 / a.v;
  return chain(a, r, -r * r, 2.0 * r * r * r);
}

inline double value(double a) { return a; }
inline double value(const Jet& a) { return a.v; }
inline double reciprocal(double a) { return 1.0 / a; }

}  // namespace softhom::fe::detail
