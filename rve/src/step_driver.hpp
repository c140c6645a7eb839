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

#include <Eigen/Eigenvalues>

#include "softhom/materials/errors.hpp"
#include "softhom/materials/loading.hpp"
#include "softhom/materials/step_control.hpp"
#include "softhom/rve/fft_solver.hpp"

namespace softhom::rve::detail {

/// The per-phase sums of an evaluation pass that the output row and the limit check read, the same in both
/// engines (per thread, then reduced): per phase (0 matrix, 1 fiber; grid frame) Σ w P, Σ w F, Σ w P Fᵀ
/// (= J σ), Σ w J and Σ w, and the smallest Material::limit_margin of each phase with where it is (a
/// voxel or an element; checked on converged states: a phase at its limit is fatal).
struct PhaseSums {
  Mat3 phase_P[2] = {Mat3::Zero(), Mat3::Zero()};
  Mat3 phase_F[2] = {Mat3::Zero(), Mat3::Zero()};
  Mat3 phase_PFt[2] = {Mat3::Zero(), Mat3::Zero()};
  double phase_J[2] = {0.0, 0.0};
  double phase_w[2] = {0.0, 0.0};
  double margin[2] = {1.0, 1.0};
  std::size_t margin_at[2] = {0, 0};
  /// Point (or element) sums of phase x: weight w, Σ w P, Σ w F, Σ w P Fᵀ, Σ w J.
  void add_phase(int x, double w, const Mat3& wP, const Mat3& wF, const Mat3& wPFt, double wJ) {
    phase_P[x] += wP;
    phase_F[x] += wF;
    phase_PFt[x] += wPFt;
    phase_J[x] += wJ;
    phase_w[x] += w;
  }
  /// A point of phase x with weight w at F, P.
  void add_point(int x, double w, const Mat3& P, const Mat3& F) {
    add_phase(x, w, w * P, w * F, w * P * F.transpose(), w * F.determinant());
  }
  void see_margin(int x, double m, std::size_t at) {
    if (m < margin[x]) {
      margin[x] = m;
      margin_at[x] = at;
    }
  }
  void add_phases(const PhaseSums& o) {
    for (int x = 0; x < 2; ++x) {
      see_margin(x, o.margin[x], o.margin_at[x]);
      add_phase(x, o.phase_w[x], o.phase_P[x], o.phase_F[x], o.phase_PFt[x], o.phase_J[x]);
    }
  }
};

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

/// A converged state with a phase's Material::limit_margin below this is refused as fatal (as the
/// material-point driver's PointSolverOptions::limit_margin): the law is at its limit (Gent locking)
/// and past it only the bulk term resists, so no further state of the path is physical.
constexpr double kLimitMargin = 1e-3;

/// A computed value in a message (4 significant digits; format_number is for numbers the user wrote).
inline std::string approx(double v) {
  std::ostringstream s;
  s.precision(4);
  s << v;
  return s.str();
}

/// Largest principal stretch of F (the stretch a locking message names).
inline double largest_stretch(const Mat3& F) {
  const Eigen::SelfAdjointEigenSolver<Mat3> es(F.transpose() * F, Eigen::EigenvaluesOnly);
  return std::sqrt(std::max(es.eigenvalues().maxCoeff(), 0.0));
}

/// The fatal reason when a phase of a converged state is at its material limit (empty otherwise):
/// `margin[x]` the smallest Material::limit_margin of phase x (0 matrix, 1 fiber), `where[x]` where.
inline std::string phase_limit_reached(const double margin[2], const std::string where[2], const Mat3& F_load) {
  const int x = margin[1] < margin[0] ? 1 : 0;
  if (!(margin[x] < kLimitMargin)) return {};
  std::ostringstream s;
  s << "the " << (x ? "fiber" : "matrix") << " phase reaches its material limit (e.g. Gent locking, Ī1 − 3 → Jm: "
    << "limit margin " << approx(margin[x]) << " < " << format_number(kLimitMargin) << " at " << where[x]
    << ") at the macro stretch " << approx(largest_stretch(F_load)) << " (F11 = " << approx(F_load(0, 0))
    << ", load frame); the cell has no physical state beyond the last converged one";
  return s.str();
}

/// The fatal reason when a sub-step's target inverts the cell (empty otherwise): det F̄ ≤ 0 for the
/// prescribed components at t_new with the free components of the committed state (which carry any
/// rotation the path took). No sub-step of the path can pass det F̄ = 0, so halving cannot help.
inline std::string target_inverts(const MixedControl& control, double t_new, const Mat3& F_committed) {
  Mat3 F = F_committed;
  for (int c = 0; c < 9; ++c)
    if (control.kind[c] == ControlKind::deformation) F(c / 3, c % 3) = control.value[c](t_new);
  const double J = F.determinant();
  if (J > 0.0) return {};
  return "the prescribed deformation inverts the cell: det F̄ = " + approx(J) + " ≤ 0 at t = " + approx(t_new) +
         " (F11 = " + approx(F(0, 0)) + ", load frame, free components of the last converged state)";
}

/// RveStop of an interval that did not reach its end.
inline RveStop stop_of(IntervalStatus s) {
  switch (s) {
    case IntervalStatus::reached: return RveStop::none;
    case IntervalStatus::cutbacks_exhausted: return RveStop::failed;
    case IntervalStatus::fatal: return RveStop::fatal;
    case IntervalStatus::time_budget: return RveStop::time_budget;
    case IntervalStatus::interrupted: return RveStop::interrupted;
  }
  return RveStop::failed;
}

/// `engine` provides: SubstepOutcome step(double t_new, double dt); void commit(double dt);
/// void restore(); RveStep record(double t); void emit(const RveStep&, double last_dt), and is
/// evaluated at t_start already. From t_start = 0: records and emits t = 0, then every output step.
/// From a converged output time t_start > 0 (a continued run): the output steps after it only. Sets
/// the totals, error, stop reason, completion flag and wall time (from `run_start`) of `result`.
template <class Engine>
void run_output_steps(const MixedControl& control, const StepControlOptions& steps, Engine& engine,
                      RveRunResult& result, std::chrono::steady_clock::time_point run_start, double t_start = 0.0) {
  using Clock = std::chrono::steady_clock;
  if (t_start == 0.0) {
    const RveStep s0 = engine.record(0.0);
    result.steps.push_back(s0);
    engine.emit(s0, 0.0);
  }
  double t_prev_out = t_start;
  for (double t_out : control.times) {
    if (t_out <= t_start) continue;
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
