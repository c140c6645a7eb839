#include "softhom/materials/driver.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include <Eigen/Dense>

#include "softhom/materials/errors.hpp"

namespace softhom {
namespace {

struct FreeSet {
  int count = 0;
  std::array<int, 9> index{};  // flattened component of each free (stress-controlled) unknown
};

FreeSet free_components(const MixedControl& c) {
  FreeSet s;
  for (int k = 0; k < 9; ++k)
    if (c.kind[k] == ControlKind::stress) s.index[s.count++] = k;
  return s;
}

struct SubstepOutcome {
  bool converged = false;
  MaterialStatus status = MaterialStatus::ok;
  int iterations = 0;
  double residual = 0.0;
  bool hit_locking = false;  // a trial state in this sub-step reached the material's locking limit
  bool beyond_limit = false; // the equilibrium itself lies within limit_margin of locking: halving cannot help
};

// Newton on the free components of F at time t, starting from F (updated in place). On success P
// and state_new hold the converged values.
SubstepOutcome solve_substep(const Material& material, const MixedControl& control, const FreeSet& free,
                             double t, double dt, const std::vector<double>& state_old,
                             std::vector<double>& state_new, const PointSolverOptions& opt,
                             double stress_scale, double bulk_scale, Mat3& F, Mat3& P) {
  SubstepOutcome out;
  F = control.prescribed_F(t, F);
  const double* s_old = state_old.empty() ? nullptr : state_old.data();
  double* s_new = state_new.empty() ? nullptr : state_new.data();
  Mat9 A;
  Eigen::VectorXd r(free.count), dx(free.count);
  Eigen::MatrixXd Jff(free.count, free.count);

  auto residual = [&](const Mat3& P_now) {
    double norm = 0.0;
    for (int a = 0; a < free.count; ++a) {
      const int k = free.index[a];
      r[a] = P_now(k / 3, k % 3) - control.value[k](t);
      norm = std::max(norm, std::abs(r[a]));
    }
    return norm;
  };

  out.status = material.evaluate(F, s_old, s_new, dt, P, &A);
  out.hit_locking = out.status == MaterialStatus::locking;
  if (out.status != MaterialStatus::ok) return out;
  double rnorm = residual(P);
  for (int it = 0; it <= opt.max_iterations; ++it) {
    out.iterations = it;
    out.residual = rnorm;
    // Relative to the current stress: the first trial state (prescribed components moved, free ones
    // not yet) can carry a volumetric stress ~K·ΔJ that says nothing about the converged scale.
    // Floor at the rounding noise of the volumetric stress (~K·eps): with G ≪ K the relative tolerance
    // alone can ask for more digits than the stress has.
    const double tolerance = std::max(opt.tolerance * std::max(stress_scale, P.cwiseAbs().maxCoeff()),
                                      100.0 * std::numeric_limits<double>::epsilon() * bulk_scale);
    if (rnorm <= tolerance || free.count == 0) {
      if (material.limit_margin(F) < opt.limit_margin) {
        out.status = MaterialStatus::locking;
        out.hit_locking = true;
        out.beyond_limit = true;
        return out;
      }
      out.converged = true;
      return out;
    }
    if (it == opt.max_iterations) break;
    for (int a = 0; a < free.count; ++a)
      for (int b = 0; b < free.count; ++b) Jff(a, b) = A(free.index[a], free.index[b]);
    dx = -Jff.fullPivLu().solve(r);
    if (!dx.allFinite()) return out;
    // Backtracking: a full Newton step may overshoot into locking or J ≤ 0, or increase the residual.
    double step = 1.0;
    Mat3 F_trial, P_trial;
    bool accepted = false;
    for (int ls = 0; ls < 12 && !accepted; ++ls, step *= 0.5) {
      F_trial = F;
      for (int a = 0; a < free.count; ++a) {
        const int k = free.index[a];
        F_trial(k / 3, k % 3) += step * dx[a];
      }
      const MaterialStatus st = material.evaluate(F_trial, s_old, s_new, dt, P_trial, &A);
      if (st != MaterialStatus::ok) {
        out.status = st;
        out.hit_locking |= st == MaterialStatus::locking;
        continue;
      }
      const double rn = residual(P_trial);
      if (rn < rnorm || step < 0.25) {
        accepted = true;
        F = F_trial;
        P = P_trial;
        rnorm = rn;
        out.status = MaterialStatus::ok;
      }
    }
    if (!accepted) return out;
  }
  return out;
}

/// One sub-step attempt in the shape advance_interval expects.
struct PointAttempt {
  bool ok = false;
  std::string why;
  bool fatal = false;
};

std::string describe_failure(const SubstepOutcome& o) {
  if (o.beyond_limit) return "the equilibrium lies within the limit margin of the material's locking limit";
  if (o.status != MaterialStatus::ok) return std::string("material call failed: ") + to_string(o.status);
  std::ostringstream s;
  s << "Newton did not converge (residual " << o.residual << " after " << o.iterations << " iterations)";
  if (o.hit_locking) s << "; trial states reached the material's locking limit";
  return s.str();
}

/// One material-point run in the load frame: the converged state (t, F, P, history) and the result
/// as it grows, one output interval at a time.
class PointRun {
 public:
  PointRun(const Material& global_material, const MixedControl& control, const PointSolverOptions& opt,
           const std::function<void(const PointState&)>& on_step)
      : control_(control),
        opt_(opt),
        on_step_(on_step),
        // Work in the load frame: a0_load = Rᵀ a0_global.
        material_ptr_(global_material.rotated(control.frame.transpose())),
        material_(*material_ptr_),
        fibers_(material_.fiber_directions()),
        free_(free_components(control)),
        stress_scale_(material_.initial_shear_modulus()),
        bulk_scale_(material_.initial_bulk_modulus()),
        nstate_(material_.state_size()),
        state_(nstate_),
        state_trial_(nstate_) {
    if (nstate_ > 0) material_.init_state(state_.data());
    step_control_.max_cutbacks = opt.max_cutbacks;
    step_control_.max_step_seconds = opt.max_step_seconds;
  }

  /// t = 0: the prescribed F(0) (usually I) must be in equilibrium with the targets too.
  bool start() {
    const SubstepOutcome o = solve(0.0, 0.0, F_, P_);
    if (!o.converged) {
      result_.error = "initial state (t = 0): " + describe_failure(o);
      return false;
    }
    if (nstate_ > 0) state_.swap(state_trial_);
    record(0.0, o.iterations, 1);
    return true;
  }

  /// The sub-steps to the output time t_out (cut back on failure); false (result's stop and error
  /// set) when the interval cannot be completed.
  bool advance_to(double t_out);

  PointRunResult& result() { return result_; }

 private:
  SubstepOutcome solve(double t, double dt, Mat3& F, Mat3& P) {
    return solve_substep(material_, control_, free_, t, dt, state_, state_trial_, opt_, stress_scale_, bulk_scale_, F,
                         P);
  }
  void record(double t, int iterations, int substeps) {
    PointState s;
    s.t = t;
    s.F = F_;
    s.P = P_;
    s.sigma = cauchy_from_piola(F_, P_);
    for (const auto& a0 : fibers_) s.fiber_angle_deg.push_back(fiber_angle_deg(F_, a0));
    s.newton_iterations = iterations;
    s.substeps = substeps;
    result_.steps.push_back(s);
    if (on_step_) on_step_(result_.steps.back());
  }
  /// A cut-back that the halved step then passes is an expected event: each kind is logged once.
  void log_cutback(double t_from, double dt_failed, const PointAttempt& a) {
    const std::string kind = a.why.substr(0, a.why.find_first_of("0123456789("));
    if (std::find(logged_kinds_.begin(), logged_kinds_.end(), kind) != logged_kinds_.end()) return;
    logged_kinds_.push_back(kind);
    result_.log.push_back("cut-back at t = " + format_number(t_from) + " + " + format_number(dt_failed) + " (" + a.why +
                          "); the step was halved (further cut-backs of this kind are counted, not listed)");
  }
  /// The run's stop and error when an interval cannot be completed.
  void stop_at(const IntervalOutcome& o, double t_out, bool locking_seen, bool last_locking) {
    // A locking limit that halving could not pass is the material's limit, not a solver failure.
    const bool at_limit = o.status == IntervalStatus::cutbacks_exhausted && last_locking;
    result_.stop = at_limit ? IntervalStatus::fatal : o.status;
    std::ostringstream s;
    s << describe_interval_failure(o, t_out, opt_.max_cutbacks, opt_.max_step_seconds,
                                   [](double v) { return format_number(v); });
    if (o.status != IntervalStatus::interrupted && locking_seen)
      s << ". The prescribed deformation reaches the Gent locking limit (Ī1 − 3 → Jm) beyond the last"
        << " converged state F11 = " << format_number(F_(0, 0)) << ", F22 = " << format_number(F_(1, 1))
        << ", F33 = " << format_number(F_(2, 2)) << " (load frame)";
    result_.error = s.str();
  }

  const MixedControl& control_;
  const PointSolverOptions& opt_;
  const std::function<void(const PointState&)>& on_step_;
  const std::unique_ptr<Material> material_ptr_;
  const Material& material_;
  const std::vector<Vec3> fibers_;
  const FreeSet free_;
  const double stress_scale_, bulk_scale_;
  const int nstate_;
  std::vector<double> state_, state_trial_;
  StepControlOptions step_control_;
  PointRunResult result_;
  Mat3 F_ = Mat3::Identity(), P_ = Mat3::Zero();
  double t_ = 0.0;
  double first_dt_ = 0.0;  // whole interval, unless the last one ended on a cut-back sub-step
  std::vector<std::string> logged_kinds_;
};

bool PointRun::advance_to(double t_out) {
  int iterations = 0;
  Mat3 F_trial = F_, P_trial = P_;
  bool locking_seen = false, last_locking = false;
  auto attempt = [&](double t_new, double dt) {
    F_trial = F_;
    const SubstepOutcome o = solve(t_new, dt, F_trial, P_trial);
    iterations += o.iterations;
    last_locking = o.status == MaterialStatus::locking || o.hit_locking;
    locking_seen |= last_locking;
    return PointAttempt{o.converged, o.converged ? std::string() : describe_failure(o), o.beyond_limit};
  };
  auto accept = [&](double t_new, double, const PointAttempt&) {
    t_ = t_new;
    F_ = F_trial;
    P_ = P_trial;
    if (nstate_ > 0) state_.swap(state_trial_);
  };
  auto reject = [&](double t_from, double, double dt_failed, double dt_next, const PointAttempt& a) {
    ++result_.cutbacks;
    if (dt_next > 0.0) log_cutback(t_from, dt_failed, a);  // else the interval gives up: the error says why
  };
  const IntervalOutcome o = advance_interval(t_, t_out, first_dt_, step_control_, attempt, accept, reject);
  result_.total_newton_iterations += iterations;
  if (!o.reached()) {
    stop_at(o, t_out, locking_seen, last_locking);
    return false;
  }
  first_dt_ = o.cutbacks > 0 || first_dt_ > 0.0 ? o.next_dt : 0.0;
  record(t_out, iterations, o.substeps);
  return true;
}

}  // namespace

PointRunResult run_material_point(const Material& global_material, const MixedControl& control,
                                  const PointSolverOptions& opt,
                                  const std::function<void(const PointState&)>& on_step) {
  control.validate();
  PointRun run(global_material, control, opt, on_step);
  if (!run.start()) return std::move(run.result());
  for (const double t_out : control.times)
    if (!run.advance_to(t_out)) return std::move(run.result());
  run.result().completed = true;
  return std::move(run.result());
}

}  // namespace softhom
