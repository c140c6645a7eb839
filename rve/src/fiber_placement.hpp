#pragma once
// Fibers of a periodic section placed in the plane (with the periodic images that reach into the
// cell) and their signed distance: shared by the 2D section mesher and the 3D cell mesher.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Core>

#include "softhom/rve/geometry.hpp"

namespace softhom::rve::detail {

constexpr double kPiPlacement = 3.14159265358979323846;

/// A fiber (or a periodic image of one) placed in the plane.
struct PlacedFiber {
  FiberSection f;  // center already shifted
  Eigen::Vector2d u{1, 0}, v{0, 1};  // rectangle axes
};

/// Signed distance to the fiber boundary (negative inside).
inline double signed_distance(const PlacedFiber& p, const Eigen::Vector2d& x) {
  if (p.f.shape == SectionShape::circle) return (x - p.f.center).norm() - p.f.radius;
  const Eigen::Vector2d q = x - p.f.center;
  const double du = std::abs(q.dot(p.u)) - 0.5 * p.f.width, dv = std::abs(q.dot(p.v)) - 0.5 * p.f.height;
  if (du > 0.0 || dv > 0.0) return std::hypot(std::max(du, 0.0), std::max(dv, 0.0));
  return std::max(du, dv);
}

inline double bounding_radius(const FiberSection& f) {
  return f.shape == SectionShape::circle ? f.radius : 0.5 * std::hypot(f.width, f.height);
}

/// Exact fiber area of the section (circles and rectangles).
inline double fiber_area(const Section& section) {
  double exact = 0.0;
  for (const auto& f : section.fibers)
    exact += f.shape == SectionShape::circle ? kPiPlacement * f.radius * f.radius : f.width * f.height;
  return exact;
}

/// Fiber boundary length of the section (circles and rectangles): the interface the meshers refine along.
inline double fiber_perimeter(const Section& section) {
  double length = 0.0;
  for (const auto& f : section.fibers)
    length += f.shape == SectionShape::circle ? 2.0 * kPiPlacement * f.radius : 2.0 * (f.width + f.height);
  return length;
}

/// The four corners of a rectangular fiber (counter-clockwise).
inline std::array<Eigen::Vector2d, 4> rectangle_corners(const PlacedFiber& p) {
  const double a = 0.5 * p.f.width, b = 0.5 * p.f.height;
  const Eigen::Vector2d c = p.f.center;
  return {c - a * p.u - b * p.v, c + a * p.u - b * p.v, c + a * p.u + b * p.v, c - a * p.u + b * p.v};
}

/// The fibers and their images that reach into the cell [0, L1] × [0, L2] enlarged by `margin`.
inline std::vector<PlacedFiber> placed_fibers(const Section& s, double margin = 0.0) {
  std::vector<PlacedFiber> out;
  for (const FiberSection& f : s.fibers)
    for (int k1 = -1; k1 <= 1; ++k1)
      for (int k2 = -1; k2 <= 1; ++k2) {
        PlacedFiber p;
        p.f = f;
        p.f.center = f.center + Eigen::Vector2d(k1 * s.L1, k2 * s.L2);
        const double R = bounding_radius(f) + margin;
        if (p.f.center.x() + R <= 0.0 || p.f.center.x() - R >= s.L1 || p.f.center.y() + R <= 0.0 ||
            p.f.center.y() - R >= s.L2)
          continue;
        const double t = f.rotation_deg * kPiPlacement / 180.0;
        p.u = Eigen::Vector2d(std::cos(t), std::sin(t));
        p.v = Eigen::Vector2d(-std::sin(t), std::cos(t));
        out.push_back(p);
      }
  return out;
}

}  // namespace softhom::rve::detail
