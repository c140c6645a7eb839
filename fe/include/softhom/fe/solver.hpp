#pragma once
// Quasi-static Newton driver: consistent linearization (including the Dirichlet increment predictor
// and the follower-pressure load stiffness), backtracking line search, adaptive sub-stepping with
// cut-back on divergence or failed material calls, history committed only after convergence.
#include <functional>
#include <string>
#include <vector>

#include "softhom/fe/model.hpp"
#include "softhom/fe/sparse.hpp"

namespace softhom::fe {

struct NewtonOptions {
  double tolerance = 1e-8;    ///< ‖R_free‖ ≤ tolerance · force scale (reactions + loads)
  int max_iterations = 25;
  int max_cutbacks = 12;      ///< consecutive halvings of one output interval
  bool line_search = true;
  int initial_substeps = 1;   ///< sub-steps per output interval at the start
  SolverKind solver = SolverKind::automatic;
  bool verbose = false;       ///< iteration log on stderr
};

/// Statistics of a run so far.
struct RunStats {
  int steps = 0;              ///< converged sub-steps
  int newton_iterations = 0;
  int cutbacks = 0;
  int line_search_backtracks = 0;
  double assembly_time = 0.0;
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
  /// Reaction force: Σ of internal forces over `dofs` (e.g. a loaded face's x-dofs).
  double reaction(const std::vector<int>& dofs) const;
  ElementFields element_fields() const;
  /// Statistics so far (linear-solver times of the current solver object).
  RunStats stats() const {
    RunStats s = stats_;
    s.linear = linear_->times();
    return s;
  }
  SolverKind solver_kind() const;
  int num_free_dofs() const { return dofs_.num_free; }
  const FeModel& model() const { return model_; }

  /// Element residual and tangent at the current state (for diagnostics and tests).
  MaterialStatus element_force(int e, const Mat83& u, Vec24& r, Mat24* K) const;

 private:
  struct Assembly;
  bool try_step(double t_new, double dt, std::string& why);
  MaterialStatus assemble(double t, double dt, bool tangent, const std::vector<double>& u,
                          double cavity_p, Assembly& out);

  FeModel model_;
  NewtonOptions options_;
  DofMap dofs_;
  CscMatrix K_;
  std::unique_ptr<LinearSolver> linear_;
  std::vector<Hex8Geometry> geometry_;
  std::vector<double> u_, u_prev_step_;
  std::vector<double> state_old_, state_new_;
  std::vector<double> cauchy_;     ///< element-mean Cauchy stress of the last converged state
  std::vector<int> state_offset_;  ///< per element into the state arrays (−1: elastic)
  double time_ = 0.0, last_dt_ = 0.0;
  bool recent_cutback_ = false;
  double cavity_pressure_ = 0.0, cavity_v0_ = 0.0;
  RunStats stats_;
};

}  // namespace softhom::fe
