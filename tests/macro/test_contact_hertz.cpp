// Hertz indentation through the contact contribution (fe/contact.hpp) on the shared problem of
// macro/contact_benchmarks.hpp: a rigid sphere pressed into a graded quarter block. The refinement study
// (the 2 % of the converged mesh and the observed order) is bench/contact_hertz.cpp. Then the ironing die
// (macro::make_ironing_problem) sliding frictionless over a coarse block: level reactions (bench/ironing.cpp).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "softhom/fe/solver.hpp"
#include "softhom/macro/contact_benchmarks.hpp"

using namespace softhom;

// Force against indentation on a 10-cell mesh (5 cells across 1.25 a, a the final contact radius:
// h = a/4), four steps: the Hertz coefficient of F = (4/3) E* √R d^{3/2}, fitted beyond the block's linear
// far-field compliance on d ≥ d_max/2, is 6.6 % stiff at this mesh, inside 9 % (bench/contact_hertz.cpp:
// the error falls with order ≈ 2 under refinement; a wrong E* or a lost factor of the quarter model
// misses by far more). The contact radius, the farthest active quadrature point from the axis, lies
// within one face h of Hertz's (3 F R / 4 E*)^{1/3}: the rim is resolved to the quadrature points only,
// and a flat face under the sphere touches it at some of its points (its sag h²/8R exceeds the
// penalty's penetration).
TEST(ContactHertz, ForceAndContactRadiusFollowHertz) {
  const macro::HertzProblem p = macro::make_hertz_problem(5, 5);
  fe::Simulation sim(p.model);
  std::vector<double> force, indentation;
  double a = 0.0;
  for (int s = 1; s <= 4; ++s) {
    const double t = 0.25 * s;
    ASSERT_TRUE(sim.advance_to(t).reached()) << t;
    const fe::Iterate it = sim.converged_iterate(*p.contact);
    const fe::ContactTotals tot = p.contact->totals(p.model.mesh, it);
    if (s == 1) continue;  // the fit on d ≥ d_max/2: a patch of at least 3 cells
    force.push_back(4.0 * tot.normal_force);  // the quarter's force × 4
    indentation.push_back(p.depth * t - tot.max_penetration);
    a = 0.0;
    for (const Vec3& x : p.contact->active_positions(p.model.mesh, it)) a = std::max(a, std::hypot(x[0], x[1]));
  }
  const double alpha = macro::hertz_coefficient(force, indentation);
  const double alpha_hertz = std::pow(3.0 / (4.0 * p.effective_modulus * std::sqrt(p.radius)), 2.0 / 3.0);
  const double force_error = std::pow(alpha_hertz / alpha, 1.5) - 1.0;
  EXPECT_LT(std::abs(force_error), 0.09) << "alpha " << alpha << " Hertz " << alpha_hertz;
  const double a_hertz = p.contact_radius(force.back()), h = 1.25 * std::sqrt(p.depth) / 5;
  EXPECT_NEAR(a, a_hertz, h);
}

// Ironing (macro::make_ironing_problem, after Puso & Laursen 2004; the die rigid), frictionless on the
// coarse mesh (one hex8 per unit): the die pressed 1.0 in 10 steps and slid 10 in 20. While it slides on
// the flat block the vertical reaction stays level, a step-to-step change below 10 % of its mean
// (measured 4.2 %: the contact patch's quadrature points cross element edges as the die moves half an
// element per step; a node-to-surface scheme jumps by a node's share), and without friction the force
// against the sliding is only the asymmetry of the indented block: |F_x| < 0.05 F_z (measured at most
// 0.036). The obstacle's path moves the first iterate of every step by its increment, which the
// penetration bound admits (the press steps take 4-11 iterations).
TEST(ContactIroning, FrictionlessDieSlidesWithLevelForces) {
  const macro::IroningProblem p = macro::make_ironing_problem(1, 0.0);
  fe::Simulation sim(p.model);
  std::vector<double> fz;
  for (int s = 1; s <= 30; ++s) {
    const double t = s <= 10 ? 0.1 * s : 1.0 + 0.05 * (s - 10);
    ASSERT_TRUE(sim.advance_to(t).reached()) << t;
    EXPECT_LE(sim.last_step_counts().newton_iterations, 25) << t;
    if (t < 1.25 - 1e-12) continue;
    const fe::ContactTotals tot = p.contact->totals(p.model.mesh, sim.converged_iterate(*p.contact));
    fz.push_back(-tot.force[2]);
    EXPECT_LT(std::abs(tot.force[0]), 0.05 * std::abs(tot.force[2])) << t;
  }
  double mean = 0.0, jump = 0.0;
  for (double f : fz) mean += f / double(fz.size());
  for (std::size_t k = 1; k < fz.size(); ++k) jump = std::max(jump, std::abs(fz[k] - fz[k - 1]));
  EXPECT_GT(mean, 3.0);  // measured 4.30: the block's resistance to the 1.0 indentation
  EXPECT_LT(jump, 0.1 * mean);
}

// Two elastic spheres (R1 = 1, G1 = 1 on R2 = 2, G2 = 2, ν = 0.3; macro::make_hertz_spheres_problem)
// pressed together through the contact between deformable surfaces, on a coarse mesh (3 fine cells
// across 1.25 a, 3 graded ones beyond: h = 0.42 a), four steps: the Hertz coefficient of
// F = (4/3) E* √R* δ^{3/2} (1/R* = 1/R1 + 1/R2, 1/E* = Σ (1 − ν²)/E), fitted beyond the bodies' linear
// far-field compliance on δ ≥ δ_max/2, is within 15 % at this mesh (measured −12.9 %, the coarse mesh
// soft; bench/contact_hertz.cpp spheres: −6.0 % at h = 0.31 a, −1.8 % at 0.21 a, order ≈ 3), where one
// body's modulus or radius in place of the effective ones predicts a force 22 % (R1) to 73 % (R2) or
// 50 % (E1/(1 − ν²)) above Hertz's with E*, R*, so the coarse mesh's error would exceed 29 %. The
// contact radius, the farthest active slave point from
// the axis, lies within one fine cell of Hertz's (3 F R* / 4 E*)^{1/3}, and the force the contact
// carries is the upper body's reaction (its only support; Newton's tolerance, 1e-6 relative).
TEST(ContactHertz, TwoSpheresFollowHertzWithEffectiveRadiusAndModulus) {
  const macro::HertzSpheresProblem p = macro::make_hertz_spheres_problem(3, 3);
  fe::Simulation sim(p.model);
  std::vector<double> force, approach;
  double a = 0.0, reaction = 0.0;
  std::vector<int> press;
  for (int node : fe::surface_nodes(p.model.mesh, "upper_far")) press.push_back(3 * node + 2);
  for (int s = 1; s <= 4; ++s) {
    const double t = 0.25 * s;
    ASSERT_TRUE(sim.advance_to(t).reached()) << t;
    const fe::Iterate it = sim.converged_iterate(*p.contact);
    const fe::ContactTotals tot = p.contact->totals(p.model.mesh, it);
    if (s == 1) continue;  // the fit on δ ≥ δ_max/2
    force.push_back(4.0 * tot.normal_force);  // the quarter's force × 4
    approach.push_back(p.approach * t - tot.max_penetration);
    a = 0.0;
    for (const Vec3& x : p.contact->active_positions(p.model.mesh, it)) a = std::max(a, std::hypot(x[0], x[1]));
    reaction = sim.reaction(press);
  }
  const double alpha = macro::hertz_coefficient(force, approach);
  const double alpha_hertz = std::pow(3.0 / (4.0 * p.effective_modulus * std::sqrt(p.effective_radius)), 2.0 / 3.0);
  const double force_error = std::pow(alpha_hertz / alpha, 1.5) - 1.0;
  std::printf("two spheres, coarse: force error %.4f, contact radius %.4g against %.4g (h %.3g)\n", force_error, a,
              p.contact_radius(force.back()), p.fine_size);
  EXPECT_LT(std::abs(force_error), 0.15);
  EXPECT_NEAR(a, p.contact_radius(force.back()), p.fine_size);
  EXPECT_NEAR(4.0 * -reaction, force.back(), 1e-6 * force.back());
}
