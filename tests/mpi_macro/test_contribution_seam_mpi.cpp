// The contribution seam on two ranks (see tests/macro/test_contribution_seam.cpp): springs added from
// outside fe's driver, between nodes in no element, enter the distributed PETSc matrix's preallocation
// and fill, and give the closed-form chain displacement on every rank.
#include <gtest/gtest.h>

#include "softhom/fe/solver.hpp"
#include "spring_contribution.hpp"

using namespace softhom;

TEST(ContributionSeamMpi, SpringChainGivesTheClosedFormOnTheDistributedPetscPath) {
  const test::SpringChain c = test::spring_chain();
  fe::NewtonOptions o;
  o.solver = fe::SolverKind::petsc;
  o.mixed = false;
  o.petsc_options = "-pc_type lu -pc_factor_mat_solver_type mumps";
  fe::Simulation sim(c.model, o);
  ASSERT_TRUE(sim.advance_to(1.0).reached());
  const std::vector<double>& u = sim.displacement();
  // Linear springs: the convergence test (1e-8 of the force scale) bounds the error, 1e-8 relative.
  const double u1 = c.force / c.k1, u2 = u1 + c.force / c.k2;
  EXPECT_NEAR(u[3 * c.n1], u1, 1e-8 * u2);
  EXPECT_NEAR(u[3 * c.n2], u2, 1e-8 * u2);
  EXPECT_NEAR(u[3 * c.n2 + 1], 0.0, 1e-8 * u2);
}

TEST(ContributionSeamMpi, SpringChainGivesTheClosedFormUnderBddc) {
  // BDDC's subdomains take the springs' groups too: the nodes in no element join the subdomain of the
  // rank holding the spring's other node (or rank 0).
  const test::SpringChain c = test::spring_chain();
  fe::NewtonOptions o;
  o.solver = fe::SolverKind::petsc;
  o.mixed = false;
  o.petsc_preconditioner = fe::PetscPreconditioner::bddc;
  o.petsc_options = "-ksp_rtol 1e-12";
  fe::Simulation sim(c.model, o);
  ASSERT_TRUE(sim.advance_to(1.0).reached());
  const std::vector<double>& u = sim.displacement();
  const double u1 = c.force / c.k1, u2 = u1 + c.force / c.k2;
  EXPECT_NEAR(u[3 * c.n1], u1, 1e-8 * u2);
  EXPECT_NEAR(u[3 * c.n2], u2, 1e-8 * u2);
}
