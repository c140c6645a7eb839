// Tied fibers on the distributed petsc path: a coarse double-helix tube (tests/macro/fiber_tube.hpp)
// inflated on every rank gives CHOLMOD's one-process answer; the fiber elements' couplings (host nodes
// of up to two elements each) enter the preallocation, the fill and the subdomains.
#include <gtest/gtest.h>

#include "macro/fiber_tube.hpp"

using namespace softhom;

namespace {

test::FiberTubeCase coarse_tube(fe::SolverKind solver) {
  test::FiberTubeCase c;
  c.length = 20.0;
  c.circumferential_cells = 12;
  c.axial_cells = 8;
  c.count = 4;
  c.angle_deg = 40.0;
  c.pressure = 0.004;
  c.substeps = 2;
  c.solver = solver;
  c.petsc_options = "-pc_type lu -pc_factor_mat_solver_type mumps";
  return c;
}

}  // namespace

TEST(FiberTubeMpi, DistributedPetscGivesTheOneProcessAnswer) {
  const test::FiberTubeResult one = test::inflate_fiber_tube(coarse_tube(fe::SolverKind::cholmod));
  const test::FiberTubeResult many = test::inflate_fiber_tube(coarse_tube(fe::SolverKind::petsc));
  ASSERT_TRUE(one.reached && many.reached);
  // Both converge to 1e-8 of the force scale: the strains agree to ~1e-8; 1e-6 of the strain leaves room
  // for the Krylov tolerance and still catches a fiber element assembled twice or not at all (a few %).
  EXPECT_NEAR(many.axial_stretch_mid, one.axial_stretch_mid, 1e-6 * std::abs(one.axial_stretch_mid - 1.0));
  EXPECT_NEAR(many.hoop_stretch_mid, one.hoop_stretch_mid, 1e-6 * std::abs(one.hoop_stretch_mid - 1.0));
  EXPECT_NEAR(many.axial_stretch_end, one.axial_stretch_end, 1e-6 * std::abs(one.axial_stretch_end - 1.0));
  EXPECT_LT(std::abs(many.twist_end_deg), 1e-6);
}
