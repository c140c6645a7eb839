#pragma once
// Quasi-static Newton driver: consistent linearization (including the Dirichlet increment predictor
// and the follower-pressure load stiffness), backtracking line search, sub-stepping by the shared loop
// of step_control.hpp (halving cut-backs on divergence or failed material calls, growth after
// successes, wall-time budget, stop on signal), history committed only after convergence.
//
// Clean stops: a body whose constraints leave a rigid motion free is refused when the Simulation is
// built (InputError naming the motions); a singular first factorization (a mechanism, a disconnected
// part) ends the run at once; a stop request ends it between Newton iterations. advance_to reports
// every such stop in its result, with the converged state kept.
//
// Performance design: elements are coloured so that no two elements of one colour share a
// node, and assembly scatters into precomputed CSC positions without atomics; the linear systems are
// solved by GMRES (krylov.hpp) right-preconditioned with a sparse direct factorization that is kept
// across Newton iterations and refreshed when its GMRES iterations cost 3/4 of a factorization, and at
// the first iteration of every step started from the (quadratic) load predictor (a fresh factor of a
// symmetric tangent solves directly). With the three-field iteration GMRES runs in the uncondensed
// (u, p_e) space (linear_solve.cpp). Late Newton iterations test the residual before assembling a
// tangent. The factor is CHOLMOD's LLᵀ of the tangent's symmetric part (the follower-pressure stiffness
// is the only unsymmetric term), falling back where the symmetric part is not positive definite (past a
// limit point, or a Newton iterate off the path) to MUMPS's LDLᵀ of it for a tangent symmetric up to
// round-off, to UMFPACK LU for another.
#include <array>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "softhom/fe/linear_solver.hpp"
#include "softhom/fe/model.hpp"
#include "softhom/fe/sparse.hpp"
#include "softhom/fe/tet10_element.hpp"
#include "softhom/materials/step_control.hpp"

namespace softhom::fe {

struct NewtonOptions {
  double tolerance = 1e-8;    ///< ‖R_free‖ ≤ tolerance · force scale (reactions + loads)
  int max_iterations = 25;
  int max_cutbacks = 12;      ///< consecutive halvings of one output interval
  double max_step_seconds = 0.0;  ///< wall-time budget of one output interval's cut-backs [s]; 0: unlimited
  bool line_search = true;
  int initial_substeps = 1;   ///< sub-steps per output interval at the start
  SolverKind solver = SolverKind::automatic;  ///< umfpack: always LU; petsc: Krylov + AMG; otherwise Cholesky first
  /// automatic (automatic_solver): PETSc from this many free dofs on, where it beats CHOLMOD. Meshes of
  /// quadratic tets alone (their p-multigrid) from petsc_min_dofs_tet10 (BENCHMARKS.md "Macro solver on PETSc",
  /// `auto`); other meshes from petsc_min_dofs, which no measured size reaches (on the 3D tube
  /// at 1.6e4 dofs the field split is several times slower per Newton iteration than the factor).
  int petsc_min_dofs = 2147483647;
  int petsc_min_dofs_tet10 = 100000;
  /// petsc: keep a preconditioner whose set-up costs more than a quarter of its solve (a factorization,
  /// e.g. MUMPS's LU; a multigrid hierarchy costs less) across tangents while GMRES with it costs less
  /// than a new one, with the refresh rules of the CHOLMOD path's lagged factor.
  bool reuse_preconditioner = true;
  /// petsc: the preconditioner of GMRES (linear_solver.hpp). field_split: the (u, p) Schur split with
  /// algebraic multigrid on the displacement block (one rank's memory grows linearly; GAMG on the whole
  /// system without three-field elements). lu: MUMPS's LU. bddc: PETSc's balancing domain decomposition
  /// by constraints on the element partition (one subdomain per rank, each factorized by MUMPS): on a
  /// given number of ranks Krylov counts flat in K/G and near-flat in the mesh, at the memory of a direct
  /// solve per subdomain (they still grow with the number of subdomains at large K/G). automatic: lu
  /// under cavity-volume control (where the split's AMG stagnates past the pressure maximum), field_split
  /// otherwise.
  PetscPreconditioner petsc_preconditioner = PetscPreconditioner::automatic;
  /// petsc, meshes with quadratic tets: the field split's displacement block (PMultigrid).
  PMultigrid petsc_p_multigrid = PMultigrid::automatic;
  /// petsc field split: α of the augmented displacement block (a bulk modulus ~ α G kept there; 0: the
  /// plain split). Unset: 10 with BoomerAMG on the block, 1 under the p-multigrid (BENCHMARKS.md).
  std::optional<double> petsc_augmentation;
  /// petsc, distributed three-field system: a nest of its four blocks, whose displacement block the field
  /// split uses in place (false: one AIJ matrix, of which the split extracts a copy).
  bool petsc_nested_matrix = true;
  /// petsc p-multigrid with a coarse solver that reads rigid-body modes (GAMG): those of the current
  /// vertex positions at every set-up (false: of the reference ones throughout).
  bool petsc_current_modes = true;
  /// petsc bddc: the volume flux of the three-field elements on every face among the primal constraints.
  bool bddc_flux = true;
  /// Options for PETSc's options database (PetscOptionsInsertString), e.g. "-ksp_type fgmres -pc_type hypre";
  /// they override the settings above (a -pc_type replaces the preconditioner).
  std::string petsc_options;
  bool mixed = true;          ///< three-field (u, θ, p) iteration for laws with a volumetric modulus
  int refactor_after = 8;     ///< refresh the factorization after a solve needing 3× more GMRES iterations
                              ///< (or whose iterations cost half a factorization)
  int krylov_max = 40;        ///< GMRES iterations before a solve refactorizes and retries
  bool extrapolate = true;    ///< secant predictor from the last converged increment (see try_step)
  int extrapolate_order = 2;  ///< 2: quadratic through the last three converged states when available, 1: secant
  /// Three-field iteration with a lagged factor: GMRES on the uncondensed (u, p_e) system, preconditioned
  /// by the exact inverse of the lagged uncondensed system (one solve with the lagged condensed factor +
  /// element operations). false: GMRES on the condensed u system (the condensed K/G ~ 1e5 tangent goes
  /// stale within a Newton step; see solver.cpp, linear_solve).
  bool saddle_krylov = true;
  /// cholmod: steps whose symmetric part is indefinite factorize it by MUMPS's symmetric indefinite LDLᵀ
  /// where the tangent is symmetric up to round-off (half the flops of UMFPACK's LU; false: LU there).
  bool symmetric_indefinite = true;
  /// Factorizations predicted to cost more than this many flops are kept across Newton iterations and
  /// load steps (GMRES with the lagged factor); cheaper ones are redone for every tangent (direct solves).
  double lag_flops = 2e9;
  /// Large (lagged) factors: a fresh factorization at the first iteration of every extrapolated step.
  bool refactor_each_step = true;
  /// From the third Newton iteration on, evaluate the residual alone first and assemble the tangent only
  /// when it does not pass the convergence test (the converging iteration needs no tangent).
  bool residual_first = true;
  /// Kelley's safeguard: the linear tolerance is never tighter than this × tolerance·scale / ‖R‖.
  double forcing_safeguard = 0.1;
  bool verbose = false;       ///< iteration log on stderr
};

/// The solver SolverKind::automatic stands for: PETSc from petsc_min_dofs_tet10 free dofs on for a mesh
/// of quadratic tets alone, from petsc_min_dofs on for any other, CHOLMOD below; always CHOLMOD under
/// cavity-volume control, where the PETSc path preconditions with MUMPS's LU (a factorization like
/// CHOLMOD's, of the larger uncondensed system). Other kinds are returned as they are.
SolverKind automatic_solver(const NewtonOptions& o, long free_dofs, bool quadratic_tets_only, bool cavity_control);

/// Statistics of a run so far.
struct RunStats {
  int steps = 0;              ///< converged sub-steps
  int newton_iterations = 0;
  int cutbacks = 0;
  int line_search_backtracks = 0;
  int krylov_iterations = 0;  ///< GMRES iterations (one preconditioner solve each)
  int tangent_assemblies = 0;   ///< assemblies with the tangent (residual + K)
  int residual_assemblies = 0;  ///< residual-only assemblies (the residual-first convergence test)
  int assembled_elements = 0;   ///< elements this rank evaluates: all, but its own share on the petsc path under MPI
  double assembly_time = 0.0;
  /// Of assembly_time: the element loop alone (kernels and their scatter into the matrix, without the
  /// sums over the ranks and the matrix assembly of distributed runs), wall and CPU seconds of this process.
  double element_loop_time = 0.0, element_loop_cpu = 0.0;
  double krylov_time = 0.0;   ///< GMRES without its preconditioner solves (matrix products, orthogonalization)
  /// Stiffness patterns rebuilt because a contribution's couplings changed (a moving contact set), and
  /// their time (pattern, scatter positions; the symbolic analysis is counted in `linear`).
  int pattern_rebuilds = 0;
  double pattern_rebuild_time = 0.0;
  SolverTimes linear;         ///< analysis / factorization / solve times
  LinearSolverReport linear_solver;  ///< the route, its preconditioner and their counts
  std::vector<std::string> log;  ///< cut-backs and notes, human readable (expected events once)
};

/// Per-element output fields (averages over the Gauss points, current configuration).
struct ElementFields {
  std::vector<double> cauchy;     ///< 9 per element, row-major
  std::vector<double> von_mises;  ///< 1 per element
  std::vector<double> J;          ///< element volume ratio θ
  std::vector<double> fiber;      ///< 3 per element: current unit direction of the first fiber family (0 if none)
};

/// Work of one converged sub-step, or (summed with +=) of an output step or a run.
struct StepCounts {
  int newton_iterations = 0;
  int factorizations = 0;     ///< numeric factorizations (Cholesky or LU)
  int solves = 0;             ///< triangular solves with a factor
  int krylov_iterations = 0;  ///< GMRES iterations
  int cutbacks = 0;           ///< failed sub-steps (halvings)
  StepCounts& operator+=(const StepCounts& o) {
    newton_iterations += o.newton_iterations;
    factorizations += o.factorizations;
    solves += o.solves;
    krylov_iterations += o.krylov_iterations;
    cutbacks += o.cutbacks;
    return *this;
  }
};

/// How Simulation::advance_to ended: reached t_end, or stopped early (the state stays at the last
/// converged sub-step) with the reason. A reachable stop is a result, never an exception.
struct AdvanceResult {
  IntervalStatus status = IntervalStatus::reached;
  std::string message;  ///< describe_interval_failure's sentence (empty when reached)
  StepCounts counts;    ///< the work of this call (every sub-step, failed ones included)
  int substeps = 0;     ///< converged sub-steps
  bool reached() const { return status == IntervalStatus::reached; }
};

class Simulation {
 public:
  /// Throws InputError for a model that cannot be solved: invalid elements, every dof prescribed, or
  /// constraints that leave a rigid-body motion free (the message names the free motions).
  explicit Simulation(FeModel model, NewtonOptions options = {});
  ~Simulation();
  Simulation(const Simulation&) = delete;
  Simulation& operator=(const Simulation&) = delete;

  /// Advances from the current time to t_end with adaptive sub-steps (advance_interval: halving
  /// cut-backs, growth after successes, wall-time budget, stop on signal). A failed interval leaves the
  /// state at the last converged sub-step and says why in the result.
  [[nodiscard]] AdvanceResult advance_to(double t_end);

  double time() const;
  const std::vector<double>& displacement() const;  ///< 3 per node
  std::vector<Vec3> current_positions() const;
  /// Pressure of the cavity control (or 0 without one).
  double cavity_pressure() const;
  /// Reaction force: Σ of the converged state's internal forces over `dofs` (e.g. a loaded face's
  /// x-dofs). Evaluates no material (so it never advances a viscoelastic history). On the petsc path
  /// under MPI a collective call before the first step (each rank sums its own elements).
  double reaction(const std::vector<int>& dofs) const;
  ElementFields element_fields() const;
  /// The probes and fields of every contribution at the converged state (ContributionReport).
  void report(ContributionReport& out) const;
  /// The converged state as contribution `c` (one of the model's) sees it: time, displacement and its
  /// committed history (state_old; state_new null), for its own queries (e.g. a contact's totals).
  Iterate converged_iterate(const Contribution& c) const;
  /// Statistics so far (linear-solver times of the current solver object).
  RunStats stats() const;
  /// Work of the last converged sub-step.
  const StepCounts& last_step_counts() const;
  /// Factorization in use (the configured one before the first solve).
  SolverKind solver_kind() const;
  int num_free_dofs() const;
  const FeModel& model() const;

  /// Element residual and tangent at the current state (for diagnostics and tests). On the petsc path
  /// under MPI a rank holds the history of its own elements only (RunStats::assembled_elements).
  MaterialStatus element_force(int e, const Mat83& u, Vec24& r, Mat24* K) const;
  /// The same for a tet10 element e (≥ mesh.num_hexes()).
  MaterialStatus element_force(int e, const Tet10Coords& u, Vec30& r, Mat30* K) const;

  struct Impl;  ///< the state and the steps (fe/src/simulation_impl.hpp)

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace softhom::fe
