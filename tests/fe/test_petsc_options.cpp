// The policy of a scene's petsc_options (fe/petsc_options.hpp): solver settings pass, anything that
// writes or reads files, unknown kinds of options, malformed strings and impossible tolerances are refused
// naming solver.petsc_options and the option.
#include <gtest/gtest.h>

#include <string>

#include "softhom/core/input_error.hpp"
#include "softhom/fe/petsc_options.hpp"

using namespace softhom;

namespace {

/// The message of the InputError `options` raises, or "" when they pass.
std::string refusal(const std::string& options) {
  try {
    fe::check_petsc_options(options);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(PetscOptions, SolverSettingsOfTheShippedScenesAndDocumentsPass) {
  for (const char* ok : {"", "-ksp_rtol 1e-10", "-pc_type lu -pc_factor_mat_solver_type mumps",
                         "-fieldsplit_u_mg_coarse_pc_type gamg -fieldsplit_u_mg_coarse_ksp_type richardson "
                         "-fieldsplit_u_mg_coarse_ksp_max_it 2 -fieldsplit_u_mg_coarse_ksp_norm_type none",
                         "-fieldsplit_u_pc_hypre_boomeramg_nodal_relaxation 10", "-pc_type hypre -ksp_rtol 1e-10",
                         "-ksp_monitor", "-ksp_view ::ascii_info", "-ksp_converged_reason ascii", "-mat_mumps_icntl_14 50",
                         "-ksp_type fgmres -ksp_gmres_restart 60 -ksp_max_it 500", "-pc_bddc_use_deluxe_scaling"})
    EXPECT_EQ(refusal(ok), "") << ok;
}

TEST(PetscOptions, ViewersAndLogsThatWriteFilesAreRefusedNamingTheOption) {
  for (const char* bad : {"-ksp_view ascii:/tmp/victim.txt", "-log_view :F", "-mat_view ascii:F", "-ksp_monitor ascii:F",
                          "-viewer_binary_filename F", "-ksp_view ascii:../../x", "-ksp_view binary",
                          "-ksp_monitor draw", "-options_file /etc/passwd", "-on_error_attach_debugger",
                          "-start_in_debugger", "-history h.txt", "-ksp_view_mat binary:m.bin"}) {
    const std::string m = refusal(bad);
    EXPECT_NE(m.find("solver.petsc_options"), std::string::npos) << bad << ": " << m;
    EXPECT_NE(m.find(std::string(bad).substr(0, std::string(bad).find(' '))), std::string::npos) << bad << ": " << m;
  }
}

TEST(PetscOptions, UnknownMalformedAndImpossibleOptionsAreRefused) {
  for (const char* bad : {"-totally_unknown_option 5", "ksp_rtol 1e-8", "-ksp_type \"gmres", "-ksp_rtol -1",
                          "-ksp_rtol nan", "-ksp_rtol 2", "-ksp_max_it 1e20", "-ksp_max_it 2.5", "-ksp_atol 0",
                          "-ksp_rtol 1e-8 extra", "-KSP_TYPE gmres", "-ksp_type $(touch x)"})
    EXPECT_NE(refusal(bad), "") << bad;
}

TEST(PetscOptions, NegativeNumbersAreValuesNotOptions) {
  const auto split = fe::split_petsc_options("-mg_levels_ksp_chebyshev_esteig 0,0.1,0,1.1 -pc_gamg_threshold -1");
  ASSERT_EQ(split.size(), 2u);
  EXPECT_EQ(split[1].second, "-1");
}
