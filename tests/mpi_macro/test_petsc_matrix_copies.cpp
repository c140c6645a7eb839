// The matrices of the petsc path's three-field system (fe/src/petsc_nest.hpp): the (u, p) system is a
// nest of its blocks, and the field split's displacement solve works on the (u, u) block itself, not
// on an extracted copy of it. Checked through the solver's own accounting of its matrices (entries
// allocated × bytes per entry, fe::petsc_last_matrix_bytes), not through the RSS, and
// against the one-matrix layout ([solver] petsc_nested_matrix = false) on the same problem.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "relative_difference.hpp"
#include "softhom/fe/petsc.hpp"
#include "softhom/fe/solver.hpp"
#include "softhom/core/mpi.hpp"
#include "softhom/macro/benchmark_problems.hpp"
#include "softhom/macro/geometry.hpp"
#include "softhom/materials/laws.hpp"

using namespace softhom;
using namespace softhom::fe;
using softhom::test::relative_difference;

namespace {

/// Cook's membrane, 8 × 8 hex8 F-bar three-field elements in plane strain at K/G = 1e4 (as in
/// test_petsc_macro.cpp), the tip sheared.
FeModel cook8() { return macro::make_cook_membrane_problem(8, 83.3, 1e4, 5.0); }

struct CookRun {
  std::vector<double> u;
  RunStats stats;
  PetscMatrixBytes bytes;
};

CookRun run_cook(const FeModel& m, SolverKind kind, const std::string& petsc, bool nested = true) {
  NewtonOptions o;
  o.solver = kind;
  o.petsc_options = petsc;
  o.petsc_nested_matrix = nested;
  Simulation sim(m, o);
  EXPECT_TRUE(sim.advance_to(1.0).reached());
  return {sim.displacement(), sim.stats(), kind == SolverKind::petsc ? petsc_last_matrix_bytes() : PetscMatrixBytes{}};
}

}  // namespace

TEST(PetscMatrixCopies, TheFieldSplitUsesTheNestedDisplacementBlockItself) {
  const FeModel m = cook8();
  const CookRun direct = run_cook(m, SolverKind::cholmod, "");
  const CookRun nest = run_cook(m, SolverKind::petsc, "-ksp_rtol 1e-10");
  const CookRun flat = run_cook(m, SolverKind::petsc, "-ksp_rtol 1e-10", /*nested=*/false);
  // Both layouts solve the same system with the same preconditioner: the CHOLMOD answer to the Newton
  // tolerance (1e-6, as test_petsc_macro.cpp), and each other's to far below it (only the order of the
  // sums in the matrix products differs; 1e-8 leaves room for a Krylov iteration more or less at 1e-10).
  EXPECT_LT(relative_difference(nest.u, direct.u), 1e-6);
  EXPECT_LT(relative_difference(nest.u, flat.u), 1e-8);
  EXPECT_NEAR(double(nest.stats.krylov_iterations), double(flat.stats.krylov_iterations),
              0.1 * flat.stats.krylov_iterations + 2.0);
  const PetscMatrixBytes& a = nest.bytes;
  const PetscMatrixBytes& b = flat.bytes;
  ASSERT_GT(b.system, 0.0);
  // The one-matrix layout: the field split extracts its displacement block, which holds most of the
  // entries (the pressure rows and columns have ≤ 3 × 8 entries per element against the ~3 × 81 per
  // displacement row of the hex8 mesh), so the copy is more than half the system matrix.
  EXPECT_GT(b.split_copy, 0.5 * b.system);
  // The nest: the same entries in four blocks (preallocated from the same counts), and no copy.
  EXPECT_EQ(a.split_copy, 0.0);
  EXPECT_LE(a.system, b.system * (1.0 + 1e-12));
  EXPECT_GE(a.system, 0.95 * b.system);
}
