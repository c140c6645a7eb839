// Fiber polylines of [[fibers]] tables (fiber_geometry.hpp): helices on a cylinder and straight families.
#include "softhom/macro/fiber_geometry.hpp"

#include <algorithm>
#include <cmath>

#include "softhom/core/input_error.hpp"

namespace softhom::macro {
namespace {

/// A curve sampled at `points` parameters t ∈ [0, 1] (equal arc length for helices and lines).
template <class Curve>
std::vector<Vec3> sample(const Curve& curve, int points) {
  std::vector<Vec3> out;
  for (int k = 0; k < points; ++k) out.push_back(curve(double(k) / (points - 1)));
  return out;
}

int elements_for(const FiberSpec& spec, double length, double default_length) {
  if (spec.elements > 0) return spec.elements;
  return std::max(1, int(std::ceil(length / std::max(default_length, 1e-12))));
}

}  // namespace

double helix_angle_deg(const FiberSpec& spec, double radius) {
  if (spec.pitch > 0.0) return std::atan(2.0 * M_PI * radius / spec.pitch) * 180.0 / M_PI;  // tan α = 2πr / pitch
  return spec.angle_deg;
}

fe::FiberLines fiber_lines(const FiberSpec& spec, double radius, double z_to, double default_length) {
  const std::string& f = spec.options.field;
  fe::FiberLines out;
  const int per_element = spec.options.order;  // points added per element
  if (spec.geometry == FiberGeometry::gmsh) {
    out.lines = spec.polylines;  // the file's lines are the elements
    return out;
  }
  if (spec.geometry == FiberGeometry::straight) {
    const double length = (spec.to - spec.from).norm();
    if (!(length > 0.0)) throw InputError(f + ".to", "", "must differ from " + f + ".from");
    const int points = per_element * elements_for(spec, length, default_length) + 1;
    for (int k = 0; k < spec.count; ++k) {
      const Vec3 shift = double(k) * spec.spacing;
      out.lines.push_back(sample([&](double t) { return Vec3(spec.from + t * (spec.to - spec.from) + shift); }, points));
    }
    return out;
  }
  if (!(radius > 0.0)) throw InputError(f + ".radius", format_number(radius), "must be positive");
  if (!(z_to > spec.z_from)) throw InputError(f + ".z_to", format_number(z_to), "must exceed z_from = " + format_number(spec.z_from));
  const double alpha = helix_angle_deg(spec, radius) * M_PI / 180.0;
  if (!(alpha >= 0.0 && alpha < 0.5 * M_PI - 1e-9))
    throw InputError(f + ".angle_deg", format_number(alpha * 180.0 / M_PI), "must lie in [0, 90)");
  const double height = z_to - spec.z_from, length = height / std::cos(alpha);
  const double turn = height * std::tan(alpha) / radius;  // angle swept [rad]
  const int points = per_element * elements_for(spec, length, default_length) + 1;
  std::vector<double> starts = spec.start_deg;
  if (starts.empty())
    for (int k = 0; k < spec.count; ++k) starts.push_back(360.0 * k / spec.count);
  const std::vector<double> signs = spec.geometry == FiberGeometry::double_helix ? std::vector<double>{1.0, -1.0}
                                                                                  : std::vector<double>{1.0};
  for (double sign : signs)
    for (double start : starts) {
      const double t0 = start * M_PI / 180.0;
      out.lines.push_back(sample(
          [&](double t) {
            // The +α family turns toward e_θ = e_z × e_r as z grows: (sin α, cos α) in (hoop, axial).
            const double th = t0 + sign * t * turn;
            return Vec3(radius * std::cos(th), radius * std::sin(th), spec.z_from + t * height);
          },
          points));
    }
  return out;
}

}  // namespace softhom::macro
