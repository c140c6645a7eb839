#pragma once
// The one sub-step loop of every engine (material-point driver, FFT and FE RVE engines, macro FE).
// An interval [t0, t1] of the load path is reached by sub-steps: the first tries `first_dt` (the whole
// interval unless the caller carries a smaller step over), a failed sub-step is halved (the engine has
// restored its committed state), and after `successes_to_grow` converged sub-steps in a row the
// sub-step grows by `grow_factor` again, never past the interval. The interval ends early, with the
// reason, when a sub-step still fails after `max_cutbacks` halvings, when the engine reports a fatal
// failure (a material limit such as Gent locking: halving cannot help), when the interval has spent
// `max_step_seconds` of wall time and would cut back again, or when a stop was requested (signal).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>
#include <type_traits>

#include "softhom/materials/interrupt.hpp"

namespace softhom {

struct StepControlOptions {
  int max_cutbacks = 12;          ///< halvings of one interval's sub-step before the run stops
  int successes_to_grow = 2;      ///< converged sub-steps in a row before the sub-step grows again
  double grow_factor = 2.0;       ///< growth of the sub-step after `successes_to_grow` successes
  double max_step_seconds = 0.0;  ///< wall-time budget of one interval's cut-backs (0: unlimited)
};

enum class IntervalStatus {
  reached,            ///< t1 reached
  cutbacks_exhausted, ///< a sub-step failed after max_cutbacks halvings
  fatal,              ///< the engine said halving cannot help (e.g. a material limit)
  time_budget,        ///< max_step_seconds spent with the interval unfinished
  interrupted,        ///< stop_requested() (SIGINT/SIGTERM)
};

struct IntervalOutcome {
  IntervalStatus status = IntervalStatus::reached;
  std::string why;        ///< reason of the last failed sub-step (empty when reached without failure)
  double t_reached = 0.0; ///< committed time at the end (t1 when reached)
  double last_dt = 0.0;   ///< last converged sub-step (0 when none converged)
  double next_dt = 0.0;   ///< sub-step the next interval may start with
  int substeps = 0;       ///< converged sub-steps
  int cutbacks = 0;       ///< failed sub-steps
  bool reached() const { return status == IntervalStatus::reached; }
};

namespace detail {
template <class R>
bool attempt_is_fatal(const R& r) {
  if constexpr (requires { r.fatal; }) return bool(r.fatal);
  else return false;
}
}  // namespace detail

/// `attempt(t_new, dt)` tries one sub-step from the committed state and returns an object with
/// `bool ok`, `std::string why` and optionally `bool fatal`; `accept(t_new, dt, result)` commits the
/// trial state; `reject(t_from, t_new, dt_failed, dt_next, result)` restores the committed state (and
/// may log; dt_next is 0 when the interval gives up). Returns how the interval ended.
template <class Attempt, class Accept, class Reject>
IntervalOutcome advance_interval(double t0, double t1, double first_dt, const StepControlOptions& options,
                                 Attempt&& attempt, Accept&& accept, Reject&& reject) {
  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  const double interval = t1 - t0;
  const double t_eps = 1e-12 * std::max(1.0, std::abs(t1));
  const double dt_min = interval / std::ldexp(1.0, std::max(0, options.max_cutbacks));
  IntervalOutcome out;
  out.t_reached = t0;
  double t = t0;
  double dt = (first_dt > 0.0 && first_dt < interval) ? first_dt : interval;
  int successes = 0;
  while (t < t1 - t_eps) {
    if (stop_requested()) {
      out.status = IntervalStatus::interrupted;
      out.why = "stopped by a signal";
      break;
    }
    const double dt_try = std::min(dt, t1 - t);
    const double t_new = (t + dt_try >= t1 - t_eps) ? t1 : t + dt_try;
    auto result = attempt(t_new, t_new - t);
    if (result.ok) {
      accept(t_new, t_new - t, result);
      out.last_dt = t_new - t;
      t = t_new;
      ++out.substeps;
      if (++successes >= options.successes_to_grow && dt < interval) {
        dt = std::min(options.grow_factor * dt, interval);
        successes = 0;
      }
      continue;
    }
    ++out.cutbacks;
    successes = 0;
    out.why = result.why;
    const double dt_next = dt_try / 2.0;
    const double spent = std::chrono::duration<double>(Clock::now() - start).count();
    if (detail::attempt_is_fatal(result)) out.status = IntervalStatus::fatal;
    else if (stop_requested()) out.status = IntervalStatus::interrupted;
    else if (dt_next < dt_min * (1.0 - 1e-12)) out.status = IntervalStatus::cutbacks_exhausted;
    else if (options.max_step_seconds > 0.0 && spent > options.max_step_seconds) out.status = IntervalStatus::time_budget;
    const bool give_up = out.status != IntervalStatus::reached;
    reject(t, t_new, dt_try, give_up ? 0.0 : dt_next, result);
    if (give_up) break;
    dt = dt_next;
  }
  out.t_reached = t;
  out.next_dt = dt;
  return out;
}

/// A sentence for a failed interval: "step to t = 2 failed after 12 cut-backs: <why>" and the like.
/// `format` prints a time as the user wrote it (shortest round trip).
template <class Format>
std::string describe_interval_failure(const IntervalOutcome& o, double t1, int max_cutbacks, double max_step_seconds,
                                      Format&& format) {
  const std::string to = "step to t = " + format(t1);
  switch (o.status) {
    case IntervalStatus::reached: return {};
    case IntervalStatus::cutbacks_exhausted:
      return to + " failed after " + std::to_string(max_cutbacks) + " cut-backs: " + o.why;
    case IntervalStatus::fatal: return to + " stopped: " + o.why;
    case IntervalStatus::time_budget:
      return to + " stopped: its cut-backs used the wall-time budget (solver.max_step_seconds = " +
             format(max_step_seconds) + " s) at t = " + format(o.t_reached) + ": " + o.why;
    case IntervalStatus::interrupted: return to + " interrupted at t = " + format(o.t_reached) + " (signal)";
  }
  return {};
}

}  // namespace softhom
