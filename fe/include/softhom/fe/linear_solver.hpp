#pragma once
// The linear solver of fe::Simulation in one place: the route a run takes (a sparse factorization or
// PETSc's GMRES over MPI ranks) and its preconditioner, resolved once from the typed [solver] keys
// (NewtonOptions) and facts of the mesh by a pure function, and what a run reports of it.
//
// Routes and their preconditioners (every one is the best measured for some case, BENCHMARKS.md):
// - cholmod: CHOLMOD's LLᵀ of the tangent's symmetric part; in steps where that part is indefinite,
//   MUMPS's LDLᵀ of it where the tangent is symmetric up to round-off (a follower pressure on a surface
//   held on its boundary), UMFPACK's LU otherwise; a direct solve, or GMRES preconditioned by a factor kept across Newton iterations where
//   a factorization costs more than NewtonOptions::lag_flops (with three-field elements on the
//   uncondensed (u, p_e) space unless saddle_krylov is off).
// - umfpack: UMFPACK's LU throughout.
// - petsc: GMRES on the uncondensed (u, p_e) system, assembled element by element on every rank, with
//   - field-split: the (u, p) Schur split with BoomerAMG on the augmented displacement block, or the
//     P2 → P1 two-level multigrid there on meshes with quadratic tets (falling back to BoomerAMG on the
//     P2 block where its coarse space locks);
//   - gamg: smoothed aggregation with the rigid-body modes (no three-field elements: no split);
//   - lu: MUMPS's LU (the default under cavity-volume control);
//   - bddc: balancing domain decomposition, one subdomain per rank;
//   - or the -pc_type of the expert petsc_options string, which overrides all of the above.
#include <optional>
#include <string>

#include "softhom/fe/sparse.hpp"

namespace softhom::fe {

struct NewtonOptions;

/// The displacement block of the petsc field split on meshes with quadratic tets ([solver] petsc_p_multigrid).
/// automatic: the P2 → P1 multigrid, replaced by BoomerAMG on the P2 block for the rest of the run when
/// GMRES does not converge with it; on: the multigrid throughout; off: BoomerAMG on the P2 block.
enum class PMultigrid { automatic, on, off };

/// α of the field split's augmented displacement block with BoomerAMG on it: the best measured on the
/// hex tube (α = 1, 3, 30, 100 need 1.2–3× more iterations; BENCHMARKS.md "Krylov iterations per Newton
/// step: the 3D helix tube").
inline constexpr double kSplitAugmentation = 10.0;
/// α under the p-multigrid: its P1 coarse space locks as the block's bulk part α G grows (one element
/// dilatation per tet), so it wants a smaller α. Measured on the cPASMO 0.5 mesh (158 481 dofs, two load
/// steps, GMRES iterations / CPU): α = 10: 654 / 183 s, 3: 424 / 126 s, 1: 357 / 102 s; BoomerAMG on the
/// P2 block (α = 10): 310 / 142 s.
inline constexpr double kPMultigridAugmentation = 1.0;

enum class LinearRoute { cholmod, umfpack, petsc };

/// The preconditioner of a route (sparse_factor: the factor of the direct routes, exact or lagged).
enum class Preconditioner { sparse_factor, field_split_boomeramg, field_split_p_multigrid, gamg, lu, bddc, petsc_options };

const char* to_string(LinearRoute route);
const char* to_string(Preconditioner preconditioner);

/// What the choice depends on beyond the options.
struct LinearSystemFacts {
  long free_dofs = 0;
  bool quadratic_tets_only = false;  ///< a mesh of tet10 elements alone (automatic's PETSc threshold)
  bool any_tets = false;             ///< some tet10 element (the p-multigrid's settings)
  bool cavity_control = false;
  bool three_field = false;          ///< three-field elements: the petsc system is the (u, p) saddle
};

/// The route, its preconditioner and the settings of the petsc route, resolved (choose_linear_solver).
struct LinearSolverChoice {
  LinearRoute route = LinearRoute::cholmod;
  Preconditioner preconditioner = Preconditioner::sparse_factor;
  /// cholmod: GMRES with a lagged factor runs on the uncondensed (u, p_e) space (three-field elements).
  bool saddle_krylov = false;
  /// cholmod: steps whose symmetric part is indefinite factorize it by MUMPS's LDLᵀ where the tangent is
  /// symmetric up to round-off (NewtonOptions::symmetric_indefinite), by UMFPACK's LU otherwise.
  bool symmetric_indefinite = false;
  // The petsc route.
  std::string user_pc_type;     ///< the -pc_type of petsc_options ("" when it sets none)
  bool field_split = false;     ///< the (u, p) Schur split (with three-field elements): nest, augmentation
  /// The p-multigrid's settings (the GMRES restart of 100 included): on every mesh with quadratic tets but
  /// under BDDC; the multigrid itself where the displacement block is split off.
  bool p_multigrid = false;
  bool p_multigrid_fallback = false;  ///< BoomerAMG on the P2 block takes over after a failed solve
  double augmentation = 10.0;   ///< α of the augmented displacement block (1 under the p-multigrid)
  bool nested_matrix = true;    ///< the distributed (u, p) system as a nest of its four blocks
  bool current_modes = true;    ///< the p-multigrid's coarse near-nullspace at the current positions
  bool bddc_flux = true;        ///< BDDC's primal constraints include the faces' volume fluxes
  std::string petsc_options;    ///< the expert pass-through
};

/// The route and preconditioner of `options` for a system with `facts` (automatic_solver for the route).
/// Throws InputError for an unusable combination.
LinearSolverChoice choose_linear_solver(const NewtonOptions& options, const LinearSystemFacts& facts);

/// The value following `name` in a PETSc options string ("" when absent; the last occurrence wins, as in
/// PETSc's database).
std::string petsc_option_value(const std::string& options, const std::string& name);

/// The linear solver a run used, for its summary.
struct LinearSolverReport {
  std::string route;           ///< to_string(LinearRoute)
  std::string preconditioner;  ///< to_string(Preconditioner) (petsc_options: "petsc_options: <pc_type>")
  std::string description;     ///< the solver's own words, e.g. PETSc's "gmres + fieldsplit (u, p) Schur ..."
  int krylov_iterations = 0;   ///< GMRES iterations
  int factorizations = 0;      ///< numeric factorizations, or preconditioner set-ups on the petsc route
  int solves = 0;              ///< solves with a factor or a preconditioned GMRES
};

}  // namespace softhom::fe
