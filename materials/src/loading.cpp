#include "softhom/materials/loading.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <Eigen/Geometry>

#include "softhom/materials/errors.hpp"

namespace softhom {

double PiecewiseLinear::operator()(double time) const {
  if (time <= t.front()) return v.front();
  if (time >= t.back()) return v.back();
  const auto it = std::upper_bound(t.begin(), t.end(), time);
  const std::size_t k = std::size_t(it - t.begin());  // t[k-1] <= time < t[k]
  const double s = (time - t[k - 1]) / (t[k] - t[k - 1]);
  return v[k - 1] + s * (v[k] - v[k - 1]);
}

void MixedControl::validate() const {
  static const char* names[9] = {"F11", "F12", "F13", "F21", "F22", "F23", "F31", "F32", "F33"};
  for (int i = 0; i < 3; ++i)
    for (int j = i + 1; j < 3; ++j)
      if (kind[voigt9(i, j)] == ControlKind::stress && kind[voigt9(j, i)] == ControlKind::stress)
        throw InputError(std::string("load.") + names[voigt9(i, j)], "free",
                         std::string("both ") + names[voigt9(i, j)] + " and " + names[voigt9(j, i)] +
                             " are free: a rigid rotation is left undetermined; prescribe one of them (e.g. 0)");
  if (times.empty()) throw InputError("load.steps", "0", "no output steps");
  double previous = 0.0;
  for (std::size_t k = 0; k < times.size(); ++k) {
    if (!(times[k] > previous) || !std::isfinite(times[k]))
      throw InputError("load.times[" + std::to_string(k) + "]", format_number(times[k]),
                       "output times must be finite and strictly increasing from t > 0");
    previous = times[k];
  }
}

Mat3 MixedControl::prescribed_F(double time, const Mat3& free_guess) const {
  Mat3 F = free_guess;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (kind[voigt9(i, j)] == ControlKind::deformation) F(i, j) = value[voigt9(i, j)](time);
  return F;
}

Mat3 load_frame(const Vec3& direction, const Vec3& in_plane) {
  const Vec3 e1 = direction.normalized();
  Vec3 e2 = in_plane - in_plane.dot(e1) * e1;
  if (e2.norm() < 1e-12) {  // in_plane parallel to direction: pick any perpendicular
    e2 = (std::abs(e1.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY());
    e2 -= e2.dot(e1) * e1;
  }
  e2.normalize();
  Mat3 R;
  R.col(0) = e1;
  R.col(1) = e2;
  R.col(2) = e1.cross(e2);
  return R;
}

namespace {

// All-stress control with the given components switched to prescribed deformation.
MixedControl base_control(const Mat3& frame, const std::string& name) {
  MixedControl c;
  c.frame = frame;
  c.name = name;
  c.kind.fill(ControlKind::stress);
  for (auto& v : c.value) v = PiecewiseLinear::constant(0.0);
  return c;
}

void prescribe(MixedControl& c, int i, int j, const PiecewiseLinear& f) {
  c.kind[voigt9(i, j)] = ControlKind::deformation;
  c.value[voigt9(i, j)] = f;
}

}  // namespace

MixedControl uniaxial_control(const PiecewiseLinear& stretch, const Vec3& direction, const Vec3& in_plane) {
  MixedControl c = base_control(load_frame(direction, in_plane), "uniaxial");
  const auto zero = PiecewiseLinear::constant(0.0);
  prescribe(c, 0, 0, stretch);
  prescribe(c, 0, 1, zero);
  prescribe(c, 0, 2, zero);
  prescribe(c, 1, 2, zero);
  return c;
}

MixedControl equibiaxial_control(const PiecewiseLinear& stretch, const Mat3& frame) {
  MixedControl c = base_control(frame, "equibiaxial");
  const auto zero = PiecewiseLinear::constant(0.0);
  prescribe(c, 0, 0, stretch);
  prescribe(c, 1, 1, stretch);
  prescribe(c, 0, 1, zero);
  prescribe(c, 1, 0, zero);
  prescribe(c, 0, 2, zero);
  prescribe(c, 1, 2, zero);
  return c;
}

MixedControl pure_shear_control(const PiecewiseLinear& stretch, const Mat3& frame) {
  MixedControl c = equibiaxial_control(stretch, frame);
  c.name = "pure_shear";
  prescribe(c, 1, 1, PiecewiseLinear::constant(1.0));
  return c;
}

MixedControl simple_shear_control(const PiecewiseLinear& gamma, const Mat3& frame) {
  MixedControl c = base_control(frame, "simple_shear");
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) prescribe(c, i, j, PiecewiseLinear::constant(i == j ? 1.0 : 0.0));
  prescribe(c, 0, 1, gamma);
  return c;
}

double fiber_angle_deg(const Mat3& F, const Vec3& a0) {
  const Vec3 a = F * a0;
  double angle = std::atan2(a.x(), a.y()) * 180.0 / std::numbers::pi;
  // A fiber has no sense of direction: fold into (−90°, 90°].
  if (angle > 90.0) angle -= 180.0;
  if (angle <= -90.0) angle += 180.0;
  return angle;
}

}  // namespace softhom
