// Fitting a calibration: the bounded least-squares problem in scaled unknowns, solved by Ceres from
// several starts, and the parameter statistics at the optimum.
#include "softhom/studies/calibration.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <random>
#include <sstream>

#include <Eigen/Dense>
#include <ceres/ceres.h>

#include "softhom/materials/errors.hpp"
#include "softhom/materials/interrupt.hpp"

namespace softhom::studies {
namespace {

// The least-squares problem in scaled unknowns u (one per free parameter).

class FitProblem {
 public:
  FitProblem(const CalibrationInput& in) : in_(in), free_(in.model.free_indices()) {
    for (const auto& c : in.curves)
      if (!c.holdout) {
        fit_.push_back(&c);
        m_ += int(c.x_data.size());
      }
  }
  int residual_count() const { return m_; }
  int unknown_count() const { return int(free_.size()); }
  const std::vector<int>& free() const { return free_; }

  double to_u(int k, double p) const {
    const CalParameter& q = in_.model.parameters[free_[k]];
    return q.log_scale ? std::log(p) : p / q.scale;
  }
  double from_u(int k, double u) const {
    const CalParameter& q = in_.model.parameters[free_[k]];
    return q.log_scale ? std::exp(u) : u * q.scale;
  }
  double dp_du(int k, double p) const {
    const CalParameter& q = in_.model.parameters[free_[k]];
    return q.log_scale ? p : q.scale;
  }
  double u_lower(int k) const { return to_u(k, in_.model.parameters[free_[k]].min); }
  double u_upper(int k) const { return to_u(k, in_.model.parameters[free_[k]].max); }

  std::vector<double> values_from_u(const double* u) const {
    std::vector<double> v = in_.model.values();
    for (int k = 0; k < unknown_count(); ++k) {
      const CalParameter& q = in_.model.parameters[free_[k]];
      // Bounds hold in u up to round-off of exp/log; keep the physical value inside too.
      v[free_[k]] = std::clamp(from_u(k, u[k]), q.min, q.max);
    }
    return v;
  }

  /// Weighted, normalised residuals of every fit curve. False (with a reason) when the model cannot be
  /// evaluated at u; never throws.
  bool residuals(const double* u, double* r, std::string* error = nullptr) const {
    ++evaluations_;
    const std::vector<double> v = values_from_u(u);
    int row = 0;
    for (const CalCurve* c : fit_) {
      ++curve_evaluations_;
      const CurveEvaluation e = evaluate_curve(in_.model, *c, v, in_.solver.point);
      if (!e.ok) {
        if (error) *error = c->name + ": " + e.error;
        return false;
      }
      const double f = std::sqrt(c->weight / double(c->x_data.size())) / c->y_range;
      for (std::size_t i = 0; i < c->x_data.size(); ++i) r[row++] = f * (e.model[i] - c->y_data[i]);
    }
    return true;
  }

  /// Jacobian dr/du by central differences (one-sided next to a point where the model fails).
  bool jacobian(const double* u, const double* r0, double* J /* row-major m x n */) const {
    const int n = unknown_count();
    std::vector<double> up(u, u + n), rp(m_), rm(m_);
    const double h = in_.solver.fd_step;
    for (int j = 0; j < n; ++j) {
      up[j] = u[j] + h;
      const bool okp = residuals(up.data(), rp.data());
      up[j] = u[j] - h;
      const bool okm = residuals(up.data(), rm.data());
      up[j] = u[j];
      if (!okp && !okm) return false;
      for (int i = 0; i < m_; ++i)
        J[i * n + j] = okp && okm ? (rp[i] - rm[i]) / (2.0 * h) : okp ? (rp[i] - r0[i]) / h : (r0[i] - rm[i]) / h;
    }
    return true;
  }

  long evaluations() const { return evaluations_; }
  long curve_evaluations() const { return curve_evaluations_; }

 private:
  const CalibrationInput& in_;
  std::vector<int> free_;
  std::vector<const CalCurve*> fit_;
  int m_ = 0;
  mutable long evaluations_ = 0, curve_evaluations_ = 0;
};

class FitCost final : public ceres::CostFunction {
 public:
  explicit FitCost(const FitProblem& p) : p_(p) {
    set_num_residuals(p.residual_count());
    mutable_parameter_block_sizes()->push_back(p.unknown_count());
  }
  bool Evaluate(double const* const* x, double* residuals, double** jacobians) const override {
    if (stop_requested()) return false;  // the point runs stop at once anyway; StopOnRequest ends the solve
    if (!p_.residuals(x[0], residuals)) return false;
    if (jacobians && jacobians[0]) return p_.jacobian(x[0], residuals, jacobians[0]);
    return true;
  }

 private:
  const FitProblem& p_;
};

CurveFit curve_statistics(const CalCurve& c, CurveEvaluation e) {
  CurveFit f;
  f.name = c.name;
  f.holdout = c.holdout;
  f.weight = c.weight;
  f.points = c.x_data.size();
  f.x = c.x_data;
  f.data = c.y_data;
  f.ok = e.ok;
  f.error = e.error;
  if (!e.ok) return f;
  f.model = e.model;
  f.run = std::move(e.run);
  double mean = 0.0;
  for (double y : c.y_data) mean += y;
  mean /= double(c.y_data.size());
  double ss_res = 0.0, ss_tot = 0.0;
  for (std::size_t i = 0; i < c.y_data.size(); ++i) {
    const double d = f.model[i] - c.y_data[i];
    ss_res += d * d;
    ss_tot += (c.y_data[i] - mean) * (c.y_data[i] - mean);
    f.max_abs_error = std::max(f.max_abs_error, std::abs(d));
  }
  f.rmse = std::sqrt(ss_res / double(c.y_data.size()));
  f.nrmse = f.rmse / c.y_range;
  f.r2 = ss_tot > 0.0 ? 1.0 - ss_res / ss_tot : 0.0;
  return f;
}

/// The best of the starts: its unknowns and cost (infinite while no start was usable).
struct BestStart {
  std::vector<double> u;
  double cost = std::numeric_limits<double>::infinity();
};

/// Without free parameters: the model evaluated once at the given values.
void evaluate_fixed_model(const FitProblem& fp, CalibrationResult& res, BestStart& best) {
  std::vector<double> r(static_cast<std::size_t>(fp.residual_count()));
  std::string err;
  if (fp.residuals(nullptr, r.data(), &err)) {
    best.cost = 0.0;
    for (double x : r) best.cost += 0.5 * x * x;
    res.best_start = 0;
  } else {
    res.warnings.push_back("model evaluation failed at the given (all fixed) parameters: " + err);
  }
  StartReport sr;
  sr.initial_cost = sr.final_cost = best.cost;
  sr.usable = std::isfinite(best.cost);
  sr.termination = "no free parameters: evaluated only";
  res.starts.push_back(sr);
}

/// The unknowns of start s: the given values first, then uniform within the bounds (in u).
std::vector<double> start_point(const FitProblem& fp, const CalibrationModel& model, int s, std::mt19937_64& rng) {
  const int n = fp.unknown_count();
  std::vector<double> u(static_cast<std::size_t>(n));
  for (int k = 0; k < n; ++k) {
    if (s == 0) u[k] = fp.to_u(k, model.parameters[fp.free()[k]].value);
    else u[k] = std::uniform_real_distribution<double>(fp.u_lower(k), fp.u_upper(k))(rng);
    u[k] = std::clamp(u[k], fp.u_lower(k), fp.u_upper(k));
  }
  return u;
}

/// Ends a solve at the end of the iteration in which a stop was requested (SIGINT, SIGTERM), keeping
/// the best point so far: a failed evaluation alone only shrinks the trust region, and the solve would
/// go on as if the stopped model runs were locking.
class StopOnRequest final : public ceres::IterationCallback {
 public:
  ceres::CallbackReturnType operator()(const ceres::IterationSummary&) override {
    return stop_requested() ? ceres::SOLVER_TERMINATE_SUCCESSFULLY : ceres::SOLVER_CONTINUE;
  }
};

ceres::Solver::Options ceres_options(const CalSolverOptions& o) {
  ceres::Solver::Options opt;
  opt.minimizer_type = ceres::TRUST_REGION;
  opt.trust_region_strategy_type = o.dogleg ? ceres::DOGLEG : ceres::LEVENBERG_MARQUARDT;
  opt.linear_solver_type = ceres::DENSE_QR;
  opt.max_num_iterations = o.max_iterations;
  opt.function_tolerance = o.function_tolerance;
  opt.parameter_tolerance = o.parameter_tolerance;
  opt.gradient_tolerance = o.gradient_tolerance;
  opt.max_num_consecutive_invalid_steps = 20;  // failed evaluations (locking) just shrink the region
  opt.num_threads = 1;
  opt.logging_type = ceres::SILENT;
  opt.minimizer_progress_to_stdout = false;
  return opt;
}

/// One bounded least-squares solve from u (left at its end point), reported in sr.
ceres::Solver::Summary solve_from(const FitProblem& fp, FitCost& cost, const CalibrationInput& in,
                                  std::vector<double>& u, StartReport& sr) {
  const int n = fp.unknown_count();
  ceres::Problem::Options popt;
  popt.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(popt);
  problem.AddResidualBlock(&cost, nullptr, u.data());
  for (int k = 0; k < n; ++k) {
    problem.SetParameterLowerBound(u.data(), k, fp.u_lower(k));
    problem.SetParameterUpperBound(u.data(), k, fp.u_upper(k));
  }
  StopOnRequest stop;
  ceres::Solver::Options options = ceres_options(in.solver);
  options.callbacks.push_back(&stop);
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  sr.initial_cost = summary.initial_cost;
  sr.final_cost = summary.final_cost;
  sr.iterations = int(summary.iterations.size()) - 1;
  sr.usable = summary.IsSolutionUsable();
  sr.termination = ceres::TerminationTypeToString(summary.termination_type) + std::string(": ") + summary.message;
  for (int k = 0; k < n; ++k) {
    const CalParameter& q = in.model.parameters[fp.free()[k]];
    sr.final.push_back(std::clamp(fp.from_u(k, u[k]), q.min, q.max));
  }
  return summary;
}

/// Every start of the fit (the first from the given values), the best kept.
void run_starts(const FitProblem& fp, const CalibrationInput& in, const CalibrationProgress& progress,
                CalibrationResult& res, BestStart& best) {
  auto say = [&](const std::string& s) {
    if (progress) progress(s);
  };
  FitCost cost(fp);
  std::mt19937_64 rng(in.solver.seed);
  std::vector<double> r(static_cast<std::size_t>(fp.residual_count()));
  for (int s = 0; s < in.solver.starts && !stop_requested(); ++s) {
    std::vector<double> u = start_point(fp, in.model, s, rng);
    StartReport sr;
    for (int k = 0; k < fp.unknown_count(); ++k) sr.initial.push_back(fp.from_u(k, u[k]));
    std::string err;
    if (!fp.residuals(u.data(), r.data(), &err)) {
      sr.termination = "initial point not evaluable: " + err;
      sr.initial_cost = sr.final_cost = std::numeric_limits<double>::quiet_NaN();
      sr.final = sr.initial;
      say("start " + std::to_string(s) + ": " + sr.termination);
      res.starts.push_back(sr);
      continue;
    }
    const ceres::Solver::Summary summary = solve_from(fp, cost, in, u, sr);
    std::ostringstream msg;
    msg << "start " << s << ": cost " << sr.initial_cost << " -> " << sr.final_cost << " in " << sr.iterations
        << " iterations (" << ceres::TerminationTypeToString(summary.termination_type) << ")";
    say(msg.str());
    if (sr.usable && summary.final_cost < best.cost) {
      best.cost = summary.final_cost;
      best.u = u;
      res.best_start = s;
    }
    res.starts.push_back(sr);
  }
}

/// Every parameter at the fitted values; a warning for a free one that ends at a bound.
void report_parameters(const CalibrationModel& model, CalibrationResult& res) {
  for (std::size_t i = 0; i < model.parameters.size(); ++i) {
    const CalParameter& q = model.parameters[i];
    ParameterReport p;
    p.name = q.name;
    p.value = res.values[i];
    p.initial = q.value;
    p.min = q.min;
    p.max = q.max;
    p.free = q.free;
    if (q.free) p.at_bound = std::abs(p.value - q.min) <= 1e-6 * q.scale || std::abs(p.value - q.max) <= 1e-6 * q.scale;
    if (p.at_bound) res.warnings.push_back(q.name + " = " + format_number(p.value) + " is at a bound: widen [min, max] or fix it");
    res.parameters.push_back(p);
  }
}

/// Parameter statistics from the Jacobian at the optimum: Cov_u = s² (JᵀJ)⁻¹, s² = 2 cost / (m − n),
/// mapped to physical units with dp/du (p for log parameters, scale for linear ones): standard errors,
/// correlations, the condition of JᵀJ, and a warning for each parameter the data do not determine.
void parameter_statistics(const FitProblem& fp, const CalibrationModel& model, const BestStart& best,
                          CalibrationResult& res) {
  const int n = fp.unknown_count(), m = fp.residual_count();
  const std::vector<int>& free = fp.free();
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> J(m, n);
  std::vector<double> r0(static_cast<std::size_t>(m));
  if (!fp.residuals(best.u.data(), r0.data()) || !fp.jacobian(best.u.data(), r0.data(), J.data())) {
    res.warnings.push_back("Jacobian at the optimum could not be evaluated: no standard errors");
    return;
  }
  const Eigen::MatrixXd JtJ = J.transpose() * J;
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(JtJ);
  const Eigen::VectorXd lam = eig.eigenvalues();
  const double lmax = lam.maxCoeff();
  res.jtj_condition = lam.minCoeff() > 0.0 ? lmax / lam.minCoeff() : std::numeric_limits<double>::infinity();
  // Pseudo-inverse: directions with eigenvalue < 1e-14 λmax are not determined by the data.
  Eigen::VectorXd inv = Eigen::VectorXd::Zero(n);
  std::vector<bool> unidentified(static_cast<std::size_t>(n), false);
  for (int k = 0; k < n; ++k) {
    if (lam[k] > 1e-14 * lmax && lmax > 0.0) inv[k] = 1.0 / lam[k];
    else
      for (int j = 0; j < n; ++j)
        if (std::abs(eig.eigenvectors()(j, k)) > 0.1) unidentified[std::size_t(j)] = true;
  }
  const Eigen::MatrixXd cov_u = eig.eigenvectors() * inv.asDiagonal() * eig.eigenvectors().transpose();
  res.residual_variance = m > n ? 2.0 * best.cost / double(m - n) : std::numeric_limits<double>::quiet_NaN();
  Eigen::VectorXd d(n);
  for (int k = 0; k < n; ++k) d[k] = fp.dp_du(k, res.values[free[k]]);
  const Eigen::MatrixXd cov = res.residual_variance * d.asDiagonal() * cov_u * d.asDiagonal();
  for (int k = 0; k < n; ++k) {
    if (unidentified[std::size_t(k)]) {
      res.warnings.push_back(model.parameters[free[k]].name +
                             " is not identifiable from the fit curves (JᵀJ singular along it): no standard error");
      continue;
    }
    if (std::isfinite(cov(k, k)) && cov(k, k) >= 0.0) res.parameters[free[k]].std_error = std::sqrt(cov(k, k));
  }
  for (int a = 0; a < n; ++a)
    for (int b = 0; b < n; ++b) {
      const double den = std::sqrt(cov(a, a) * cov(b, b));
      if (!unidentified[std::size_t(a)] && !unidentified[std::size_t(b)] && den > 0.0 && std::isfinite(den))
        res.correlation(a, b) = a == b ? 1.0 : cov(a, b) / den;
    }
  if (res.jtj_condition > 1e10)
    res.warnings.push_back("JᵀJ is ill-conditioned (condition " + format_number(res.jtj_condition) +
                           "): strongly correlated parameters, see the correlation matrix");
}

/// Every curve (fit and holdout) at the optimum.
void evaluate_curves_at_optimum(const CalibrationInput& in, CalibrationResult& res) {
  for (const CalCurve& c : in.curves) {
    CurveFit f = curve_statistics(c, evaluate_curve(in.model, c, res.values, in.solver.point, true));
    ++res.curve_evaluations;
    if (!f.ok) res.warnings.push_back("curve " + c.name + " could not be evaluated at the optimum: " + f.error);
    res.curves.push_back(std::move(f));
  }
}

}  // namespace

CalibrationResult calibrate(const CalibrationInput& in, const CalibrationProgress& progress) {
  const auto wall_start = std::chrono::steady_clock::now();
  CalibrationResult res;
  FitProblem fp(in);
  const int n = fp.unknown_count(), m = fp.residual_count();
  BestStart best;
  best.u.assign(static_cast<std::size_t>(n), 0.0);
  if (n == 0) evaluate_fixed_model(fp, res, best);
  else run_starts(fp, in, progress, res, best);

  // A stop request (SIGINT, SIGTERM) leaves the best point so far: reported as such, never as a fit;
  // the statistics and the curves at the optimum would need model runs that the stop ends at once.
  const bool interrupted = stop_requested();
  const bool found = res.best_start >= 0;
  res.values = in.model.values();
  res.success = found && !interrupted;
  if (found && n > 0) res.values = fp.values_from_u(best.u.data());
  res.final_cost = found ? best.cost : std::numeric_limits<double>::quiet_NaN();
  res.residuals = m;
  res.dof = m - n;
  report_parameters(in.model, res);
  res.correlation = Eigen::MatrixXd::Constant(n, n, std::numeric_limits<double>::quiet_NaN());
  if (res.success && n > 0) parameter_statistics(fp, in.model, best, res);
  if (interrupted)
    res.warnings.push_back(std::string("interrupted: ") + (found ? "the parameters are the best found so far, not a converged fit"
                                                               : "no start finished; the parameters are the initial values"));
  else if (!found)
    res.warnings.push_back("no start converged to a usable solution");
  if (!interrupted) evaluate_curves_at_optimum(in, res);
  res.model_evaluations = fp.evaluations();
  res.curve_evaluations += fp.curve_evaluations();
  res.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  return res;
}

}  // namespace softhom::studies
