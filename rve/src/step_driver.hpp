#pragma once
// The output-step loop shared by the FFT and FE RVE engines: each output interval of the control is
// reached by the sub-steps of softhom::advance_interval (step_control.hpp): they start at the full
// interval, halve after a failed sub-step (the engine restores its committed state) and double again
// after two successes. The run ends, keeping its converged rows, when a step still fails after
// `max_cutbacks` halvings, when the engine reports a fatal failure (a phase at its material limit,
// an inverted cell: halving cannot help), when one output step's cut-backs exceed the wall-time
// budget, or on a stop request (signal). Cut-backs of an output step that is then reached are one
// calm log line, not a warning each.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include "softhom/materials/errors.hpp"
#include "softhom/materials/loading.hpp"
#include "softhom/materials/step_control.hpp"
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

/// Result of one sub-step attempt of an engine (the counts of the attempt, whether it converged).
struct SubstepOutcome : RveCounts {
  bool ok = false;
  bool fatal = false;  ///< halving cannot help (material limit, inverted cell): the run stops
  std::string why;
  int minres_fallbacks = 0;
  std::vector<double> residuals;
};

inline std::string format_time(double t) { return format_number(t); }

/// The log line of a converged sub-step that needed MINRES or continuation (empty otherwise).
inline std::vector<std::string> substep_notes(double t0, double t1, const SubstepOutcome& o) {
  std::vector<std::string> notes;
  const std::string span = "t = " + format_time(t0) + " → " + format_time(t1) + ": ";
  if (o.minres_solves > 0)
    notes.push_back(span + "tangent indefinite near equilibrium (" + std::to_string(o.minres_solves) + " MINRES solves" +
                    (o.minres_fallbacks > 0 ? " after the shifted iteration stalled" : "") +
                    "): the cell is past a bifurcation (e.g. fiber micro-buckling) and this branch is unstable");
  if (o.continuation_iterations > 0)
    notes.push_back(span + "Newton stalled (the equilibrium branch ends: fold or bifurcation of the cell); converged after " +
                    std::to_string(o.continuation_iterations) + " pseudo-transient continuation iterations");
  return notes;
}

/// RveStop of an interval that did not reach its end.
inline RveStop stop_of(IntervalStatus s) {
  switch (s) {
    case IntervalStatus::reached: return RveStop::none;
    case IntervalStatus::cutbacks_exhausted: return RveStop::failed;
    case IntervalStatus::fatal: return RveStop::material_limit;
    case IntervalStatus::time_budget: return RveStop::time_budget;
    case IntervalStatus::interrupted: return RveStop::interrupted;
  }
  return RveStop::failed;
}

/// `engine` provides: SubstepOutcome step(double t_new, double dt); void commit(double dt);
/// void restore(); RveStep record(double t); void emit(const RveStep&, double last_dt), and is
/// evaluated at t = 0 already. Records and emits t = 0, then every output step; sets the totals,
/// error, stop reason, completion flag and wall time (from `run_start`) of `result`.
template <class Engine>
void run_output_steps(const MixedControl& control, const StepControlOptions& steps, Engine& engine,
                      RveRunResult& result, std::chrono::steady_clock::time_point run_start) {
  using Clock = std::chrono::steady_clock;
  {
    const RveStep s0 = engine.record(0.0);
    result.steps.push_back(s0);
    engine.emit(s0, 0.0);
  }
  double t_prev_out = 0.0;
  for (double t_out : control.times) {
    const auto step_start = Clock::now();
    RveStep agg;
    std::vector<double> last_residuals;
    std::string first_cutback;
    auto attempt = [&](double t_new, double dt) {
      SubstepOutcome o = engine.step(t_new, dt);
      agg += o;
      result += o;
      return o;
    };
    auto accept = [&](double t_new, double dt, SubstepOutcome& o) {
      for (auto& note : substep_notes(t_new - dt, t_new, o)) result.log.push_back(std::move(note));
      engine.commit(dt);
      last_residuals = std::move(o.residuals);
    };
    auto reject = [&](double t_from, double t_new, double, double, const SubstepOutcome& o) {
      engine.restore();
      if (first_cutback.empty()) first_cutback = "t = " + format_time(t_from) + " → " + format_time(t_new) + ": " + o.why;
    };
    const IntervalOutcome io = advance_interval(t_prev_out, t_out, 0.0, steps, attempt, accept, reject);
    agg.substeps += io.substeps;
    agg.cutbacks += io.cutbacks;
    result.substeps += io.substeps;
    result.cutbacks += io.cutbacks;
    if (!io.reached()) {
      result.stop = stop_of(io.status);
      result.error = describe_interval_failure(io, t_out, steps.max_cutbacks, steps.max_step_seconds, format_time);
      break;
    }
    if (io.cutbacks > 0) {
      std::ostringstream msg;
      msg << "step to t = " << format_time(t_out) << " reached in " << io.substeps << " sub-steps after " << io.cutbacks
          << " cut-back" << (io.cutbacks > 1 ? "s" : "") << " (first: " << first_cutback << ")";
      result.log.push_back(msg.str());
    }
    RveStep s = engine.record(t_out);
    static_cast<RveCounts&>(s) = agg;
    s.residuals = std::move(last_residuals);
    s.wall_seconds = std::chrono::duration<double>(Clock::now() - step_start).count();
    if (!(s.F.allFinite() && s.P.allFinite() && s.sigma.allFinite())) {
      result.stop = RveStop::failed;
      result.error = "non-finite homogenized state at t = " + format_time(t_out);
      break;
    }
    result.steps.push_back(s);
    engine.emit(s, io.last_dt);
    t_prev_out = t_out;
  }
  result.completed = result.error.empty();
  result.wall_seconds = std::chrono::duration<double>(Clock::now() - run_start).count();
}

}  // namespace softhom::rve::detail
