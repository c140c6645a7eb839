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

}  // namespace

PointRunResult run_material_point(const Material& global_material, const MixedControl& control,
                                  const PointSolverOptions& opt,
                                  const std::function<void(const PointState&)>& on_step) {
  control.validate();
  // Work in the load frame: a0_load = Rᵀ a0_global.
  const Mat3 Rt = control.frame.transpose();
  const auto material_ptr = global_material.rotated(Rt);
  const Material& material = *material_ptr;
  const auto fibers = material.fiber_directions();
  const FreeSet free = free_components(control);
  const double stress_scale = material.initial_shear_modulus();
  const double bulk_scale = material.initial_bulk_modulus();

  PointRunResult result;
  const int nstate = material.state_size();
  std::vector<double> state(nstate), state_trial(nstate);
  if (nstate > 0) material.init_state(state.data());

  auto make_state = [&](double t, const Mat3& F, const Mat3& P, int iterations, int substeps) {
    PointState s;
    s.t = t;
    s.F = F;
    s.P = P;
    s.sigma = cauchy_from_piola(F, P);
    for (const auto& a0 : fibers) s.fiber_angle_deg.push_back(fiber_angle_deg(F, a0));
    s.newton_iterations = iterations;
    s.substeps = substeps;
    return s;
  };

  // t = 0: the prescribed F(0) (usually I) must be in equilibrium with the targets too.
  Mat3 F = Mat3::Identity(), P = Mat3::Zero();
  {
    const SubstepOutcome o = solve_substep(material, control, free, 0.0, 0.0, state, state_trial, opt,
                                           stress_scale, bulk_scale, F, P);
    if (!o.converged) {
      result.error = "initial state (t = 0): " + describe_failure(o);
      return result;
    }
    if (nstate > 0) state.swap(state_trial);
    result.steps.push_back(make_state(0.0, F, P, o.iterations, 1));
    if (on_step) on_step(result.steps.back());
  }

  StepControlOptions step_control;
  step_control.max_cutbacks = opt.max_cutbacks;
  step_control.max_step_seconds = opt.max_step_seconds;
  double t = 0.0;
  double first_dt = 0.0;  // whole interval, unless the last one ended on a cut-back sub-step
  std::vector<std::string> logged_kinds;
  for (const double t_out : control.times) {
    int iterations = 0;
    Mat3 F_trial = F, P_trial = P;
    bool locking_seen = false, last_locking = false;
    auto attempt = [&](double t_new, double dt) {
      F_trial = F;
      const SubstepOutcome o = solve_substep(material, control, free, t_new, dt, state, state_trial, opt,
                                             stress_scale, bulk_scale, F_trial, P_trial);
      iterations += o.iterations;
      last_locking = o.status == MaterialStatus::locking || o.hit_locking;
      locking_seen |= last_locking;
      return PointAttempt{o.converged, o.converged ? std::string() : describe_failure(o), o.beyond_limit};
    };
    auto accept = [&](double t_new, double, const PointAttempt&) {
      t = t_new;
      F = F_trial;
      P = P_trial;
      if (nstate > 0) state.swap(state_trial);
    };
    auto reject = [&](double t_from, double, double dt_failed, double dt_next, const PointAttempt& a) {
      ++result.cutbacks;
      if (dt_next <= 0.0) return;  // the interval gives up: the error says why
      // A cut-back that the halved step then passes is an expected event: each kind is logged once.
      const std::string kind = a.why.substr(0, a.why.find_first_of("0123456789("));
      if (std::find(logged_kinds.begin(), logged_kinds.end(), kind) != logged_kinds.end()) return;
      logged_kinds.push_back(kind);
      result.log.push_back("cut-back at t = " + format_number(t_from) + " + " + format_number(dt_failed) + " (" +
                           a.why + "); the step was halved (further cut-backs of this kind are counted, not listed)");
    };
    const IntervalOutcome o = advance_interval(t, t_out, first_dt, step_control, attempt, accept, reject);
    result.total_newton_iterations += iterations;
    if (!o.reached()) {
      // A locking limit that halving could not pass is the material's limit, not a solver failure.
      const bool at_limit = o.status == IntervalStatus::cutbacks_exhausted && last_locking;
      result.stop = at_limit ? IntervalStatus::fatal : o.status;
      std::ostringstream s;
      s << describe_interval_failure(o, t_out, opt.max_cutbacks, opt.max_step_seconds,
                                     [](double v) { return format_number(v); });
      if (o.status != IntervalStatus::interrupted && locking_seen)
        s << ". The prescribed deformation reaches the Gent locking limit (Ī1 − 3 → Jm) beyond the last"
          << " converged state F11 = " << format_number(F(0, 0)) << ", F22 = " << format_number(F(1, 1))
          << ", F33 = " << format_number(F(2, 2)) << " (load frame)";
      result.error = s.str();
      return result;
    }
    first_dt = o.cutbacks > 0 || first_dt > 0.0 ? o.next_dt : 0.0;
    result.steps.push_back(make_state(t_out, F, P, iterations, o.substeps));
    if (on_step) on_step(result.steps.back());
  }
  result.completed = true;
  return result;
}

}  // namespace softhom
