// Geometrically nonlinear benchmarks of Sze, Liu & Lo (2004) on coarse meshes (macro/shell_benchmarks.hpp;
// the refinements are bench_shell_nonlinear's): the cantilever rolled up by an end moment against Euler's
// closed form (to the full circle with u_y held), the hemisphere with an 18° hole under alternating radial
// forces and the open cylinder pulled out by two radial forces against the published deflections.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "softhom/macro/shell_benchmarks.hpp"

using namespace softhom;
using namespace softhom::macro;

namespace {

/// The tip's worst distance from Euler's arc over `steps` equal steps to t = 1, over L.
double rolled_tip_error(const RolledCantilever& c, double fraction, int steps, fe::Simulation& sim) {
  double worst = 0.0;
  for (int k = 1; k <= steps; ++k) {
    const fe::AdvanceResult a = sim.advance_to(double(k) / steps);
    EXPECT_TRUE(a.reached()) << k << ": " << a.message;
    if (!a.reached()) return 1.0;
    const auto& u = sim.displacement();
    const auto exact = c.tip(fraction * c.max_moment * k / steps);
    worst = std::max(worst, std::hypot(u[3 * c.tip_node] - exact[0], u[3 * c.tip_node + 2] - exact[1]) / c.length);
  }
  return worst;
}

}  // namespace

TEST(ShellNonlinearBenchmarks, CantileverRollsIntoAQuarterCircleUnderAnEndMoment) {
  // 24 × 2 cells to M_max / 4 (θ = π/2) in 5 steps. bench_shell_nonlinear: the tip error at θ = π is
  // 6.7e-2, 1.9e-2, 4.7e-3 L at 12, 24, 48 cells along (order 1.8–2.0); here measured 7.3e-3 L at
  // θ = π/2, bound 1.5e-2 L (a moment not work-conjugate to the end rotation would miss by its
  // lever arm's share, h / L = 4 %).
  const RolledCantilever c = make_rolled_cantilever(24, 2, 0.25);
  fe::Simulation sim(c.structure.model);
  const double error = rolled_tip_error(c, 0.25, 5, sim);
  std::printf("rolled cantilever 24 x 2 to θ = π/2: worst tip error %.3e L\n", error);
  EXPECT_LT(error, 1.5e-2);
  // The edge's rotation probe: the arc's end angle θ = π/2, less at most the curvature over the last
  // row's chord, κ h / 2 = θ h / (2 L) (2.1 % of θ at 24 cells; measured 1.5479, −1.5 %). Bound 4 %.
  fe::ContributionReport report;
  sim.report(report);
  double rotation = 0.0;
  for (const auto& [name, value] : report.probes)
    if (name == "shell edge rotation [rad]") rotation = value;
  std::printf("edge rotation %.5f (θ = %.5f)\n", rotation, 0.5 * M_PI);
  EXPECT_NEAR(rotation, 0.5 * M_PI, 0.04 * 0.5 * M_PI);
}

TEST(ShellNonlinearBenchmarks, HemisphereUnderSmallAlternatingForcesIsMacNealHardersLinearOne) {
  // The same hemisphere at a thousandth of MacNeal & Harder's (1985) F = 2 (1 per point on the quarter):
  // the displacement of A, 0.094 at F = 2, scaled (linear to ~1e-4 at u ~ 1e-4 ≪ t = 0.04).
  // Measured at 16²: 0.09557 at A and 0.09286 at B (+1.7 %, −1.2 %: the grid's single diagonal is not
  // symmetric under x ↔ y); bound 3 %.
  const PinchedHemisphere h = make_pinched_hemisphere(16, 2e-3);
  fe::NewtonOptions o;
  o.tolerance = 1e-10;
  fe::Simulation sim(h.structure.model, o);
  ASSERT_TRUE(sim.advance_to(1.0).reached());
  const auto& u = sim.displacement();
  const double ua = u[3 * h.node_a] / 1e-3, ub = -u[3 * h.node_b + 1] / 1e-3;
  std::printf("hemisphere 16^2 linear: u_A %.5f, -u_B %.5f\n", ua, ub);
  EXPECT_NEAR(ua, 0.094, 0.03 * 0.094);
  EXPECT_NEAR(ub, 0.094, 0.03 * 0.094);
}

TEST(ShellNonlinearBenchmarks, HemisphereUnderAlternatingRadialForcesOnACoarseMesh) {
  // P = 400 on 8² cells in 20 steps (fewer cut-backs than 10): u_A 4.518, −u_B 9.682 (+11 %, +18 % of Sze
  // et al.'s 4.067 and 8.178; this coarse mesh has a second equilibrium at P = 400, 4.391 and 9.047, which
  // 5 or 10 steps reach). bench_shell_nonlinear: 4.215, 8.370 at 16² and 4.108, 8.151 at 32² (+1.0 %,
  // −0.3 %), the same with 10 or 40 steps. Bound 25 %: the coarse mesh's own error; a lost bending or
  // membrane term is off by far more.
  const PinchedHemisphere h = make_pinched_hemisphere(8);
  fe::Simulation sim(h.structure.model);
  for (int k = 1; k <= 20; ++k) ASSERT_TRUE(sim.advance_to(k / 20.0).reached()) << k;
  const auto& u = sim.displacement();
  const double ua = u[3 * h.node_a], ub = -u[3 * h.node_b + 1];
  std::printf("hemisphere 8^2: u_A %.4f, -u_B %.4f\n", ua, ub);
  EXPECT_NEAR(ua, kHemisphereUaAt400, 0.25 * kHemisphereUaAt400);
  EXPECT_NEAR(ub, kHemisphereUbAt400, 0.25 * kHemisphereUbAt400);
  EXPECT_GT(ua, kHemisphereUaAt400);  // from above, as on every mesh of the bench
  EXPECT_GT(ub, kHemisphereUbAt400);
}

TEST(ShellNonlinearBenchmarks, CantileverHeldInItsPlaneRollsIntoAFullCircle) {
  // 24 × 2 cells to M_max (θ = 2π) in 20 steps with u_y = 0 held (free, the one-diagonal mesh's twist
  // coupling drifts the strip sideways and Newton stops at 0.80 M_max on this mesh: bench_shell_nonlinear).
  // Measured: the tip 4.67e-2 L from Euler's at θ = 2π, the worst over the path; bench: 1.2e-2 at 48 cells.
  // Bound 6e-2 L: the mesh's own error (a moment that lost work conjugacy would miss by far more, and
  // a step that does not converge fails the run).
  const RolledCantilever c = make_rolled_cantilever(24, 2, 1.0, true);
  fe::Simulation sim(c.structure.model);
  const double error = rolled_tip_error(c, 1.0, 20, sim);
  std::printf("rolled cantilever 24 x 2, u_y held, to θ = 2π: worst tip error %.3e L\n", error);
  EXPECT_LT(error, 6e-2);
}

TEST(ShellNonlinearBenchmarks, OpenCylinderPulledOutOnACoarseMesh) {
  // 12 × 8 cells, P = 40 000 in 40 steps (through the steep stretch near P_max / 2 that Sze et al.'s
  // table shows). Measured: w_A 2.786 (+0.7 %), −u_B 4.689 (+3.0 %), −u_C 3.696 (+13 %);
  // bench_shell_nonlinear at 24 × 16: −0.7, +1.5, +2.7 %. Bounds 3 %, 6 %, 20 %: this mesh's own error
  // (the free end's C converges slowest); a lost membrane or bending term is off by far more.
  const PulloutCylinder c = make_pullout_cylinder(12, 8);
  fe::Simulation sim(c.structure.model);
  for (int k = 1; k <= 40; ++k) ASSERT_TRUE(sim.advance_to(k / 40.0).reached()) << k;
  const auto& u = sim.displacement();
  const double wa = u[3 * c.node_a + 1], ub = -u[3 * c.node_b], uc = -u[3 * c.node_c];
  std::printf("pull-out 12 x 8: w_A %.4f, -u_B %.4f, -u_C %.4f\n", wa, ub, uc);
  EXPECT_NEAR(wa, kPulloutWaAt40k, 0.03 * kPulloutWaAt40k);
  EXPECT_NEAR(ub, kPulloutUbAt40k, 0.06 * kPulloutUbAt40k);
  EXPECT_NEAR(uc, kPulloutUcAt40k, 0.20 * kPulloutUcAt40k);
}
