// Hertz indentation through the contact contribution (fe/contact.hpp) on the shared problem of
// macro/contact_benchmarks.hpp: a rigid sphere pressed into a graded quarter block. The refinement study
// (the 2 % of the converged mesh and the observed order) is bench/contact_hertz.cpp.
#include <gtest/gtest.h>

#include <cmath>

#include "softhom/fe/solver.hpp"
#include "softhom/macro/contact_benchmarks.hpp"

using namespace softhom;

// Force against indentation on a 10-cell mesh (5 cells across the final contact radius a, h = a/4):
// the Hertz coefficient of F = (4/3) E* √R d^{3/2}, fitted beyond the block's linear far-field
// compliance, within 5 % (the mesh's discretization error measured by the bench at this size is
// about 2-3 %); and the contact radius of the active area, a = √(4 A / π) on the quarter, within
// 10 % of Hertz's (3 F R / 4 E*)^{1/3} (the area is resolved to the quadrature points of h = a/4 faces).
TEST(ContactHertz, ForceAndContactRadiusFollowHertz) {
  const macro::HertzProblem p = macro::make_hertz_problem(5, 5);
  fe::Simulation sim(p.model);
  std::vector<double> force, indentation;
  double area = 0.0;
  for (int s = 1; s <= 4; ++s) {
    const double t = 0.25 * s;
    ASSERT_TRUE(sim.advance_to(t).reached()) << t;
    fe::Iterate it;
    it.t = t;
    it.u = &sim.displacement();
    const fe::ContactTotals tot = p.contact->totals(p.model.mesh, it);
    force.push_back(4.0 * tot.normal_force);  // the quarter's force × 4
    indentation.push_back(p.depth * t - tot.max_penetration);
    area = 4.0 * tot.area;
  }
  const double alpha = macro::hertz_coefficient(force, indentation);
  const double alpha_hertz = std::pow(3.0 / (4.0 * p.effective_modulus * std::sqrt(p.radius)), 2.0 / 3.0);
  const double force_error = std::pow(alpha_hertz / alpha, 1.5) - 1.0;
  EXPECT_LT(std::abs(force_error), 0.05) << "alpha " << alpha << " Hertz " << alpha_hertz;
  const double a = std::sqrt(area / M_PI), a_hertz = p.contact_radius(force.back());
  EXPECT_NEAR(a, a_hertz, 0.1 * a_hertz);
}
