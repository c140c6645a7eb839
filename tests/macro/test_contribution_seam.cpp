// A contribution added from outside fe's driver (tests/spring_contribution.hpp: springs between two
// nodes, as an interface) reaches the Newton iteration through the contribution seam alone: its declared
// couplings enter the stiffness pattern (nodes in no element get their equations from them), its
// residual and tangent the assembly, on the CHOLMOD path and on the petsc path (one process here; two
// ranks in tests/mpi_macro/test_contribution_seam_mpi.cpp).
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "softhom/fe/solver.hpp"
#include "spring_contribution.hpp"

using namespace softhom;

namespace {

/// The displacements of the chain's free nodes after one load step on `kind`.
std::vector<double> solve_chain(const test::SpringChain& c, fe::SolverKind kind) {
  fe::NewtonOptions o;
  o.solver = kind;
  o.mixed = false;  // the held cubes need no element pressures
  o.petsc_options = "-pc_type lu -pc_factor_mat_solver_type mumps";
  fe::Simulation sim(c.model, o);
  EXPECT_TRUE(sim.advance_to(1.0).reached());
  const std::vector<double>& u = sim.displacement();
  return {u[3 * c.n1], u[3 * c.n1 + 1], u[3 * c.n1 + 2], u[3 * c.n2], u[3 * c.n2 + 1], u[3 * c.n2 + 2]};
}

void expect_closed_form(const test::SpringChain& c, const std::vector<double>& u) {
  // Linear springs: Newton's first correction is the solution; the convergence test (1e-8 of the force
  // scale) bounds what is left, so 1e-8 relative.
  const double u1 = c.u1(), u2 = c.u2();
  EXPECT_NEAR(u[0], u1, 1e-8 * u2);
  EXPECT_NEAR(u[3], u2, 1e-8 * u2);
  for (int i : {1, 2, 4, 5}) EXPECT_NEAR(u[i], 0.0, 1e-8 * u2);
}

}  // namespace

TEST(ContributionSeam, SpringChainGivesTheClosedFormOnTheCholmodPath) {
  const test::SpringChain c = test::spring_chain();
  expect_closed_form(c, solve_chain(c, fe::SolverKind::cholmod));
}

TEST(ContributionSeam, SpringChainGivesTheClosedFormOnThePetscPath) {
  const test::SpringChain c = test::spring_chain();
  expect_closed_form(c, solve_chain(c, fe::SolverKind::petsc));
}

TEST(ContributionSeam, ATangentOutsideTheDeclaredCouplingsIsRefused) {
  // Without its couplings the springs' nodes have no place in the pattern: the assembly says so
  // instead of writing outside the matrix.
  const test::SpringChain c = test::spring_chain(/*declare=*/false);
  fe::NewtonOptions o;
  o.solver = fe::SolverKind::cholmod;
  o.mixed = false;
  fe::Simulation sim(c.model, o);
  EXPECT_THROW((void)sim.advance_to(1.0), std::logic_error);
}

TEST(ContributionSeam, ContributionsReportTheirProbesAndFieldsAtTheConvergedState) {
  // Springs in series carry the load F each: the probes read it back at the converged state (1e-8
  // relative as the displacements), one field per spring with its segment's reference ends.
  const test::SpringChain c = test::spring_chain();
  fe::NewtonOptions o;
  o.solver = fe::SolverKind::cholmod;
  o.mixed = false;
  fe::Simulation sim(c.model, o);
  fe::ContributionReport before;
  sim.report(before);
  ASSERT_EQ(before.probes.size(), 2u);
  EXPECT_EQ(before.probes[0].second, 0.0);
  ASSERT_TRUE(sim.advance_to(1.0).reached());
  fe::ContributionReport r;
  sim.report(r);
  ASSERT_EQ(r.probes.size(), 2u);
  EXPECT_EQ(r.probes[1].first, "spring_12_13_force [N]");
  for (const auto& [name, force] : r.probes) EXPECT_NEAR(force, c.force, 1e-8 * c.force) << name;
  ASSERT_EQ(r.fields.size(), 2u);
  EXPECT_EQ(r.fields[1].cells.stem, "spring_12_13");
  EXPECT_EQ(r.fields[1].cells.points[1], c.model.mesh.nodes[c.n2]);
  ASSERT_EQ(r.fields[1].arrays.size(), 1u);
  EXPECT_NEAR(r.fields[1].arrays[0].values[0], c.force, 1e-8 * c.force);
}
