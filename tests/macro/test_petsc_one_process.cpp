// The petsc path without an MPI launcher (the one-process program): its elements go straight into
// PETSc's matrix as under MPI (no CSC tangent), and its answer is the CHOLMOD path's. Cook's membrane,
// 6 × 6 hex8 three-field elements in plane strain at K/G = 1e4, the tip sheared (as in
// tests/mpi_macro/test_petsc_macro.cpp, which runs the same comparison under mpirun -n 1 and -n 2).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "softhom/fe/petsc.hpp"
#include "softhom/fe/solver.hpp"
#include "softhom/macro/benchmark_problems.hpp"
#include "softhom/macro/geometry.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/materials/laws.hpp"

using namespace softhom;
using namespace softhom::fe;

namespace {

FeModel cook6() { return macro::make_cook_membrane_problem(6, 83.3, 1e4, 5.0); }

std::vector<double> solve(const FeModel& m, SolverKind kind) {
  NewtonOptions o;
  o.solver = kind;
  o.petsc_options = "-ksp_rtol 1e-10";
  Simulation sim(m, o);
  EXPECT_TRUE(sim.advance_to(1.0).reached());
  return sim.displacement();
}

/// max |u − reference| / max |reference|.
double relative_gap(const std::vector<double>& u, const std::vector<double>& reference) {
  double d = 0.0, s = 1e-300;
  for (std::size_t k = 0; k < reference.size(); ++k) {
    d = std::max(d, std::abs(u[k] - reference[k]));
    s = std::max(s, std::abs(reference[k]));
  }
  return d / s;
}

/// max |u_petsc − u_cholmod| / max |u_cholmod| on `m`.
double gap_to_cholmod(const FeModel& m) { return relative_gap(solve(m, SolverKind::petsc), solve(m, SolverKind::cholmod)); }

}  // namespace

TEST(PetscOneProcess, CookMembraneEqualsCholmodWithoutACopyOfTheTangent) {
  // The Newton tolerance (1e-8 of the force scale) brings the displacements to ~1e-7 at most on this
  // mesh; 1e-6 as in test_petsc_macro.cpp.
  EXPECT_LT(gap_to_cholmod(cook6()), 1e-6);
  // The field split worked on the nest's displacement block, not on an extracted copy.
  const PetscMatrixBytes bytes = petsc_last_matrix_bytes();
  EXPECT_GT(bytes.system, 0.0);
  EXPECT_EQ(bytes.split_copy, 0.0);
}

TEST(PetscOneProcess, BddcOnOneProcessIsADirectSolveAndIsIgnoredOffThePetscPath) {
  // One rank, one subdomain: BDDC factorizes it whole, so the answer is CHOLMOD's and each solve takes
  // a few GMRES iterations (measured 1.7–3 per solve on Cook's membrane with lagged set-ups).
  const FeModel m = cook6();
  NewtonOptions o;
  o.solver = SolverKind::petsc;
  o.petsc_preconditioner = PetscPreconditioner::bddc;
  o.petsc_options = "-ksp_rtol 1e-10";
  Simulation bddc(m, o);
  ASSERT_TRUE(bddc.advance_to(1.0).reached());
  EXPECT_LT(relative_gap(bddc.displacement(), solve(m, SolverKind::cholmod)), 1e-6);
  EXPECT_LE(double(bddc.stats().krylov_iterations) / std::max(1, bddc.stats().linear.solves), 5.0);
  // With the direct solver the choice is said in the log, and the run solves.
  o.solver = SolverKind::cholmod;
  Simulation direct_run(m, o);
  ASSERT_TRUE(direct_run.advance_to(1.0).reached());
  const std::vector<std::string>& log = direct_run.stats().log;
  EXPECT_TRUE(std::any_of(log.begin(), log.end(), [](const std::string& line) {
    return line.find("petsc_preconditioner applies to linear_solver = \"petsc\"; this run solves with cholmod") != std::string::npos;
  }));
}

TEST(PetscOneProcess, AnOptionPetscRejectsAtSetUpIsAnInputErrorNamingIt) {
  // PETSc reads most options only when the object they belong to is set up (here BoomerAMG on the
  // displacement block, at the first tangent): a value it rejects there is the user's error, reported
  // with the field, the options and PETSc's own message, not as a failed PETSc call.
  const FeModel m = cook6();
  NewtonOptions o;
  o.solver = SolverKind::petsc;
  o.petsc_options = "-fieldsplit_u_pc_hypre_boomeramg_nodal_relaxation 10";
  bool thrown = false;
  try {
    Simulation sim(m, o);
    (void)sim.advance_to(1.0);  // throws before it returns
  } catch (const InputError& e) {
    thrown = true;
    EXPECT_EQ(e.field(), "solver.petsc_options");
    EXPECT_EQ(e.value(), o.petsc_options);
    EXPECT_NE(std::string(e.what()).find("Unknown logical value: 10"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(thrown);
  // PETSc's error handling is back to its own: the next simulation in this process solves.
  EXPECT_LT(gap_to_cholmod(m), 1e-6);
}
