// Displacement field of the FFT RVE solver: u = (F̄ − I) y + ũ at the voxel corners.
#include <gtest/gtest.h>

#include <iostream>

#include "rve/rve_test_helpers.hpp"
#include "softhom/materials/laws.hpp"
#include "softhom/rve/fft_solver.hpp"

using namespace softhom;
using namespace softhom::rve;
using softhom::rve::testing::circle_image;
using softhom::rve::testing::uniaxial_ramp;
using softhom::rve::testing::neo_hookean;

namespace {

FftSolverOptions options(fft::Discretization d) {
  FftSolverOptions o;
  o.discretization = d;
  o.tolerance = 1e-10;
  o.plan.rigor = fft::PlanRigor::estimate;
  return o;
}

/// The converged fields of the last output step.
RveFields last_fields(FftRveSolver& solver, const MixedControl& control, RveStep& step) {
  RveFields out;
  const RveRunResult r = solver.run(
      control,
      [&](const RveStep& s, const RveFields* f) {
        if (f) {
          out = *f;
          step = s;
        }
      },
      [&](double t) { return t == control.times.back(); });
  EXPECT_TRUE(r.completed) << r.error;
  return out;
}

}  // namespace

// Both phases the same law (composite voxels everywhere along the circle, so the laminate rule runs)
// at α = 30°: the fluctuation vanishes and u is the macro part (F̄_grid − I) y at every corner.
// Tolerance 1e-10 of the cell size: ũ is the Newton solution of a zero residual, round-off only.
TEST(FftDisplacement, HomogeneousCellIsTheMacroPart) {
  const MixedControl control = uniaxial_ramp(1.5, 2);
  const MaterialPtr m = neo_hookean(1.0, 10.0);
  const PhaseImage im = circle_image(8, 0.3);
  FftRveSolver solver(im, m, m, 30.0, control.frame, options(fft::Discretization::rotated));
  RveStep step;
  const RveFields f = last_fields(solver, control, step);
  const Mat3 R = grid_rotation(30.0);
  const Mat3 G = R.transpose() * step.F * R - Mat3::Identity();
  const int m1 = im.n[0] + 1, m2 = im.n[1] + 1, m3 = im.n[2] + 1;
  ASSERT_EQ(f.displacement.size(), std::size_t(3 * m1 * m2 * m3));
  EXPECT_GT(step.F(0, 0), 1.49);
  double worst = 0.0;
  for (int i3 = 0; i3 < m3; ++i3)
    for (int i2 = 0; i2 < m2; ++i2)
      for (int i1 = 0; i1 < m1; ++i1) {
        const Vec3 y(i1 * im.size[0] / im.n[0], i2 * im.size[1] / im.n[1], i3 * im.size[2] / im.n[2]);
        const Vec3 u_exact = G * y;
        const double* u = &f.displacement[3 * (i1 + m1 * (i2 + m2 * i3))];
        for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(u[c] - u_exact[c]));
      }
  EXPECT_LT(worst, 1e-10 * im.size[0]);
}

// A stiff fiber (contrast 20) under uniaxial tension: the fluctuation is not zero, and the gradient
// of u by differences over each voxel's edges (the mean of the 4 edge differences per direction)
// reproduces the voxel's F field. For the rotated and hex schemes that edge mean *is* the voxel mean
// of the trilinear gradient, so they agree to round-off: 1e-9 of |F| (the fields are load-frame,
// rotated back here).
TEST(FftDisplacement, DifferenceGradientMatchesTheFField) {
  for (fft::Discretization d : {fft::Discretization::rotated, fft::Discretization::hex}) {
    const MixedControl control = uniaxial_ramp(1.3, 3);
    const PhaseImage im = circle_image(16, 0.3);
    const double alpha = 30.0;
    FftRveSolver solver(im, neo_hookean(1.0, 10.0), neo_hookean(20.0, 200.0), alpha, control.frame, options(d));
    RveStep step;
    const RveFields f = last_fields(solver, control, step);
    const Mat3 R = grid_rotation(alpha);
    const int n1 = im.n[0], n2 = im.n[1], m1 = n1 + 1, m2 = n2 + 1;
    const double h[3] = {im.size[0] / n1, im.size[1] / n2, im.size[2] / im.n[2]};
    auto u_at = [&](int i1, int i2, int i3) { return Eigen::Map<const Vec3>(&f.displacement[3 * (i1 + m1 * (i2 + m2 * i3))]); };
    double worst = 0.0, fluctuation = 0.0;
    for (int i2 = 0; i2 < n2; ++i2)
      for (int i1 = 0; i1 < n1; ++i1) {
        Mat3 grad = Mat3::Zero();
        for (int a = 0; a < 2; ++a)
          for (int b = 0; b < 2; ++b) {
            grad.col(0) += (u_at(i1 + 1, i2 + a, b) - u_at(i1, i2 + a, b)) / (4.0 * h[0]);
            grad.col(1) += (u_at(i1 + a, i2 + 1, b) - u_at(i1 + a, i2, b)) / (4.0 * h[1]);
            grad.col(2) += (u_at(i1 + a, i2 + b, 1) - u_at(i1 + a, i2 + b, 0)) / (4.0 * h[2]);
          }
        const std::size_t v = i1 + std::size_t(n1) * i2;
        Mat3 F_load;
        for (int c = 0; c < 9; ++c) F_load(c / 3, c % 3) = f.F[9 * v + c];
        const Mat3 F_grid = R.transpose() * F_load * R;
        worst = std::max(worst, (Mat3::Identity() + grad - F_grid).cwiseAbs().maxCoeff());
        fluctuation = std::max(fluctuation, (F_grid - R.transpose() * step.F * R).cwiseAbs().maxCoeff());
      }
    std::cout << "[ displacement ] " << fft::to_string(d) << ": max |I + Δu/Δy − F| = " << worst
              << ", max |F − F̄| = " << fluctuation << "\n";
    EXPECT_GT(fluctuation, 1e-2) << "the fiber must perturb the field for the test to mean anything";
    EXPECT_LT(worst, 1e-9 * step.F.cwiseAbs().maxCoeff()) << fft::to_string(d);
  }
}
