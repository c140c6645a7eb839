// The shell against the tet10 solid on a thin tube (H/R = 0.02) with two symmetric fiber families,
// inflated at the axial stretch λz = 1 (macro/shell_benchmarks.hpp; bench_shell_vs_solid compares both
// with the exact thick-walled tube on finer meshes and times them).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "softhom/macro/shell_benchmarks.hpp"

using namespace softhom;
using namespace softhom::macro;

namespace {

double thin_tube_mean_radius(const fe::Simulation& sim, const std::vector<int>& nodes) {
  const std::vector<Vec3> x = sim.current_positions();
  double r = 0.0;
  for (int n : nodes) r += std::hypot(x[n].x(), x[n].y()) / double(nodes.size());
  return r;
}

}  // namespace

TEST(ShellThinTube, MatchesTheTet10SolidInRadiusAndAxialForce) {
  // The solid under inner pressure to 0.085 (a mid-wall hoop stretch of 1.4) in 3 steps; the shell then
  // carries, at the same times, the mid-surface pressure of the same hoop force, p_i r_i / r_m, from the
  // solid's radii. bench_shell_vs_solid at 12 cells against the exact tube: the shell's radius 0.14 %
  // and axial force 0.69 % off, the solid's 0.46 % and 0.07 % (the shell's plane stress drops the
  // wall's radial stress, −p_i/2 in the mean: an O(H/R) difference of the axial force). Here measured
  // shell against solid: radius −0.20, −0.33, −0.42 %, axial force +0.48, +0.55, +0.60 %. Bound: 1 %.
  const MaterialPtr law = thin_wall_tube_law(true);
  const ThinWallTubeSize size;  // R = 10, H = 0.2, L = 1
  const double p_inner = 0.085;
  const ThinWallTube solid = make_thin_wall_tube_solid(law, size, 12, 1, p_inner);
  fe::Simulation solid_sim(solid.structure.model);
  std::vector<double> times{0.0}, p_mid{0.0}, radius, force;
  for (int k = 1; k <= 3; ++k) {
    ASSERT_TRUE(solid_sim.advance_to(k / 3.0).reached()) << k;
    const double r_inner = thin_tube_mean_radius(solid_sim, solid.structure.inner_nodes), r_mid = solid.radius(solid_sim);
    times.push_back(k / 3.0);
    p_mid.push_back(p_inner * k / 3.0 * r_inner / r_mid);
    radius.push_back(r_mid);
    force.push_back(solid_sim.reaction(solid.end_dofs));
  }
  ThinWallTube shell = make_thin_wall_tube_shell(law, size, 12, 1.0);
  shell.structure.model.pressures.front().pressure = PiecewiseLinear{times, p_mid};
  fe::Simulation shell_sim(shell.structure.model);
  for (int k = 1; k <= 3; ++k) {
    ASSERT_TRUE(shell_sim.advance_to(k / 3.0).reached()) << k;
    const double r = shell.radius(shell_sim), f = shell_sim.reaction(shell.end_dofs);
    std::printf("step %d: radius shell %.5f solid %.5f (%.3f %%), axial force shell %.5f solid %.5f (%.3f %%)\n", k, r,
                radius[k - 1], 100 * (r / radius[k - 1] - 1), f, force[k - 1], 100 * (f / force[k - 1] - 1));
    EXPECT_NEAR(r / radius[k - 1], 1.0, 0.01);
    EXPECT_NEAR(f / force[k - 1], 1.0, 0.01);
  }
  EXPECT_GT(radius.back(), 1.35 * size.radius);  // the load reached the large-strain range
}
