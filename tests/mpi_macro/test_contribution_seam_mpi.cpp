// The contribution seam on two ranks (see tests/macro/test_contribution_seam.cpp): springs added from
// outside fe's driver, between nodes in no element, enter the distributed PETSc matrix's preallocation
// and fill, and give the closed-form chain displacement on every rank.
#include <gtest/gtest.h>

#include "partition.hpp"
#include "softhom/fe/solver.hpp"
#include "spring_contribution.hpp"
#include "surface_contact_blocks.hpp"

using namespace softhom;

namespace {

/// The spring chain solved on the petsc path with `o`'s preconditioner; false when it stops early.
bool solve_chain(const test::SpringChain& c, fe::NewtonOptions o, std::vector<double>& u) {
  o.solver = fe::SolverKind::petsc;
  o.mixed = false;  // the held cubes need no element pressures
  fe::Simulation sim(c.model, o);
  const bool reached = sim.advance_to(1.0).reached();
  u = sim.displacement();
  return reached;
}

}  // namespace

TEST(ContributionSeamMpi, SpringChainGivesTheClosedFormOnTheDistributedPetscPath) {
  const test::SpringChain c = test::spring_chain();
  fe::NewtonOptions o;
  o.petsc_options = "-pc_type lu -pc_factor_mat_solver_type mumps";
  std::vector<double> u;
  ASSERT_TRUE(solve_chain(c, o, u));
  // Linear springs: the convergence test (1e-8 of the force scale) bounds the error, 1e-8 relative.
  EXPECT_NEAR(u[3 * c.n1], c.u1(), 1e-8 * c.u2());
  EXPECT_NEAR(u[3 * c.n2], c.u2(), 1e-8 * c.u2());
  EXPECT_NEAR(u[3 * c.n2 + 1], 0.0, 1e-8 * c.u2());
}

TEST(ContributionSeamMpi, SpringChainGivesTheClosedFormUnderBddc) {
  // BDDC's subdomains take the springs' groups too: the nodes in no element join the subdomain of the
  // rank holding the spring's other node (or rank 0).
  const test::SpringChain c = test::spring_chain();
  fe::NewtonOptions o;
  o.petsc_preconditioner = fe::PetscPreconditioner::bddc;
  o.petsc_options = "-ksp_rtol 1e-12";
  std::vector<double> u;
  ASSERT_TRUE(solve_chain(c, o, u));
  EXPECT_NEAR(u[3 * c.n1], c.u1(), 1e-8 * c.u2());
  EXPECT_NEAR(u[3 * c.n2], c.u2(), 1e-8 * c.u2());
}

// A contact between deformable surfaces on the distributed petsc path: its pairs, chosen at every step
// (the first step adds them all), enter the matrix at the next fill on every rank. The stacked blocks'
// contact patch test (tests/fe/test_surface_contact.cpp) gives the CHOLMOD run's face pressures to 1e-6
// of the applied traction (both to Newton's 1e-8 of the force scale) and its uniform pressure. On two
// ranks the pair spans them: every rank evaluates the whole contact and adds the rows it owns.
TEST(ContributionSeamMpi, ContactPatchTestEqualsCholmod) {
  {
    // The partition of two ranks (deterministic, the same on any number of processes): the lower
    // block (master faces, elements 0–3) on one rank, part of the upper block (slave faces) on the other.
    const std::vector<int> part = fe::partition_elements_rcb(test::two_blocks(2, 4, 0.0, false), 2);
    int upper_elsewhere = 0;
    for (int e = 4; e < 20; ++e) upper_elsewhere += part[e] != part[0];
    for (int e = 1; e < 4; ++e) ASSERT_EQ(part[e], part[0]);
    ASSERT_GT(upper_elsewhere, 0);
    ASSERT_LT(upper_elsewhere, 16);
  }
  const test::Stack direct = test::stack(2, 4, false, true, false);
  const test::Stack petsc = test::stack(2, 4, false, true, false, false, fe::SolverKind::petsc);
  ASSERT_EQ(petsc.pressure.size(), direct.pressure.size());
  for (std::size_t f = 0; f < petsc.pressure.size(); ++f) {
    EXPECT_NEAR(petsc.pressure[f], direct.pressure[f], 1e-6 * direct.applied);
    EXPECT_NEAR(petsc.pressure[f], petsc.applied, 1e-6 * petsc.applied);
  }
  EXPECT_GE(petsc.rebuilds, 1);
}
