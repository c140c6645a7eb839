#pragma once
// The state and the steps of fe::Simulation (solver.hpp), shared by its translation units:
// solver.cpp (set-up, Newton iteration, sub-step loop, outputs), assembly.cpp (the loop over the
// contributions, the solids' element loop and the AssemblySink), contributions.cpp (the model's loads
// and constraints), linear_solve.cpp (factorizations and the Krylov solves).
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <ctime>
#include <memory>
#include <string>
#include <vector>

#include "softhom/core/krylov.hpp"
#include "softhom/fe/solver.hpp"
#include "linear_solver_factory.hpp"
#include "petsc_solve.hpp"

namespace softhom::fe {
namespace detail {


inline double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

inline double process_cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

inline double norm(const std::vector<double>& v) {
  double s = 0.0;
  for (double x : v) s += x * x;
  return std::sqrt(s);
}

inline Mat83 gather(const std::vector<double>& u, const Hex& hex) {
  Mat83 ue;
  for (int a = 0; a < 8; ++a)
    for (int i = 0; i < 3; ++i) ue(a, i) = u[3 * hex[a] + i];
  return ue;
}

inline Tet10Coords gather(const std::vector<double>& u, const Tet10& tet) {
  Tet10Coords ue;
  for (int a = 0; a < 10; ++a)
    for (int i = 0; i < 3; ++i) ue(a, i) = u[3 * tet[a] + i];
  return ue;
}

/// Reference coordinates of element e's N nodes, one row per node.
template <int N>
Eigen::Matrix<double, N, 3> element_coords(const Mesh& mesh, int e) {
  Eigen::Matrix<double, N, 3> X;
  const int* nodes = mesh.element_nodes(e);
  for (int a = 0; a < N; ++a) X.row(a) = mesh.nodes[nodes[a]].transpose();
  return X;
}

/// Gauss points per element (history blocks).
inline int gauss_points(const Mesh& mesh, int e) { return mesh.is_tet(e) ? 4 : 8; }


}  // namespace detail

/// One assembly: residuals, load vectors and element stresses at an iterate.
struct Assembly {
  std::vector<double> R;       ///< f_int − f_ext on all dofs (condensed three-field residual: Newton's rhs)
  std::vector<double> R_true;  ///< the F-bar residual (convergence test); empty without three-field elements
  std::vector<double> R_u;     ///< u-row of the three-field residual r_rest + V p d (line search); idem
  std::vector<double> a;       ///< cavity unit-pressure vector on all dofs (∂R/∂p)
  std::vector<double> g;       ///< cavity volume gradient on all dofs (∂V/∂u; −a when the faces close the cavity)
  std::vector<double> dirichlet_rhs;  ///< K_fc Δu_c on all dofs (predictor only)
  std::vector<double> cauchy;  ///< 9 per element
  std::vector<double> fint;    ///< internal forces on all dofs (F-bar), for reactions at the converged state
  double fint_norm = 0.0, fext_norm = 0.0, volume = 0.0;
  MaterialStatus status = MaterialStatus::ok;
  int failed_element = -1;
};

/// The mesh's solids (hex8 and tet10) as the first contribution of every assembly: the coloured
/// element loop of assembly.cpp, each rank its own elements, their sums over the ranks. Their couplings
/// are the mesh's elements, which the pattern builders walk directly. The element data it evaluates
/// (geometry, history, the three-field unknowns) lives in Simulation::Impl, where the linear solvers
/// read it too.
class SolidDomain final : public Contribution {
 public:
  explicit SolidDomain(Simulation::Impl& s) : s_(s) {}
  Kind kind() const override { return Kind::domain; }
  std::string name() const override { return "solids"; }
  MaterialStatus assemble(const Mesh& mesh, const Iterate& it, AssemblySink& sink) const override;

 private:
  Simulation::Impl& s_;
};

/// The driver's AssemblySink: residuals into an Assembly (R, and the three-field R_true and R_u alike;
/// f_ext for external forces), the tangent into the CSC matrix K_ or, on the petsc path, into PETSc
/// (each rank keeping its own rows), a prescribed column's increment into the predictor's right-hand
/// side, and the cavity's border.
class AssemblyTarget final : public AssemblySink {
 public:
  AssemblyTarget(Simulation::Impl& s, Assembly& out, const std::vector<double>& du_c, bool tangent);
  void add_residual(int n, const int* dofs, const double* r) override;
  void add_tangent(int nr, const int* rows, int nc, const int* cols, const double* k) override;
  void add_border(int n, const int* dofs, const double* dR_dlambda, const double* dc_du) override;
  void add_constraint_value(double value) override;
  Assembly& out;
  const std::vector<double>& du_c;  ///< prescribed increments (empty: no predictor)
  std::vector<double> fext;         ///< the external forces (force scale)
  bool external = false;            ///< the contribution being added is an external force

 private:
  Simulation::Impl& s_;
};

/// Outcome of one sub-step attempt (the shape advance_interval expects).
struct StepAttempt {
  bool ok = false;
  std::string why;
  bool fatal = false;  ///< no smaller step can help (a singular system)
};

/// The Newton iterate of one sub-step: displacement, cavity pressure, their line-search base and the
/// last correction.
struct NewtonIterate {
  std::vector<double> u, u_base, du_c;  ///< du_c: prescribed increments of the step (empty: none)
  double p = 0.0, p_base = 0.0, dp = 0.0, alpha = 1.0, s0 = 0.0;
  std::vector<double> x1, x2, rhs, afree, du_full;
  double r0 = -1.0, r_prev = 1e300, last_du = 1e300, u_max = 0.0;
  int backtracks = 0;
};

struct Simulation::Impl {
  Impl(FeModel model, NewtonOptions options);

  // Set-up (solver.cpp).
  void build_dofs();            ///< equation numbers, stiffness pattern; refuses unconstrained bodies
  void build_geometry();        ///< Gauss-point geometry per element; refuses inverted elements
  void build_history();         ///< history blocks of the inelastic elements
  void build_linear_solvers();  ///< the route and preconditioner (choose_linear_solver) and the solver
  void build_colouring();       ///< element colours: no shared node within one colour
  void build_scatter();         ///< CSC positions of every element's node-pair blocks
  void build_mixed();           ///< three-field element unknowns and the uncondensed Krylov space
  // Distributed assembly (distributed_assembly.cpp): the petsc path, on one process or under MPI.
  /// The petsc solver is in use: each rank (the one process included) assembles its own elements into
  /// the PETSc matrix.
  bool petsc_distributed() const;
  /// The configured linear solver, `automatic` resolved for this mesh and its free dofs.
  SolverKind resolved_solver() const;
  void build_partition();           ///< element owners (sets distributed_, owned_elements_)
  void build_distributed_system();  ///< the PETSc matrix's rows from the partition (after build_mixed)
  /// Sums over the ranks of the owned elements' residuals (and the first failed element).
  void reduce_element_sums(Assembly& out) const;
  /// The element stresses of every element (each rank computed its own): before a commit.
  void reduce_cauchy(std::vector<double>& cauchy) const;
  /// Σ over the ranks (distributed assembly), v itself otherwise.
  double sum_over_ranks(double v) const;

  // Couplings that follow the configuration (pairing.cpp): the contributions' pairing at the start of
  // every sub-step attempt, and the stiffness pattern rebuilt when their couplings change.
  void update_pairing();
  /// The static couplings and the current pairing's, in one list (the pattern's and the preallocation's).
  Couplings all_couplings() const;
  void rebuild_pattern();

  // One sub-step (solver.cpp): predictor, Newton iteration with line search, commit.
  StepAttempt try_step(double t_new, double dt);
  void reset_mixed_iterate();
  /// Increments of the prescribed dofs to their values at t_new (empty when none moves).
  std::vector<double> prescribed_increment(double t_new) const;
  /// Secant or quadratic start u from the last converged states (sets extrapolated_).
  void extrapolate(double t_new, std::vector<double>& u);
  MaterialStatus evaluate_iterate(int it, bool predictor, double t_new, double dt, double v_target,
                                  const NewtonIterate& n, Assembly& as);
  MaterialStatus line_search(double t_new, double dt, MaterialStatus st, NewtonIterate& n, Assembly& as);
  bool converged_at(double rc, const Assembly& a, int iter, const NewtonIterate& n, double v_target) const;
  double volume_residual(const Assembly& a, double v_target) const;
  static double force_scale(const Assembly& a) { return std::max({a.fint_norm, a.fext_norm, 1e-300}); }
  /// The Newton correction x1 (and the cavity pressure increment dp) of the current residual.
  bool newton_correction(int it, bool predictor, double rc, double rc_last, double rn, double scale,
                         double v_target, const Assembly& as, NewtonIterate& n, std::string& why);
  void apply_correction(bool predictor, const Assembly& as, NewtonIterate& n);
  void commit(NewtonIterate& n, Assembly& as, int iterations);
  // The sub-step loop (solver.cpp).
  AdvanceResult advance_to(double t_end);
  StepAttempt attempt_substep(double t_new, double dt);
  void note_once(const std::string& key, const std::string& message);

  // Assembly (assembly.cpp): every contribution in one loop.
  MaterialStatus assemble(double t, double dt, bool tangent, const std::vector<double>& u, double cavity_p,
                          Assembly& out);
  /// Clears the residuals and starts the tangent (K_ zeroed, or PETSc's fill begun); returns the
  /// predictor's prescribed increments (taken from out.dirichlet_rhs, empty without a predictor).
  std::vector<double> begin_assembly(bool tangent, const std::vector<double>& u, Assembly& out);
  /// Element loop: internal forces, three-field residuals, tangent, predictor rhs K_fc Δu_c.
  void assemble_elements(double dt, bool tangent, const std::vector<double>& u, const std::vector<double>& du_c,
                         Assembly& out);

  // Linear algebra (linear_solve.cpp).
  /// x = K⁻¹ b (free dofs) to relative residual `tol`; false when no factorization works. `secant_start`:
  /// the first solve from the secant predictor, whose failure is retried from the converged state.
  bool linear_solve(const std::vector<double>& b, std::vector<double>& x, double tol, std::string& why,
                    bool secant_start = false);
  /// GMRES with the current factor as preconditioner (uncondensed (u, p_e) space for three-field
  /// elements with a lagged factor); refactorizes and retries once.
  bool krylov_solve(const std::vector<double>& b, std::vector<double>& x, double tol, std::string& why);
  /// GMRES's options for the current factor: a lagged one gets the iterations that cost less than a
  /// fresh factorization.
  krylov::GmresOptions gmres_budget(double tol) const;
  /// After a converged solve of `its` iterations with a lagged factor: stale once they cost too much.
  void judge_lagged_factor(int its);
  bool refactor(std::string& why);
  /// The saddle data (d_e, c_e) of the factorized tangent, for the uncondensed preconditioner.
  void keep_saddle_of_factor(bool ok);
  /// A singular first factorization is a fatal stop (singular_system_); otherwise `ok`.
  bool check_first_factorization(bool ok, std::string& why);
  /// The petsc solver's solve (petsc_linear_solve.cpp): GMRES to `tol` with the preconditioner of this
  /// tangent or, where reuse pays, a lagged one (rebuilt and solved again when it fails).
  bool petsc_linear_solve(const std::vector<double>& b, std::vector<double>& x, double tol, std::string& why,
                          bool secant_start);
  /// The current tangent into PETSc's operator, with a new preconditioner or keeping the last one.
  void petsc_set_operator(bool new_preconditioner);
  /// A lagged preconditioner can save more than it costs: its set-up is a large part of a solve.
  bool petsc_reuse_pays() const;
  void saddle_current();  ///< fills sad_db_, sad_cb_ from the last tangent assembly
  void mixed_update(const std::vector<double>& du, double alpha);
  /// The uncondensed Krylov space is in use: three-field elements and factors large enough to be lagged.
  bool saddle_lagged() const {
    return options_.saddle_krylov && !sad_elem_.empty() && last_factor_flops_ >= options_.lag_flops;
  }
  /// Linear-solver work so far.
  SolverTimes linear_times() const { return solver_->times(); }
  /// The route, its preconditioner and their counts so far.
  LinearSolverReport linear_report() const;

  // Outputs (solver.cpp).
  std::vector<Vec3> current_positions() const;
  double reaction(const std::vector<int>& dofs) const;
  ElementFields element_fields() const;
  RunStats stats() const;
  MaterialStatus element_force(int e, const Mat83& u, Vec24& r, Mat24* K) const;
  MaterialStatus element_force(int e, const Tet10Coords& u, Vec30& r, Mat30* K) const;

  FeModel model_;
  SolidDomain solids_{*this};
  /// Assembly order: the solids, then model_.assembly_order() (internal forces first).
  std::vector<const Contribution*> contributions_;
  Couplings couplings_;  ///< of every contribution beyond the solids (whose couplings are the mesh's elements)
  Couplings pairing_couplings_;  ///< of the contributions whose couplings change (Contribution::pair), this step's
  bool pairing_ = false;         ///< some contribution's couplings change
  NewtonOptions options_;
  DofMap dofs_;
  CscMatrix K_;
  // The linear solver (linear_solver_factory.hpp): its route and preconditioner, the one object that
  // solves, and that object as what it is: the factor of the direct routes or, on the petsc route, the
  // PETSc solver whose matrix the element loop fills.
  LinearSolverChoice linear_choice_;
  std::unique_ptr<LinearSolver> solver_;
  SparseDirectSolver* direct_ = nullptr;
  PetscSolver* petsc_ = nullptr;
  // Distributed assembly: this rank evaluates owned_elements_ only (their history alone is stored);
  // K_ and the scatter positions stay empty (the matrix is PETSc's). Mesh, geometry and the Newton
  // vectors (u, R, ...) stay replicated; the residuals are summed over the ranks after the element loop.
  bool distributed_ = false;
  std::vector<int> element_owner_, owned_elements_;
  int mpi_rank_ = 0, mpi_ranks_ = 1;
  /// This rank evaluates element e (always without distributed assembly).
  bool owns(int e) const { return !distributed_ || element_owner_[e] == mpi_rank_; }
  bool refactor_first_ = false;               ///< the lagged factor failed at the last step's first iteration
  bool factor_valid_ = false, factor_stale_ = false, factor_exact_ = false;
  long k_version_ = 0, factor_version_ = -1;  ///< tangent assemblies; the one last factorized
  double last_factor_time_ = 0.0, last_factor_flops_ = 0.0;
  double iteration_time_ = 0.0;                  ///< running mean cost of one GMRES iteration [s]
  // The petsc path's preconditioner reuse (petsc_linear_solve.cpp): the tangent in PETSc's operator, the
  // last set-up's seconds, a GMRES iteration's (running mean), the last fresh solve's iterations and the
  // consecutive failed lagged solves (two stop the reuse until the step is done).
  long petsc_operator_version_ = -1;
  double petsc_setup_time_ = 0.0, petsc_iteration_time_ = 0.0;
  int petsc_fresh_iterations_ = 0, petsc_lag_failures_ = 0;
  krylov::GmresWorkspace<std::vector<double>> krylov_;  ///< GMRES basis, M⁻¹ of it, condensed residuals; kept between solves
  // Uncondensed (u, p_e) Krylov space of the three-field iteration (linear_solve): per mixed element k,
  // its element number, the free equation of each element dof (−1 fixed) at sad_off_[k] .. sad_off_[k+1],
  // and d_e = ∂θ_e/∂u, c_e = V_e U″(θ) of the current tangent (b) and of the factorized one (a).
  std::vector<int> sad_elem_, sad_off_, sad_eq_;
  std::vector<std::vector<int>> sad_colors_;  ///< the element colours, as mixed-element indices k
  std::vector<double> sad_db_, sad_cb_, sad_da_, sad_ca_;
  bool sad_a_valid_ = false;
  long sad_b_version_ = -1;  ///< k_version_ of sad_db_, sad_cb_
  // Gauss-point geometry of the elements this rank evaluates (all of them without distributed assembly):
  // geometry_slot_[e] indexes geometry_ (hexes) or tet_geometry_ (tets), −1 for another rank's element,
  // whose geometry is recomputed when asked for (outputs, the public element_force). At 1e6 dofs the
  // replicated tet10 geometry was 0.3 GiB per rank.
  std::vector<int> geometry_slot_;
  std::vector<Hex8Geometry> geometry_;
  std::vector<Tet10Geometry> tet_geometry_;
  const Hex8Geometry& hex_geometry(int e, Hex8Geometry& scratch) const;
  const Tet10Geometry& tet_geometry(int e, Tet10Geometry& scratch) const;
  std::vector<std::vector<int>> colors_;  ///< element colours: no shared node within one colour
  std::vector<std::array<long, 64>> block_;  ///< per element, node pair (a, b): K position of (a_0, b_0), −1 if absent
  std::vector<std::array<long, 100>> tet_block_;  ///< the same per tet (10 × 10 node pairs)
  std::vector<std::array<signed char, 3>> free_rank_;  ///< per node: rank of each free component (−1 fixed)
  // Three-field iteration (per element; bulk 0 = plain F-bar): iterate, converged and linearization data.
  std::vector<double> mix_bulk_, mix_theta_, mix_p_, mix_theta_conv_, mix_p_conv_, mix_theta_u_;
  std::vector<double> mix_theta_base_, mix_p_base_, mix_dtheta_, mix_dp_;
  // ∂θ_e/∂u of the elements this rank evaluates, at geometry_slot_[e] (hexes, tets).
  std::vector<Vec24> mix_d_;
  std::vector<Vec30> mix_d_tet_;
  const double* mixed_gradient(int e) const {
    return model_.mesh.is_tet(e) ? mix_d_tet_[geometry_slot_[e]].data() : mix_d_[geometry_slot_[e]].data();
  }
  std::vector<double> u_, u_prev_step_;  ///< converged displacement and the one before it (secant predictor)
  double prev_step_time_ = 0.0;            ///< time of u_prev_step_
  std::vector<double> u_prev2_step_;       ///< the converged displacement before u_prev_step_ (quadratic predictor)
  double prev2_step_time_ = 0.0;           ///< its time (valid when stored_steps_ ≥ 2)
  int stored_steps_ = 0;                   ///< converged steps behind u_ (capped at 2)
  bool extrapolate_step_ = true;           ///< false while a step is retried without the secant predictor
  bool extrapolated_ = false;              ///< the last try_step started from the secant predictor
  FailureBackoff extrapolation_backoff_{0};  ///< sub-steps that start from the converged state
  double stiffness_time_ = -1.0;           ///< ≥ 0: time of the pressure in the load stiffness (assemble)
  std::vector<double> state_old_, state_new_;
  std::vector<double> cauchy_;     ///< element-mean Cauchy stress of the last converged state
  std::vector<double> fint_;       ///< internal forces (all dofs) of the last converged state
  std::vector<int> state_offset_;  ///< per element into the state arrays (−1: elastic)
  /// The contributions' own history (Contribution::state_size), committed with the elements': per entry
  /// of contributions_ its offset into these arrays (−1: none).
  std::vector<double> contribution_state_old_, contribution_state_new_;
  std::vector<long> contribution_state_offset_;
  double time_ = 0.0, last_dt_ = 0.0;
  bool recent_cutback_ = false;
  double next_dt_ = 0.0;           ///< sub-step the next interval starts with after cut-backs
  double cavity_pressure_ = 0.0, cavity_v0_ = 0.0;
  bool first_factorization_ = true; ///< the next factorization is the first one (singularity diagnosis)
  bool anisotropic_smoother_noted_ = false;  // the PETSc path's switch of its P2 smoother, logged once
  bool singular_system_ = false;    ///< the first factorization found the system singular: a fatal stop
  StepCounts attempt_counts_;      ///< work of the current sub-step attempt
  StepCounts last_step_;           ///< work of the last converged sub-step
  std::vector<std::string> noted_; ///< keys of the notes already logged (note_once)
  RunStats stats_;
};

}  // namespace softhom::fe
