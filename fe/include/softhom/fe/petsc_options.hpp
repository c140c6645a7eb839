#pragma once
// What a scene may pass to PETSc's options database ([solver] petsc_options): solver, preconditioner,
// tolerance and monitor settings, and nothing that reads or writes files, starts a debugger or changes
// PETSc's own behaviour. A scene is something users share; PETSc's viewers and logs would otherwise write
// wherever an option points ("-ksp_view ascii:/any/path").
//
// The policy (check_petsc_options):
// - an option is "-name" with an optional value; names are lower-case words joined by '_' and must
//   contain a solver object's word, "ksp_" or "pc_", or start with "mat_mumps_" (the factorization's
//   controls); prefixes before it (fieldsplit_u_, mg_levels_, sub_, pc_bddc_neumann_, ...) are free;
// - names with "view", "monitor" or "converged_reason" print to standard output: they take no value,
//   "ascii" or "ascii::<format>" / "::<format>" (no file name, no binary, draw or socket viewer);
// - names with "file", "log", "history", "debugger", "draw", "dump", "saws", "python" or "viewer_" are refused;
// - tolerances (rtol, atol, divtol, dtol) are finite numbers > 0 (rtol < 1), iteration counts and
//   restarts integers in [1, 10⁷];
// - every value is a plain token (no quote, no '$', no control character).
#include <string>
#include <vector>

namespace softhom::fe {

/// The options of a petsc_options string, as PETSc reads them: ("-name", "value" or "").
std::vector<std::pair<std::string, std::string>> split_petsc_options(const std::string& options);

/// Throws InputError("solver.petsc_options", <the offending option>, why) for an option outside the policy
/// above; an empty string passes.
void check_petsc_options(const std::string& options);

}  // namespace softhom::fe
