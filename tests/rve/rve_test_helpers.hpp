#pragma once
// Small local image builders and controls for the FFT RVE tests (independent of the geometry generator).
#include <algorithm>
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "softhom/materials/driver.hpp"
#include "softhom/materials/laws.hpp"
#include "softhom/materials/library.hpp"
#include "softhom/materials/loading.hpp"
#include "softhom/rve/fft_solver.hpp"
#include "softhom/rve/geometry.hpp"

namespace softhom::rve::testing {

inline constexpr double kPi = 3.14159265358979323846;

/// The chapter-IV phases: Ecoflex (Gent, G = 0.017 MPa, Jm = 14, K = 2000 MPa) and the 10 MPa glass.
inline MaterialPtr ecoflex() { return make_material(make_gent_hgo({0.017, 14.0, 2000.0, {}, FiberInvariant::full, true})); }
inline MaterialPtr glass() { return make_material(make_neo_hookean(NeoHookeanParams::from_young(10.0, 0.3))); }
inline MaterialPtr neo_hookean(double mu, double K) { return make_material(make_neo_hookean({mu, K})); }
/// A named preset of the material library.
inline MaterialPtr preset(const std::string& name) { return build_material(preset_spec(name)); }
/// One circular fiber of radius 0.2 mm (the chapter-IV cells) at volume fraction vf.
inline FiberCellSpec circle_spec(double vf, Arrangement arr = Arrangement::square) {
  FiberCellSpec s;
  s.shape = SectionShape::circle;
  s.radius = 0.2;
  s.volume_fraction = vf;
  s.arrangement = arr;
  return s;
}
/// |a − b| / |b| (Frobenius).
inline double rel(const Mat3& a, const Mat3& b) { return (a - b).norm() / std::max(b.norm(), 1e-300); }

/// A cell of one homogeneous law is that law's material point under the same control: every output
/// step's P̄ and F̄ to `tol` (relative).
inline void expect_steps_match_point(const RveRunResult& r, const PointRunResult& point, double tol) {
  ASSERT_EQ(r.steps.size(), point.steps.size());
  for (std::size_t k = 1; k < r.steps.size(); ++k) {
    EXPECT_LT(rel(r.steps[k].P, point.steps[k].P), tol) << "step " << k;
    EXPECT_LT(rel(r.steps[k].F, point.steps[k].F), tol) << "step " << k;
  }
}

/// One circular fiber of radius r at the centre of the unit cell, n × n pixels, fraction by s × s
/// sub-sampling, radial normals in composite pixels.
inline PhaseImage circle_image(int n, double r, int s = 16) {
  PhaseImage im;
  im.n = {n, n, 1};
  im.size = {1.0, 1.0, 1.0 / n};
  im.fiber_fraction.assign(std::size_t(n) * n, 0.0);
  im.normal.assign(std::size_t(n) * n, Eigen::Vector3d::Zero());
  const double h = 1.0 / n;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      int inside = 0;
      for (int b = 0; b < s; ++b)
        for (int a = 0; a < s; ++a) {
          const double x = (i + (a + 0.5) / s) * h - 0.5, y = (j + (b + 0.5) / s) * h - 0.5;
          inside += (x * x + y * y < r * r);
        }
      const double f = double(inside) / (s * s);
      im.fiber_fraction[i + std::size_t(n) * j] = f;
      if (f > 0.0 && f < 1.0) {
        const Eigen::Vector3d c((i + 0.5) * h - 0.5, (j + 0.5) * h - 0.5, 0.0);
        im.normal[i + std::size_t(n) * j] = c.normalized();
      }
    }
  return im;
}

/// Layers normal to y1: fiber for i1 < n_fiber, matrix beyond; optionally one composite column with
/// fraction `phi_interface` at i1 = n_fiber (normal +y1, pointing out of the fiber).
inline PhaseImage layer_image(int n1, int n2, int n_fiber, double phi_interface = -1.0) {
  PhaseImage im;
  im.n = {n1, n2, 1};
  im.size = {1.0, double(n2) / n1, 1.0 / n1};
  im.fiber_fraction.assign(std::size_t(n1) * n2, 0.0);
  im.normal.assign(std::size_t(n1) * n2, Eigen::Vector3d::Zero());
  for (int j = 0; j < n2; ++j)
    for (int i = 0; i < n1; ++i) {
      const std::size_t v = i + std::size_t(n1) * j;
      if (i < n_fiber) im.fiber_fraction[v] = 1.0;
      if (i == n_fiber && phi_interface > 0.0) {
        im.fiber_fraction[v] = phi_interface;
        im.normal[v] = Eigen::Vector3d::UnitX();
      }
    }
  return im;
}

/// Every component of F prescribed: linear ramp from I to F_end over [0, 1], output at `steps` times.
inline MixedControl full_deformation(const Mat3& F_end, int steps) {
  MixedControl c;
  for (int k = 0; k < 9; ++k) {
    c.kind[k] = ControlKind::deformation;
    const double start = (k % 4 == 0) ? 1.0 : 0.0;
    c.value[k] = PiecewiseLinear{{0.0, 1.0}, {start, F_end(k / 3, k % 3)}};
  }
  for (int s = 1; s <= steps; ++s) c.times.push_back(double(s) / steps);
  c.name = "full";
  return c;
}

inline MixedControl uniaxial_ramp(double lambda, int steps, double duration = 1.0) {
  MixedControl c = uniaxial_control(PiecewiseLinear{{0.0, duration}, {1.0, lambda}});
  c.times.clear();
  for (int s = 1; s <= steps; ++s) c.times.push_back(duration * s / steps);
  return c;
}

}  // namespace softhom::rve::testing
