// choose_linear_solver: the route and preconditioner of a macro run from the typed [solver] keys and
// the facts of the mesh, as documented in softhom/fe/linear_solver.hpp.
#include <gtest/gtest.h>

#include "softhom/fe/linear_solver.hpp"
#include "softhom/fe/solver.hpp"
#include "softhom/materials/errors.hpp"

using namespace softhom;
using namespace softhom::fe;

namespace {

/// A mesh of quadratic tets with three-field elements, above auto's PETSc threshold.
LinearSystemFacts large_tet10() {
  LinearSystemFacts f;
  f.free_dofs = 200000;
  f.quadratic_tets_only = true;
  f.any_tets = true;
  f.three_field = true;
  return f;
}

NewtonOptions petsc() {
  NewtonOptions o;
  o.solver = SolverKind::petsc;
  return o;
}

}  // namespace

TEST(LinearSolverChoice, DirectRoutesBelowThePetscSizes) {
  NewtonOptions o;
  LinearSystemFacts f = large_tet10();
  f.free_dofs = 99999;
  LinearSolverChoice c = choose_linear_solver(o, f);
  EXPECT_EQ(c.route, LinearRoute::cholmod);
  EXPECT_EQ(c.preconditioner, Preconditioner::sparse_factor);
  EXPECT_TRUE(c.saddle_krylov);  // three-field elements: lagged GMRES on (u, p_e)
  o.saddle_krylov = false;
  EXPECT_FALSE(choose_linear_solver(o, f).saddle_krylov);
  o.solver = SolverKind::umfpack;
  c = choose_linear_solver(o, large_tet10());
  EXPECT_EQ(c.route, LinearRoute::umfpack);
  EXPECT_EQ(c.preconditioner, Preconditioner::sparse_factor);
  // A hex mesh stays with CHOLMOD at any size, as does cavity control.
  LinearSystemFacts hexes = large_tet10();
  hexes.quadratic_tets_only = hexes.any_tets = false;
  EXPECT_EQ(choose_linear_solver(NewtonOptions{}, hexes).route, LinearRoute::cholmod);
  LinearSystemFacts cavity = large_tet10();
  cavity.cavity_control = true;
  EXPECT_EQ(choose_linear_solver(NewtonOptions{}, cavity).route, LinearRoute::cholmod);
}

TEST(LinearSolverChoice, AutoTakesThePMultigridSplitOnLargeTet10Meshes) {
  const LinearSolverChoice c = choose_linear_solver(NewtonOptions{}, large_tet10());
  EXPECT_EQ(c.route, LinearRoute::petsc);
  EXPECT_EQ(c.preconditioner, Preconditioner::field_split_p_multigrid);
  EXPECT_TRUE(c.field_split);
  EXPECT_TRUE(c.p_multigrid);
  EXPECT_TRUE(c.p_multigrid_fallback);
  EXPECT_EQ(c.augmentation, kPMultigridAugmentation);
  EXPECT_TRUE(c.nested_matrix);
  EXPECT_TRUE(c.current_modes);
  EXPECT_FALSE(c.bddc_flux);
}

TEST(LinearSolverChoice, TheDisplacementBlockByTheKeys) {
  NewtonOptions o = petsc();
  o.petsc_p_multigrid = PMultigrid::off;
  LinearSolverChoice c = choose_linear_solver(o, large_tet10());
  EXPECT_EQ(c.preconditioner, Preconditioner::field_split_boomeramg);
  EXPECT_FALSE(c.p_multigrid);
  EXPECT_EQ(c.augmentation, kSplitAugmentation);
  // Chosen explicitly: no fall-back replaces it.
  o.petsc_p_multigrid = PMultigrid::on;
  c = choose_linear_solver(o, large_tet10());
  EXPECT_EQ(c.preconditioner, Preconditioner::field_split_p_multigrid);
  EXPECT_FALSE(c.p_multigrid_fallback);
  o = petsc();
  o.petsc_augmentation = 3.0;
  c = choose_linear_solver(o, large_tet10());
  EXPECT_EQ(c.augmentation, 3.0);
  EXPECT_FALSE(c.p_multigrid_fallback);
  o = petsc();
  o.petsc_options = "-fieldsplit_u_pc_type gamg";
  EXPECT_FALSE(choose_linear_solver(o, large_tet10()).p_multigrid_fallback);
  // A hex mesh: BoomerAMG on the displacement block; without three-field elements no split (GAMG).
  LinearSystemFacts hexes = large_tet10();
  hexes.quadratic_tets_only = hexes.any_tets = false;
  c = choose_linear_solver(petsc(), hexes);
  EXPECT_EQ(c.preconditioner, Preconditioner::field_split_boomeramg);
  EXPECT_EQ(c.augmentation, kSplitAugmentation);
  hexes.three_field = false;
  EXPECT_EQ(choose_linear_solver(petsc(), hexes).preconditioner, Preconditioner::gamg);
  o = petsc();
  o.petsc_augmentation = -1.0;
  EXPECT_THROW(choose_linear_solver(o, large_tet10()), InputError);
}

TEST(LinearSolverChoice, CavityControlTakesMumpsUnlessAsked) {
  LinearSystemFacts f = large_tet10();
  f.cavity_control = true;
  LinearSolverChoice c = choose_linear_solver(petsc(), f);
  EXPECT_EQ(c.preconditioner, Preconditioner::lu);
  EXPECT_FALSE(c.field_split);
  NewtonOptions o = petsc();
  o.petsc_preconditioner = PetscPreconditioner::field_split;
  EXPECT_EQ(choose_linear_solver(o, f).preconditioner, Preconditioner::field_split_p_multigrid);
  o.petsc_preconditioner = PetscPreconditioner::lu;
  EXPECT_EQ(choose_linear_solver(o, large_tet10()).preconditioner, Preconditioner::lu);
}

TEST(LinearSolverChoice, BddcByKeyOrByTheExpertOptions) {
  NewtonOptions o = petsc();
  o.petsc_preconditioner = PetscPreconditioner::bddc;
  LinearSolverChoice c = choose_linear_solver(o, large_tet10());
  EXPECT_EQ(c.preconditioner, Preconditioner::bddc);
  EXPECT_FALSE(c.field_split);
  EXPECT_FALSE(c.p_multigrid);  // BDDC condenses every element
  EXPECT_TRUE(c.bddc_flux);
  o.bddc_flux = false;
  EXPECT_FALSE(choose_linear_solver(o, large_tet10()).bddc_flux);
  o = petsc();
  o.petsc_options = "-ksp_rtol 1e-10 -pc_type bddc";
  EXPECT_EQ(choose_linear_solver(o, large_tet10()).preconditioner, Preconditioner::bddc);
}

TEST(LinearSolverChoice, AnExpertPcTypeReplacesTheTypedPreconditioner) {
  NewtonOptions o = petsc();
  o.petsc_preconditioner = PetscPreconditioner::lu;
  o.petsc_options = "-pc_type hypre -ksp_rtol 1e-10";
  LinearSolverChoice c = choose_linear_solver(o, large_tet10());
  EXPECT_EQ(c.preconditioner, Preconditioner::petsc_options);
  EXPECT_EQ(c.user_pc_type, "hypre");
  EXPECT_FALSE(c.field_split);
  // The settings of the p-multigrid stay with the mesh (its GMRES restart among them).
  EXPECT_TRUE(c.p_multigrid);
  o.petsc_options = "-pc_type fieldsplit";
  EXPECT_TRUE(choose_linear_solver(o, large_tet10()).field_split);
}

TEST(LinearSolverChoice, PetscOptionValueIsTheLastOccurrence) {
  EXPECT_EQ(petsc_option_value("-ksp_rtol 1e-10 -pc_type lu -pc_factor_mat_solver_type mumps", "-pc_type"), "lu");
  EXPECT_EQ(petsc_option_value("-pc_type lu -pc_type hypre", "-pc_type"), "hypre");
  EXPECT_EQ(petsc_option_value("-ksp_rtol 1e-10", "-pc_type"), "");
  EXPECT_EQ(petsc_option_value("-pc_type", "-pc_type"), "");
  EXPECT_EQ(petsc_option_value("", "-pc_type"), "");
}

TEST(LinearSolverChoice, NamesForTheSummary) {
  EXPECT_STREQ(to_string(LinearRoute::cholmod), "cholmod");
  EXPECT_STREQ(to_string(LinearRoute::petsc), "petsc");
  EXPECT_STREQ(to_string(Preconditioner::field_split_p_multigrid), "field-split-p-multigrid");
  EXPECT_STREQ(to_string(Preconditioner::lu), "mumps-lu");
}
