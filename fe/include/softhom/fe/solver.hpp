#pragma once
// Quasi-static Newton driver: consistent linearization (including the Dirichlet increment predictor
// and the follower-pressure load stiffness), backtracking line search, adaptive sub-stepping with
// cut-back on divergence or failed material calls, history committed only after convergence.
//
// Performance design (issue #4): elements are coloured so that no two elements of one colour share a
// node, and assembly scatters into precomputed CSC positions without atomics; the linear systems are
// solved by GMRES right-preconditioned with a sparse direct factorization that is kept across Newton
// iterations and refreshed when its GMRES iterations cost 3/4 of a factorization, and at the first
// iteration of every step started from the (quadratic) load predictor (a fresh factor of a symmetric
// tangent solves directly). With the three-field iteration GMRES runs in the uncondensed (u, p_e) space
// (linear_solve). Late Newton iterations test the residual before assembling a tangent. The factor is CHOLMOD's LLᵀ of the tangent's symmetric part
// (the follower-pressure stiffness is the only unsymmetric term), falling back to UMFPACK LU when the
// symmetric part is not positive definite (past a limit point).
#include <array>
#include <functional>
#include <string>
#include <vector>

#include "softhom/fe/model.hpp"
#include "softhom/fe/sparse.hpp"
#include "softhom/fe/tet10_element.hpp"

namespace softhom::fe {

struct NewtonOptions {
  double tolerance = 1e-8;    ///< ‖R_free‖ ≤ tolerance · force scale (reactions + loads)
  int max_iterations = 25;
  int max_cutbacks = 12;      ///< consecutive halvings of one output interval
  double max_step_seconds = 0.0;  ///< wall-time budget of one output interval's cut-backs [s]; 0: unlimited
  bool line_search = true;
  int initial_substeps = 1;   ///< sub-steps per output interval at the start
  SolverKind solver = SolverKind::automatic;  ///< umfpack: always LU; otherwise Cholesky first
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

/// Statistics of a run so far.
struct RunStats {
  int steps = 0;              ///< converged sub-steps
  int newton_iterations = 0;
  int cutbacks = 0;
  int line_search_backtracks = 0;
  int krylov_iterations = 0;  ///< GMRES iterations (one preconditioner solve each)
  int tangent_assemblies = 0;   ///< assemblies with the tangent (residual + K)
  int residual_assemblies = 0;  ///< residual-only assemblies (the residual-first convergence test)
  double assembly_time = 0.0;
  double krylov_time = 0.0;   ///< GMRES without its preconditioner solves (matrix products, orthogonalization)
  SolverTimes linear;         ///< analysis / factorization / solve times
  std::vector<std::string> log;  ///< cut-backs and warnings, human readable
};

/// Per-element output fields (averages over the Gauss points, current configuration).
struct ElementFields {
  std::vector<double> cauchy;     ///< 9 per element, row-major
  std::vector<double> von_mises;  ///< 1 per element
  std::vector<double> J;          ///< element volume ratio θ
  std::vector<double> fiber;      ///< 3 per element: current unit direction of the first fiber family (0 if none)
};

class Simulation {
 public:
  explicit Simulation(FeModel model, NewtonOptions options = {});
  ~Simulation();
  Simulation(const Simulation&) = delete;
  Simulation& operator=(const Simulation&) = delete;

  /// Advances from the current time to t_end with adaptive sub-steps. Throws ConvergenceError
  /// (state left at the last converged sub-step) when a sub-step fails after max_cutbacks halvings.
  void advance_to(double t_end);

  double time() const { return time_; }
  const std::vector<double>& displacement() const { return u_; }  ///< 3 per node
  std::vector<Vec3> current_positions() const;
  /// Pressure of the cavity control (or 0 without one).
  double cavity_pressure() const { return cavity_pressure_; }
  /// Reaction force: Σ of the converged state's internal forces over `dofs` (e.g. a loaded face's
  /// x-dofs). Evaluates no material (so it never advances a viscoelastic history).
  double reaction(const std::vector<int>& dofs) const;
  ElementFields element_fields() const;
  /// Statistics so far (linear-solver times of the current solver object).
  RunStats stats() const {
    RunStats s = stats_;
    s.linear = SolverTimes{};
    for (const auto* ls : {chol_.get(), lu_.get()}) {  // both factorizations' work
      if (!ls) continue;
      const SolverTimes& t = ls->times();
      s.linear.analysis += t.analysis;
      s.linear.factorization += t.factorization;
      s.linear.solve += t.solve;
      s.linear.factorizations += t.factorizations;
      s.linear.solves += t.solves;
      s.linear.flops += t.flops;
      s.linear.factor_nnz = std::max(s.linear.factor_nnz, t.factor_nnz);
    }
    return s;
  }
  /// Factorization in use (the configured one before the first solve).
  SolverKind solver_kind() const;
  int num_free_dofs() const { return dofs_.num_free; }
  const FeModel& model() const { return model_; }

  /// Element residual and tangent at the current state (for diagnostics and tests).
  MaterialStatus element_force(int e, const Mat83& u, Vec24& r, Mat24* K) const;
  /// The same for a tet10 element e (≥ mesh.num_hexes()).
  MaterialStatus element_force(int e, const Tet10Coords& u, Vec30& r, Mat30* K) const;

 private:
  struct Assembly;
  bool try_step(double t_new, double dt, std::string& why);
  MaterialStatus assemble(double t, double dt, bool tangent, const std::vector<double>& u,
                          double cavity_p, Assembly& out);
  /// x = K⁻¹ b (free dofs) to relative residual `tol`; false when no factorization works.
  bool linear_solve(const std::vector<double>& b, std::vector<double>& x, double tol, std::string& why);
  bool refactor(std::string& why);
  void mixed_update(const std::vector<double>& du, double alpha);

  FeModel model_;
  NewtonOptions options_;
  DofMap dofs_;
  CscMatrix K_;
  std::unique_ptr<LinearSolver> chol_, lu_;  ///< Cholesky of the symmetric part; LU (created on demand)
  LinearSolver* linear_ = nullptr;            ///< the one holding the current factor
  bool lu_this_step_ = false;
  bool refactor_first_ = false;               ///< the lagged factor failed at the last step's first iteration                 ///< the symmetric part was indefinite in this step: LU
  bool chol_analyzed_ = false, lu_analyzed_ = false, factor_valid_ = false, factor_stale_ = false, factor_exact_ = false;
  long k_version_ = 0, factor_version_ = -1;  ///< tangent assemblies; the one last factorized
  double last_factor_time_ = 0.0, last_factor_flops_ = 0.0;
  double iteration_time_ = 0.0;                  ///< running mean cost of one GMRES iteration [s]
  std::vector<std::vector<double>> krylov_basis_;  ///< GMRES basis, kept between solves
  std::vector<std::vector<double>> krylov_preconditioned_;  ///< M⁻¹ of the basis vectors (no extra solve per cycle)
  std::vector<std::vector<double>> krylov_condensed_;  ///< condensed residuals of the basis (uncondensed Krylov space)
  // Uncondensed (u, p_e) Krylov space of the three-field iteration (linear_solve): per mixed element k,
  // its element number, the free equation of each element dof (−1 fixed) at sad_off_[k] .. sad_off_[k+1],
  // and d_e = ∂θ_e/∂u, c_e = V_e U″(θ) of the current tangent (b) and of the factorized one (a).
  std::vector<int> sad_elem_, sad_off_, sad_eq_;
  std::vector<std::vector<int>> sad_colors_;  ///< the element colours, as mixed-element indices k
  std::vector<double> sad_db_, sad_cb_, sad_da_, sad_ca_;
  bool sad_a_valid_ = false;
  long sad_b_version_ = -1;  ///< k_version_ of sad_db_, sad_cb_
  void saddle_current();  ///< fills sad_db_, sad_cb_ from the last tangent assembly
  /// The uncondensed Krylov space is in use: three-field elements and factors large enough to be lagged.
  bool saddle_lagged() const {
    return options_.saddle_krylov && !sad_elem_.empty() && last_factor_flops_ >= options_.lag_flops;
  }
  std::vector<Hex8Geometry> geometry_;
  std::vector<Tet10Geometry> tet_geometry_;  ///< per tet (element e − num_hexes)
  std::vector<std::vector<int>> colors_;  ///< element colours: no shared node within one colour
  std::vector<std::array<long, 64>> block_;  ///< per element, node pair (a, b): K position of (a_0, b_0), −1 if absent
  std::vector<std::array<long, 100>> tet_block_;  ///< the same per tet (10 × 10 node pairs)
  std::vector<std::array<signed char, 3>> free_rank_;  ///< per node: rank of each free component (−1 fixed)
  // Three-field iteration (per element; bulk 0 = plain F-bar): iterate, converged and linearization data.
  std::vector<double> mix_bulk_, mix_theta_, mix_p_, mix_theta_conv_, mix_p_conv_, mix_theta_u_;
  std::vector<double> mix_theta_base_, mix_p_base_, mix_dtheta_, mix_dp_;
  std::vector<Vec24> mix_d_;
  std::vector<Vec30> mix_d_tet_;  ///< ∂θ_e/∂u per tet
  std::vector<double> u_, u_prev_step_;  ///< converged displacement and the one before it (secant predictor)
  double prev_step_time_ = 0.0;            ///< time of u_prev_step_
  std::vector<double> u_prev2_step_;       ///< the converged displacement before u_prev_step_ (quadratic predictor)
  double prev2_step_time_ = 0.0;           ///< its time (valid when stored_steps_ ≥ 2)
  int stored_steps_ = 0;                   ///< converged steps behind u_ (capped at 2)
  bool extrapolate_step_ = true;           ///< false while a step is retried without the secant predictor
  bool extrapolated_ = false;              ///< the last try_step started from the secant predictor
  double stiffness_time_ = -1.0;           ///< ≥ 0: time of the pressure in the load stiffness (assemble)
  std::vector<double> state_old_, state_new_;
  std::vector<double> cauchy_;     ///< element-mean Cauchy stress of the last converged state
  std::vector<double> fint_;       ///< internal forces (all dofs) of the last converged state
  std::vector<int> state_offset_;  ///< per element into the state arrays (−1: elastic)
  double time_ = 0.0, last_dt_ = 0.0;
  bool recent_cutback_ = false;
  double cavity_pressure_ = 0.0, cavity_v0_ = 0.0;
  RunStats stats_;
};

}  // namespace softhom::fe
