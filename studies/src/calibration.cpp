// The calibration model: its material for given parameter values, the quantities of a material-point
// state a curve can name, and the model's response sampled at a curve's data.
#include "softhom/studies/calibration.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>

#include "softhom/materials/errors.hpp"

namespace softhom::studies {
namespace {

/// Model y at data x by linear interpolation along the first monotone stretch of x(t) (a hold or a
/// reversal ends it). Returns false with a reason when a data x lies outside that stretch.
bool sample_in_x(const std::vector<double>& mx, const std::vector<double>& my, const std::vector<double>& x,
                 std::vector<double>& out, std::string& error) {
  if (mx.size() < 2) {
    error = "model response has fewer than two steps";
    return false;
  }
  const double scale = std::max({1e-300, std::abs(mx.front()), std::abs(mx.back())});
  std::size_t begin = 0;
  while (begin + 1 < mx.size() && std::abs(mx[begin + 1] - mx[begin]) <= 1e-14 * scale) ++begin;
  if (begin + 1 >= mx.size()) {
    error = "model x is constant over the run";
    return false;
  }
  const double dir = mx[begin + 1] > mx[begin] ? 1.0 : -1.0;
  std::size_t end = begin + 1;
  while (end + 1 < mx.size() && dir * (mx[end + 1] - mx[end]) > 0.0) ++end;
  const double lo = std::min(mx[begin], mx[end]), hi = std::max(mx[begin], mx[end]);
  const double tol = 1e-9 * std::max(scale, hi - lo);
  out.resize(x.size());
  for (std::size_t i = 0; i < x.size(); ++i) {
    if (x[i] < lo - tol || x[i] > hi + tol) {
      std::ostringstream s;
      s << "data x = " << x[i] << " outside the model's monotone x range [" << lo << ", " << hi << "]";
      error = s.str();
      return false;
    }
    // Segment k with x between mx[k] and mx[k+1] (binary search in the direction of the run).
    std::size_t a = begin, b = end;
    while (b - a > 1) {
      const std::size_t mid = (a + b) / 2;
      if (dir * (mx[mid] - x[i]) <= 0.0) a = mid;
      else b = mid;
    }
    const double w = std::clamp((x[i] - mx[a]) / (mx[b] - mx[a]), 0.0, 1.0);
    out[i] = (1.0 - w) * my[a] + w * my[b];
  }
  return true;
}

}  // namespace

MaterialSpec CalibrationModel::spec(const std::vector<double>& v) const {
  MaterialSpec s;
  s.field_prefix = "model";
  s.law = GL >= 0 ? LawKind::fiber_composite : LawKind::gent_hgo;
  if (GL >= 0) s.fiber_shear = {v[GL], v[GT], v[Ef]};
  s.gent.G = v[G];
  s.gent.Jm = v[Jm];
  s.gent.K = v[K];
  s.gent.invariant = invariant;
  s.gent.tension_only = tension_only;
  const double dispersion = kappa >= 0 ? v[kappa] : 0.0;
  for (const CalFiber& f : fibers) {
    const double a = v[f.angle_parameter] * std::numbers::pi / 180.0;
    s.gent.fibers.push_back({Vec3(std::sin(a), std::cos(a), 0.0), v[k1], v[k2], dispersion});
    if (f.plus_minus) s.gent.fibers.push_back({Vec3(-std::sin(a), std::cos(a), 0.0), v[k1], v[k2], dispersion});
  }
  if (viscoelastic) {
    PronySeries pr;
    if (g_inf >= 0) {
      pr.g_inf = v[g_inf];
      pr.terms.push_back({1.0 - v[g_inf], v[prony_tau.at(0)]});
    } else {
      double sum = 0.0;
      for (std::size_t k = 0; k < prony_g.size(); ++k) {
        pr.terms.push_back({v[prony_g[k]], v[prony_tau[k]]});
        sum += v[prony_g[k]];
      }
      pr.g_inf = 1.0 - sum;
      // Σ g is exactly 1 − g∞ here; validate() would only see round-off, so check admissibility first.
      if (!(pr.g_inf > 0.0))
        throw InputError("model.viscoelastic.terms", "sum(g) = " + format_number(sum), "Prony weights must sum to < 1 (g_inf = 1 - sum(g) > 0)");
    }
    s.prony = pr;
  }
  validate(s);
  return s;
}

std::vector<double> CalibrationModel::values() const {
  std::vector<double> v;
  for (const auto& p : parameters) v.push_back(p.value);
  return v;
}

std::vector<int> CalibrationModel::free_indices() const {
  std::vector<int> f;
  for (std::size_t i = 0; i < parameters.size(); ++i)
    if (parameters[i].free) f.push_back(int(i));
  return f;
}

double model_quantity(const PointState& s, const std::string& name, int* ok) {
  if (ok) *ok = 1;
  if (name == "t") return s.t;
  const Mat3* m = nullptr;
  std::string rest;
  if (name.size() == 3 && name[0] == 'F') m = &s.F, rest = name.substr(1);
  else if (name.size() == 3 && name[0] == 'P') m = &s.P, rest = name.substr(1);
  else if (name.size() == 7 && name.compare(0, 5, "sigma") == 0) m = &s.sigma, rest = name.substr(5);
  if (m && rest.size() == 2 && rest[0] >= '1' && rest[0] <= '3' && rest[1] >= '1' && rest[1] <= '3')
    return (*m)(rest[0] - '1', rest[1] - '1');
  if (name.compare(0, 5, "fiber") == 0 && name.size() > 15 && name.compare(name.size() - 10, 10, "_angle_deg") == 0) {
    const std::string k = name.substr(5, name.size() - 15);
    if (!k.empty() && std::all_of(k.begin(), k.end(), [](char c) { return c >= '0' && c <= '9'; })) {
      const std::size_t idx = std::stoul(k);
      if (idx >= 1 && idx <= s.fiber_angle_deg.size()) return s.fiber_angle_deg[idx - 1];
    }
  }
  if (ok) *ok = 0;
  return 0.0;
}

bool is_model_quantity(const std::string& name, std::size_t fiber_families) {
  PointState s;
  s.fiber_angle_deg.assign(fiber_families, 0.0);
  int ok = 0;
  model_quantity(s, name, &ok);
  return ok != 0;
}

CurveEvaluation evaluate_curve(const CalibrationModel& model, const CalCurve& curve, const std::vector<double>& values,
                               const PointSolverOptions& point, bool keep_run) {
  CurveEvaluation e;
  try {
    const MaterialPtr material = build_material(model.spec(values));
    PointRunResult run = run_material_point(*material, curve.control, point);
    if (!run.completed) {
      e.error = run.error.empty() ? "material-point run stopped early" : run.error;
      if (keep_run) e.run = std::move(run);
      return e;
    }
    std::vector<double> mx, my;
    mx.reserve(run.steps.size());
    my.reserve(run.steps.size());
    for (const auto& s : run.steps) {
      mx.push_back(model_quantity(s, curve.x));
      my.push_back(model_quantity(s, curve.y));
    }
    for (double y : my)
      if (!std::isfinite(y)) {
        e.error = "non-finite model output";
        return e;
      }
    if (curve.x == "t") {
      // Data times are output times of the run (merged in parse_calibration): exact lookup.
      e.model.resize(curve.x_data.size());
      const double tol = 1e-9 * std::max(1.0, mx.back());
      for (std::size_t i = 0; i < curve.x_data.size(); ++i) {
        const auto it = std::lower_bound(mx.begin(), mx.end(), curve.x_data[i] - tol);
        if (it == mx.end() || std::abs(*it - curve.x_data[i]) > tol) {
          e.error = "data time " + format_number(curve.x_data[i]) + " is not an output time of the run";
          return e;
        }
        e.model[i] = my[std::size_t(it - mx.begin())];
      }
    } else if (!sample_in_x(mx, my, curve.x_data, e.model, e.error)) {
      return e;
    }
    e.ok = true;
    if (keep_run) e.run = std::move(run);
  } catch (const std::exception& ex) {
    // Inadmissible parameter values (InputError from validate) or a solver exception: a failed
    // evaluation, never a crash of the fit.
    e.ok = false;
    e.error = ex.what();
  }
  return e;
}

}  // namespace softhom::studies
