#pragma once
// The output-step loop shared by the FFT and FE RVE engines: each output interval of the control is
// reached by sub-steps that start at the full interval, halve after a failed sub-step (the engine
// restores its committed state) and double again after two successes; a step that still fails after
// `max_cutbacks` halvings ends the run with its reason. Every cut-back is logged.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include "softhom/materials/loading.hpp"
#include "softhom/rve/fft_solver.hpp"

namespace softhom::rve::detail {

/// Output row of a converged state: macro F and P (load frame) and the phase means of an engine's
/// pass sums (phase_w, phase_P, phase_F, phase_PFt, phase_J in the grid frame, rotated by `to_load`);
/// the fiber angle is that of the mean fiber-phase F applied to a0 (spec §7).
template <class Sums, class ToLoad>
RveStep record_step(double t, double angle0, const Mat3& F, const Mat3& P, const Sums& sums, const ToLoad& to_load,
                    const Vec3& a0_load) {
  RveStep s;
  s.t = t;
  s.F = F;
  s.P = P;
  s.sigma = cauchy_from_piola(s.F, s.P);
  for (int x = 0; x < 2; ++x) {
    const double w = sums.phase_w[x];
    if (w > 0.0) {
      (x ? s.P_fiber : s.P_matrix) = to_load(sums.phase_P[x] / w);
      (x ? s.sigma_fiber : s.sigma_matrix) = to_load(sums.phase_PFt[x] / sums.phase_J[x]);
    }
  }
  const Mat3 Ff = sums.phase_w[1] > 0.0 ? to_load(sums.phase_F[1] / sums.phase_w[1]) : s.F;
  s.fiber_angle_deg = fiber_angle_deg(Ff, a0_load);
  s.fiber_angle_change_deg = s.fiber_angle_deg - angle0;
  return s;
}

/// Result of one sub-step attempt of an engine.
struct SubstepOutcome {
  bool ok = false;
  std::string why;
  int newton = 0, krylov = 0, line_search_cuts = 0, shifted_solves = 0, minres_solves = 0, minres_fallbacks = 0, continuation = 0;
  std::vector<double> residuals;
};

/// `engine` provides: SubstepOutcome step(double t_new, double dt); void commit(double dt);
/// void restore(); RveStep record(double t); void emit(const RveStep&, double last_dt), and is
/// evaluated at t = 0 already. Records and emits t = 0, then every output step; sets the totals,
/// error, completion flag and wall time (from `run_start`) of `result`.
template <class Engine>
void run_output_steps(const MixedControl& control, int max_cutbacks, Engine& engine, RveRunResult& result,
                      std::chrono::steady_clock::time_point run_start) {
  using Clock = std::chrono::steady_clock;
  {
    const RveStep s0 = engine.record(0.0);
    result.steps.push_back(s0);
    engine.emit(s0, 0.0);
  }
  double t = 0.0, t_prev_out = 0.0, last_dt = 0.0;
  for (double t_out : control.times) {
    const auto step_start = Clock::now();
    const double interval = t_out - t_prev_out;
    const double t_eps = 1e-12 * std::max(1.0, t_out);
    double dt = interval;
    int successes = 0;
    RveStep agg;
    SubstepOutcome last;
    bool failed = false;
    while (t < t_out - t_eps) {
      const double dt_try = std::min(dt, t_out - t);
      const double t_new = (t + dt_try >= t_out - t_eps) ? t_out : t + dt_try;
      SubstepOutcome o = engine.step(t_new, t_new - t);
      agg.newton_iterations += o.newton;
      agg.krylov_iterations += o.krylov;
      agg.shifted_solves += o.shifted_solves;
      result.shifted_solves += o.shifted_solves;
      agg.minres_solves += o.minres_solves;
      result.minres_solves += o.minres_solves;
      agg.continuation_iterations += o.continuation;
      result.continuation_iterations += o.continuation;
      if (o.ok) {
        if (o.minres_solves > 0) {
          std::ostringstream msg;
          msg << "t = " << t << " → " << t_new << ": tangent indefinite near equilibrium (" << o.minres_solves
              << " MINRES solves" << (o.minres_fallbacks > 0 ? " after the shifted iteration stalled" : "")
              << "): the cell is past a bifurcation (e.g. fiber micro-buckling) and this branch is unstable";
          result.log.push_back(msg.str());
        }
        if (o.continuation > 0) {
          std::ostringstream msg;
          msg << "t = " << t << " → " << t_new << ": Newton stalled (the equilibrium branch ends: fold or "
              << "bifurcation of the cell); converged after " << o.continuation
              << " pseudo-transient continuation iterations";
          result.log.push_back(msg.str());
        }
        last_dt = t_new - t;
        engine.commit(last_dt);
        t = t_new;
        ++agg.substeps;
        last = std::move(o);
        if (++successes >= 2 && dt < interval) {
          dt = std::min(2.0 * dt, interval);
          successes = 0;
        }
      } else {
        engine.restore();
        ++agg.cutbacks;
        ++result.cutbacks;
        successes = 0;
        std::ostringstream msg;
        msg << "t = " << t << " → " << t_new << ": " << o.why << "; cutting back (dt " << dt_try << " → "
            << dt_try / 2 << ")";
        result.log.push_back(msg.str());
        dt = dt_try / 2.0;
        if (dt < interval / std::ldexp(1.0, max_cutbacks)) {
          result.error = "step to t = " + std::to_string(t_out) + " failed after " + std::to_string(max_cutbacks) +
                         " cut-backs: " + o.why;
          failed = true;
          break;
        }
      }
    }
    result.total_newton_iterations += agg.newton_iterations;
    result.total_krylov_iterations += agg.krylov_iterations;
    if (failed) break;
    RveStep s = engine.record(t_out);
    s.newton_iterations = agg.newton_iterations;
    s.krylov_iterations = agg.krylov_iterations;
    s.shifted_solves = agg.shifted_solves;
    s.minres_solves = agg.minres_solves;
    s.continuation_iterations = agg.continuation_iterations;
    s.substeps = agg.substeps;
    s.cutbacks = agg.cutbacks;
    s.residuals = last.residuals;
    s.wall_seconds = std::chrono::duration<double>(Clock::now() - step_start).count();
    if (!(s.F.allFinite() && s.P.allFinite() && s.sigma.allFinite())) {
      result.error = "non-finite homogenized state at t = " + std::to_string(t_out);
      break;
    }
    result.steps.push_back(s);
    engine.emit(s, last_dt);
    t_prev_out = t_out;
  }
  result.completed = result.error.empty();
  result.wall_seconds = std::chrono::duration<double>(Clock::now() - run_start).count();
}

}  // namespace softhom::rve::detail
