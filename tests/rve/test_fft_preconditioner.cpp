// The Jacobi–Green preconditioner of the FFT Newton–CG solve (FftSolverOptions::preconditioner,
// rve/src/fft_preconditioner.hpp): its scaling is the node diagonal of the stencil operator (probed
// with the stencil passes themselves), and the solve it preconditions converges to the same stress as
// with the Green preconditioner.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "../rve/src/fft_local_bulk.hpp"
#include "../rve/src/fft_preconditioner.hpp"
#include "rve/rve_test_helpers.hpp"
#include "softhom/materials/laws.hpp"
#include "softhom/rve/fft_solver.hpp"

using namespace softhom;
using namespace softhom::rve;
using softhom::rve::testing::circle_image;
using softhom::rve::testing::uniaxial_ramp;

namespace {

/// A heterogeneous tangent field: point p has c_p · C with c_p in [0.5, 20] (deterministic).
double factor(std::size_t p) { return 0.5 + 19.5 * std::fmod(0.6180339887 * double(p * p + 3 * p + 1), 1.0); }

/// (K e_(y,i))_(y,i) for the stencil operator with tangents factor(p) C, by the solver's own passes.
double probed_diagonal(const fft::StencilGradient& st, const Mat9& C, std::size_t y, int i) {
  const std::size_t N = st.grid().voxels();
  std::vector<double> u(3 * N, 0.0), f(3 * N, 0.0), store(st.stored_values() * N, 0.0);
  u[i * N + y] = 1.0;
  constexpr int B = fft::StencilGradient::kBatch;
#pragma omp parallel
  st.gradient_pass(u.data(), store.data(), [&](std::size_t p0, int count, const double* grad, double* stress) {
    for (int l = 0; l < B; ++l)
      for (int a = 0; a < 9; ++a) {
        double acc = 0.0;
        if (l < count)
          for (int b = 0; b < 9; ++b) acc += factor(p0 + l) * C(a, b) * grad[b * B + l];
        stress[a * B + l] = acc;
      }
  });
  st.divergence_pass(store.data(), f.data(), nullptr);
  return f[i * N + y];
}

void expect_scaling_is_the_node_diagonal(const fft::Grid& grid, fft::Discretization disc) {
  const fft::GradientOperator op(grid, disc);
  const fft::StencilGradient st(op);
  const Mat9 C = rve::detail::isotropic_tangent(2.0, 1.0);
  std::vector<double> w;
  for (const auto& q : op.quadrature()) w.push_back(q.weight);
  const Eigen::Vector3d D0 = rve::detail::reference_diagonal(st, w, C);
  double packed[45];
  int idx = 0;
  for (int a = 0; a < 9; ++a)
    for (int b = a; b < 9; ++b) packed[idx++] = C(a, b);
  const std::size_t N = grid.voxels();
  std::vector<double> store(3 * N);
  std::vector<float> s;
  rve::detail::jacobi_scaling(
      st, w, D0, N, false, [&](std::size_t p, int k) { return factor(p) * packed[k]; }, store.data(),
      [](double*, std::size_t) {}, s);
  ASSERT_EQ(s.size(), 3 * N);
  // s = (D0 / D)^½ in float: D = D0 / s² to ≈ 1e-7 relative (float rounding of the sum and the root).
  for (std::size_t y = 0; y < N; y += 7)
    for (int i = 0; i < 3; ++i) {
      const double D = probed_diagonal(st, C, y, i);
      EXPECT_NEAR(D0[i] / (double(s[i * N + y]) * s[i * N + y]), D, 1e-6 * D) << "node " << y << " component " << i;
    }
}

struct Stress {
  Mat3 P;
  int newton = 0, krylov = 0;
};

Stress solve(const PhaseImage& im, const MaterialPtr& matrix, const MaterialPtr& fiber, const MixedControl& control,
             fft::Discretization disc, Preconditioner pc) {
  FftSolverOptions o;
  o.discretization = disc;
  o.preconditioner = pc;
  o.tolerance = 1e-10;  // far below the 1e-8 compared: both runs at the same converged P
  o.plan.rigor = fft::PlanRigor::estimate;
  FftRveSolver s(im, matrix, fiber, 30.0, Mat3::Identity(), o);
  const RveRunResult r = s.run(control);
  EXPECT_TRUE(r.completed) << r.error;
  return {r.steps.back().P, r.newton_iterations, r.krylov_iterations};
}

void expect_same_stress(const PhaseImage& im, const MaterialPtr& matrix, const MaterialPtr& fiber,
                        const MixedControl& control, fft::Discretization disc) {
  const Stress g = solve(im, matrix, fiber, control, disc, Preconditioner::green);
  const Stress j = solve(im, matrix, fiber, control, disc, Preconditioner::jacobi_green);
  std::printf("[ info     ] green %d Newton / %d Krylov, jacobi-green %d / %d\n", g.newton, g.krylov, j.newton, j.krylov);
  // Newton tolerance 1e-10 on both: the converged stresses agree to ≈ 1e-10 relative; 1e-8 leaves room
  // for the different inexact-Newton paths (another preconditioned norm stops each CG solve).
  EXPECT_LE((g.P - j.P).cwiseAbs().maxCoeff(), 1e-8 * g.P.cwiseAbs().maxCoeff()) << g.P << "\n" << j.P;
  EXPECT_GT(j.krylov, 0);
}

/// A ball of radius r at the centre of an n1 × n2 × n3 cell (fractions by 4³ sub-sampling; no normals:
/// the solver estimates them in the composite voxels).
PhaseImage ball_image(std::array<int, 3> n, double r) {
  PhaseImage im;
  im.n = n;
  im.size = {1.0, double(n[1]) / n[0], double(n[2]) / n[0]};
  im.fiber_fraction.assign(std::size_t(n[0]) * n[1] * n[2], 0.0);
  const int s = 4;
  for (int k = 0; k < n[2]; ++k)
    for (int j = 0; j < n[1]; ++j)
      for (int i = 0; i < n[0]; ++i) {
        int inside = 0;
        for (int c = 0; c < s * s * s; ++c) {
          const double h = 1.0 / n[0];
          const double x = (i + (c % s + 0.5) / s) * h - 0.5 * im.size[0], y = (j + (c / s % s + 0.5) / s) * h - 0.5 * im.size[1],
                       z = (k + (c / (s * s) + 0.5) / s) * h - 0.5 * im.size[2];
          inside += x * x + y * y + z * z < r * r;
        }
        im.fiber_fraction[i + std::size_t(n[0]) * (j + std::size_t(n[1]) * k)] = double(inside) / (s * s * s);
      }
  return im;
}

}  // namespace

TEST(JacobiGreenScaling, IsTheNodeDiagonalOfTheStencilOperatorOnASection) {
  expect_scaling_is_the_node_diagonal(fft::Grid{{6, 5, 1}, {1.0, 0.9, 0.2}}, fft::Discretization::rotated);
  expect_scaling_is_the_node_diagonal(fft::Grid{{6, 5, 1}, {1.0, 0.9, 0.2}}, fft::Discretization::hex);
}

TEST(JacobiGreenScaling, IsTheNodeDiagonalOfTheStencilOperatorIn3D) {
  expect_scaling_is_the_node_diagonal(fft::Grid{{5, 4, 3}, {1.0, 0.8, 0.7}}, fft::Discretization::rotated);
  expect_scaling_is_the_node_diagonal(fft::Grid{{5, 4, 3}, {1.0, 0.8, 0.7}}, fft::Discretization::hex);
}

TEST(JacobiGreenPreconditioner, SameStressAsGreenOnAGlassEcoflexSection) {
  const MaterialPtr ecoflex = make_material(make_gent_hgo({0.017, 14.0, 2000.0, {}, FiberInvariant::full, true}));
  const MaterialPtr glass = make_material(make_neo_hookean(NeoHookeanParams::from_young(10.0, 0.3)));
  expect_same_stress(circle_image(12, 0.27), ecoflex, glass, uniaxial_ramp(1.15, 2), fft::Discretization::rotated);
}

TEST(JacobiGreenPreconditioner, SameStressAsGreenOnA3DCell) {
  const MaterialPtr matrix = make_material(make_neo_hookean({0.5, 5.0}));
  const MaterialPtr fiber = make_material(make_neo_hookean({50.0, 400.0}));
  expect_same_stress(ball_image({8, 7, 6}, 0.3), matrix, fiber, uniaxial_ramp(1.1, 2), fft::Discretization::rotated);
  expect_same_stress(ball_image({6, 6, 5}, 0.3), matrix, fiber, uniaxial_ramp(1.1, 1), fft::Discretization::hex);
}
