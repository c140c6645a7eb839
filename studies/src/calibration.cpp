#include "softhom/studies/calibration.hpp"

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cmath>
#include <fstream>
#include <limits>
#include <numbers>
#include <random>
#include <set>
#include <sstream>

#include <Eigen/Dense>
#include <ceres/ceres.h>

#include "softhom/io/files.hpp"
#include "softhom/core/keys.hpp"
#include "softhom/io/scene.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/studies/campaign.hpp"

namespace softhom::studies {
namespace {

const std::vector<std::string>& tensor_columns() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n{"t"};
    for (const char* name : {"F", "P", "sigma"})
      for (int i = 1; i <= 3; ++i)
        for (int j = 1; j <= 3; ++j) n.push_back(name + std::to_string(i) + std::to_string(j));
    return n;
  }();
  return names;
}

// ---------------------------------------------------------------------------------------------------
// Parameters

/// A key whose value the calibration parser reads itself (parameters, sub-tables).
template <class O>
typename keys::KeyTable<O>::Apply read_below() {
  return [](const toml::node&, const std::string&, O&) {};
}

const std::string kParameter = "number or {value, min, max}";
const std::string kParameterDoc = "a number is fixed; {value, min, max} is free within [min, max]; {value, fixed = true}";

struct NoKeys {};

const keys::KeyTable<NoKeys>& parameter_table() {
  static const keys::KeyTable<NoKeys> t = [] {
    keys::KeyTable<NoKeys> k("model.<parameter>", "A parameter given as a table.");
    auto r = read_below<NoKeys>();
    k.custom("value", "number", "initial (free) or fixed value", r, "required")
        .custom("min", "number", "lower bound of a free parameter (> 0: fitted in log space)", r, "required when free")
        .custom("max", "number", "upper bound of a free parameter", r, "required when free")
        .custom("fixed", "true/false", "keep the value (no bounds then)", r, "false");
    return k;
  }();
  return t;
}

/// A parameter entry: a number (fixed), {value, min, max} (free) or {value, fixed = true}.
/// `positive`: the quantity must be > 0 (so a free range needs min > 0 and is fitted in log space).
int add_parameter(CalibrationModel& m, const toml::table& t, const std::string& key, const std::string& path,
                  const std::string& name, bool positive, double lo_limit, double hi_limit) {
  const std::string field = keys::join_key(path, key);
  const toml::node* node = t.get(key);
  if (!node) throw InputError(field, "", "missing (a number = fixed, or {value, min, max} = free)");
  CalParameter p;
  p.name = name;
  if (const auto* pt = node->as_table()) {
    NoKeys none;
    parameter_table().read(*pt, field, none);
    p.value = io::get_number(*pt, "value", field);
    p.free = !io::get_bool_or(*pt, "fixed", field, false);
    if (p.free) {
      p.min = io::get_number(*pt, "min", field);
      p.max = io::get_number(*pt, "max", field);
      if (!(p.min < p.max)) throw InputError(keys::join_key(field, "max"), format_number(p.max), "must be > min = " + format_number(p.min));
      if (p.min < lo_limit || (positive && !(p.min > 0.0)))
        throw InputError(keys::join_key(field, "min"), format_number(p.min), positive ? "must be > 0" : "must be >= " + format_number(lo_limit));
      if (p.max > hi_limit) throw InputError(keys::join_key(field, "max"), format_number(p.max), "must be <= " + format_number(hi_limit));
      if (!(p.value >= p.min && p.value <= p.max))
        throw InputError(keys::join_key(field, "value"), format_number(p.value), "initial value outside [min, max] = [" + format_number(p.min) + ", " + format_number(p.max) + "]");
      p.log_scale = p.min > 0.0;
      p.scale = std::max(std::abs(p.min), std::abs(p.max));
    } else {
      if (pt->contains("min") || pt->contains("max"))
        throw InputError(keys::join_key(field, pt->contains("min") ? "min" : "max"), "", "a fixed parameter takes no bounds");
    }
  } else if (auto v = node->value<double>()) {
    if (!std::isfinite(*v)) throw InputError(field, keys::describe_value(*node), "must be finite");
    p.value = *v;
  } else {
    throw InputError(field, keys::describe_value(*node), "must be a number (fixed) or a table {value, min, max} (free)");
  }
  if (!p.free && (p.value < lo_limit || p.value > hi_limit || (positive && !(p.value > 0.0))))
    throw InputError(field, format_number(p.value), positive ? "must be > 0" : "outside the admissible range");
  m.parameters.push_back(p);
  return int(m.parameters.size()) - 1;
}

// ---------------------------------------------------------------------------------------------------
// JSON (summary.json scene echo) → TOML, so a `softhom point`/`rve` output directory can be fitted.

void json_into_array(toml::array& arr, const nlohmann::json& v);
void json_into_table(toml::table& t, const std::string& key, const nlohmann::json& v) {
  if (v.is_object()) {
    toml::table sub;
    for (const auto& [k, x] : v.items()) json_into_table(sub, k, x);
    t.insert(key, std::move(sub));
  } else if (v.is_array()) {
    toml::array arr;
    json_into_array(arr, v);
    t.insert(key, std::move(arr));
  } else if (v.is_boolean()) t.insert(key, v.get<bool>());
  else if (v.is_number_integer()) t.insert(key, v.get<std::int64_t>());
  else if (v.is_number()) t.insert(key, v.get<double>());
  else if (v.is_string()) t.insert(key, v.get<std::string>());
}
void json_into_array(toml::array& arr, const nlohmann::json& v) {
  for (const auto& x : v) {
    if (x.is_object()) {
      toml::table sub;
      for (const auto& [k, y] : x.items()) json_into_table(sub, k, y);
      arr.push_back(std::move(sub));
    } else if (x.is_array()) {
      toml::array sub;
      json_into_array(sub, x);
      arr.push_back(std::move(sub));
    } else if (x.is_boolean()) arr.push_back(x.get<bool>());
    else if (x.is_number_integer()) arr.push_back(x.get<std::int64_t>());
    else if (x.is_number()) arr.push_back(x.get<double>());
    else if (x.is_string()) arr.push_back(x.get<std::string>());
  }
}

// ---------------------------------------------------------------------------------------------------
// Sampling the model response at the data's x.

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

// ---------------------------------------------------------------------------------------------------
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

}  // namespace

// ---------------------------------------------------------------------------------------------------

MaterialSpec CalibrationModel::spec(const std::vector<double>& v) const {
  MaterialSpec s;
  s.field_prefix = "model";
  s.law = LawKind::gent_hgo;
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

int CsvData::column(const std::string& name) const {
  for (std::size_t i = 0; i < columns.size(); ++i)
    if (columns[i] == name) return int(i);
  return -1;
}

CsvData read_csv(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path.string(), "", "cannot open the CSV file");
  auto trim = [](std::string s) {
    const auto b = s.find_first_not_of(" \t\r\"");
    const auto e = s.find_last_not_of(" \t\r\"");
    return b == std::string::npos ? std::string() : s.substr(b, e - b + 1);
  };
  auto split = [&](const std::string& line) {
    std::vector<std::string> out;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) out.push_back(trim(cell));
    if (!line.empty() && line.back() == ',') out.push_back("");
    return out;
  };
  const std::string file = path.string();
  CsvData d;
  std::string line;
  int lineno = 0;
  while (std::getline(in, line)) {
    ++lineno;
    const std::string t = trim(line);
    if (t.empty() || t[0] == '#') continue;
    const auto cells = split(line);
    if (d.columns.empty()) {
      d.columns = cells;
      continue;
    }
    const std::string where = file + " line " + std::to_string(lineno);
    if (cells.size() != d.columns.size())
      throw InputError(where, "", std::to_string(cells.size()) + " fields, the header has " + std::to_string(d.columns.size()));
    std::vector<double> row;
    for (std::size_t j = 0; j < cells.size(); ++j) {
      const std::string& c = cells[j];
      char* end = nullptr;
      const double v = std::strtod(c.c_str(), &end);
      if (c.empty() || end != c.c_str() + c.size() || !std::isfinite(v))
        throw InputError(where, "'" + c + "'", "not a finite number (column " + d.columns[j] + ")");
      row.push_back(v);
    }
    d.rows.push_back(std::move(row));
  }
  if (d.columns.empty()) throw InputError(file, "", "empty CSV file (no header)");
  return d;
}

// ---------------------------------------------------------------------------------------------------
// Declared keys. Values that are parameters ({value, min, max}) or sub-tables are read by the
// functions below; the tables declare every key once (unknown keys, docs, defaults).

namespace {


const keys::KeyTable<NoKeys>& root_table() {
  static const keys::KeyTable<NoKeys> t = [] {
    keys::KeyTable<NoKeys> k("", "A calibration: the model with its free parameters, the curves, the optimizer.");
    auto r = read_below<NoKeys>();
    k.custom("description", "string", "free text, copied to summary.json", r)
        .custom("model", "table", "the Gent + HGO (+ QLV) model and its parameters", r).required()
        .custom("curves", "list of tables", "[[curves]]: data curves to fit or hold out", r).required()
        .custom("solver", "table", "optimizer settings", r)
        .custom("output", "table", "output switches", r);
    return k;
  }();
  return t;
}

const keys::KeyTable<NoKeys>& model_table() {
  static const keys::KeyTable<NoKeys> t = [] {
    keys::KeyTable<NoKeys> k("model", "The homogeneous Gent + HGO model; parameters: " + kParameterDoc + ".");
    auto r = read_below<NoKeys>();
    k.custom("law", "string", "\"gent\" only (Gent matrix + HGO fibers)", r, "\"gent\"")
        .custom("G", kParameter, "shear modulus", r, "required", "> 0", "MPa")
        .custom("Jm", kParameter, "Gent locking parameter", r, "required", "> 0", "-")
        .custom("K", kParameter, "bulk modulus", r, "required", "> 0", "MPa")
        .custom("k1", kParameter, "HGO fiber stiffness (with fibers)", r, "required with fibers", ">= 0", "MPa")
        .custom("k2", kParameter, "HGO exponential coefficient (with fibers)", r, "required with fibers", ">= 0", "-")
        .custom("kappa", kParameter, "GOH fiber dispersion shared by all families", r, "0", "[0, 1/3]", "-")
        .custom("fiber_invariant", "choice", "fiber invariant (with fibers)", r, "required with fibers",
                "\"full\", \"isochoric\"")
        .custom("tension_only", "true/false", "fibers carry no compression (with fibers)", r, "true")
        .custom("fibers", "list of tables", "[[model.fibers]] families", r)
        .custom("viscoelastic", "table", "QLV Prony series", r);
    return k;
  }();
  return t;
}


const keys::KeyTable<NoKeys>& fiber_table() {
  static const keys::KeyTable<NoKeys> t = [] {
    keys::KeyTable<NoKeys> k("model.fibers[]", "A fiber family.");
    auto r = read_below<NoKeys>();
    k.custom("angle_deg", kParameter, "angle in the 1-2 plane from e2 toward e1", r, "required", "[-180, 180]", "deg")
        .custom("plus_minus", "true/false", "two families at +θ and −θ sharing the angle parameter", r, "false");
    return k;
  }();
  return t;
}

const keys::KeyTable<NoKeys>& viscoelastic_table() {
  static const keys::KeyTable<NoKeys> t = [] {
    keys::KeyTable<NoKeys> k("model.viscoelastic", "QLV: one term (g_inf, tau) or terms = [{g, tau}, ...].");
    auto r = read_below<NoKeys>();
    k.custom("g_inf", kParameter, "long-time fraction (one term, g = 1 − g_inf)", r, "", "(0, 1)", "-")
        .custom("tau", kParameter, "relaxation time (one term)", r, "", "> 0", "s")
        .custom("terms", "list of {g, tau}", "Prony terms (g_inf = 1 − Σ g derived)", r);
    return k;
  }();
  return t;
}

const keys::KeyTable<NoKeys>& term_table() {
  static const keys::KeyTable<NoKeys> t = [] {
    keys::KeyTable<NoKeys> k("model.viscoelastic.terms[]", "A Prony term.");
    auto r = read_below<NoKeys>();
    k.custom("g", kParameter, "relative modulus of the term", r, "required", "(0, 1)", "-")
        .custom("tau", kParameter, "relaxation time", r, "required", "> 0", "s");
    return k;
  }();
  return t;
}

const keys::KeyTable<CalSolverOptions>& solver_table() {
  using O = CalSolverOptions;
  static const keys::KeyTable<O> t = [] {
    const O defaults{};
    keys::KeyTable<O> k("solver", "Bounded nonlinear least squares (Ceres) and the material-point driver of each evaluation.");
    k.choice("method", &O::dogleg,
             keys::Choices<bool>{{{"levenberg-marquardt", false}, {"dogleg", true}}, {{"levenberg_marquardt", "levenberg-marquardt"}}},
             "trust-region strategy")
        .integer("starts", &O::starts, keys::closed_range(1, 1000), "-", "the initial values + seeded random points inside the bounds")
        .integer("seed", &O::seed, keys::closed_range(0, 9007199254740992.0), "-", "random starts' seed")
        .integer("max_iterations", &O::max_iterations, keys::closed_range(1, 100000), "-", "optimizer iterations per start")
        .number("function_tolerance", &O::function_tolerance, keys::open_range(0, 1), "-", "relative cost change to stop")
        .number("parameter_tolerance", &O::parameter_tolerance, keys::open_range(0, 1), "-", "relative step to stop")
        .number("gradient_tolerance", &O::gradient_tolerance, keys::open_range(0, 1), "-", "gradient norm to stop")
        .number("fd_step", &O::fd_step, keys::open_range(0, 1), "-", "central-difference step in the scaled unknowns")
        .custom(
            "point_tolerance", "number", "driver Newton tolerance (relative to max(G, |P|))",
            [](const toml::node& n, const std::string& f, O& o) { o.point.tolerance = keys::read_number(n, f, keys::open_range(0, 1)); },
            format_number(defaults.point.tolerance), "(0, 1)", "-")
        .custom(
            "point_max_iterations", "integer", "driver Newton iterations per step",
            [](const toml::node& n, const std::string& f, O& o) {
              o.point.max_iterations = keys::read_int<int>(n, f, keys::closed_range(1, 1000));
            },
            std::to_string(defaults.point.max_iterations), "[1, 1000]", "-")
        .custom(
            "point_max_cutbacks", "integer", "driver step halvings",
            [](const toml::node& n, const std::string& f, O& o) {
              o.point.max_cutbacks = keys::read_int<int>(n, f, keys::closed_range(0, 60));
            },
            std::to_string(defaults.point.max_cutbacks), "[0, 60]", "-");
    return k;
  }();
  return t;
}

struct OutputKeys {
  bool plot = true;
};

const keys::KeyTable<OutputKeys>& output_table() {
  static const keys::KeyTable<OutputKeys> t = [] {
    keys::KeyTable<OutputKeys> k("output", "Output switches.");
    k.flag("plot", &OutputKeys::plot, "write fit.svg (data and model curves)");
    return k;
  }();
  return t;
}

struct CurveKeys {
  std::string name, file, run, campaign, case_id, x = "t", y = "P11", x_column, y_column;
  const toml::table* load = nullptr;
  double load_rotation_deg = 0.0;
  double weight = 1.0;
  bool holdout = false;
};

const keys::KeyTable<CurveKeys>& curve_table() {
  using O = CurveKeys;
  static const keys::KeyTable<O> t = [] {
    keys::KeyTable<O> k("curves[]", "A data curve: one source (file, run or campaign case), its load and the quantities compared.");
    k.text("name", &O::name, "curve name (file names, response.csv); default: from the source")
        .default_text("from the source")
        .text("file", &O::file, "CSV file (header of names), relative to the calibration file")
        .text("run", &O::run, "a softhom point/rve output directory (its response.csv and summary.json)")
        .text("campaign", &O::campaign, "a softhom sweep store (DIR or DIR/campaign.h5), with case")
        .text("case", &O::case_id, "case id in the campaign store")
        .custom(
            "load", "table", "the curve's control, as a softhom point [load] (default: the run's or case's)",
            [](const toml::node& n, const std::string& f, O& o) { o.load = &keys::read_table(n, f); })
        .number("load_rotation_deg", &O::load_rotation_deg, keys::any_value(), "deg", "turns the load frame about e3")
        .text("x", &O::x, "model quantity on the x axis (t, F11..F33, P11..P33, sigma11..sigma33, fiberK_angle_deg)")
        .text("y", &O::y, "model quantity compared with the data")
        .text("x_column", &O::x_column, "CSV column of x").default_text("= x")
        .text("y_column", &O::y_column, "CSV column of y").default_text("= y")
        .number("weight", &O::weight, keys::above(0), "-", "weight of the curve's NRMSE² in the cost")
        .choice("role", &O::holdout, keys::Choices<bool>{{{"fit", false}, {"holdout", true}}, {}},
                "fitted, or only predicted and reported");
    return k;
  }();
  return t;
}

const double kInf = std::numeric_limits<double>::infinity();

void parse_fibers(const toml::table& mt, const toml::node& fibers, CalibrationModel& m) {
  const auto* arr = fibers.as_array();
  if (!arr || arr->empty())
    throw InputError("model.fibers", keys::describe_value(fibers), "must be a non-empty array of tables ([[model.fibers]])");
  m.k1 = add_parameter(m, mt, "k1", "model", "k1", false, 0.0, kInf);
  m.k2 = add_parameter(m, mt, "k2", "model", "k2", false, 0.0, kInf);
  // Optional GOH fiber dispersion, shared by all families; absent = aligned fibers (κ = 0, no parameter).
  if (mt.contains("kappa")) m.kappa = add_parameter(m, mt, "kappa", "model", "kappa", false, 0.0, 1.0 / 3.0);
  for (std::size_t i = 0; i < arr->size(); ++i) {
    const std::string fp = keys::index_field("model.fibers", i);
    const toml::table& ft = keys::read_table(*arr->get(i), fp);
    NoKeys none;
    fiber_table().read(ft, fp, none);
    CalFiber f;
    f.angle_parameter = add_parameter(m, ft, "angle_deg", fp, keys::index_field("fibers", i) + ".angle_deg", false, -180.0, 180.0);
    f.plus_minus = io::get_bool_or(ft, "plus_minus", fp, false);
    m.fibers.push_back(f);
  }
  const toml::node* inv = mt.get("fiber_invariant");
  if (!inv) throw InputError("model.fiber_invariant", "", "required with fibers: \"full\" (recommended, spec §2) or \"isochoric\"");
  m.invariant = keys::read_choice(*inv, "model.fiber_invariant",
                                keys::Choices<FiberInvariant>{{{"full", FiberInvariant::full}, {"isochoric", FiberInvariant::isochoric}}, {}});
  m.tension_only = io::get_bool_or(mt, "tension_only", "model", true);
}

void parse_viscoelastic(const toml::node& ve, CalibrationModel& m) {
  const std::string vp = "model.viscoelastic";
  const toml::table& vt = keys::read_table(ve, vp);
  NoKeys none;
  viscoelastic_table().read(vt, vp, none);
  m.viscoelastic = true;
  if (vt.contains("terms")) {
    if (vt.contains("g_inf") || vt.contains("tau"))
      throw InputError(keys::join_key(vp, vt.contains("g_inf") ? "g_inf" : "tau"), "",
                       "with terms = [...], g_inf = 1 - sum(g) is derived; give either g_inf + tau or terms");
    const auto* arr = vt.get("terms")->as_array();
    if (!arr || arr->empty()) throw InputError(keys::join_key(vp, "terms"), "", "must be a non-empty array of {g, tau} tables");
    for (std::size_t k = 0; k < arr->size(); ++k) {
      const std::string tp = keys::index_field(vp + ".terms", k);
      const toml::table& tt = keys::read_table(*arr->get(k), tp);
      term_table().read(tt, tp, none);
      const std::string np = keys::index_field("viscoelastic.terms", k);
      m.prony_g.push_back(add_parameter(m, tt, "g", tp, np + ".g", true, 0.0, 1.0));
      m.prony_tau.push_back(add_parameter(m, tt, "tau", tp, np + ".tau", true, 0.0, kInf));
    }
  } else {
    m.g_inf = add_parameter(m, vt, "g_inf", vp, "viscoelastic.g_inf", true, 0.0, 1.0);
    if (m.parameters[m.g_inf].free && !(m.parameters[m.g_inf].max < 1.0))
      throw InputError(keys::join_key(vp, "g_inf.max"), format_number(m.parameters[m.g_inf].max),
                       "must be < 1 (g = 1 - g_inf must stay > 0)");
    m.prony_tau.push_back(add_parameter(m, vt, "tau", vp, "viscoelastic.tau", true, 0.0, kInf));
  }
}

CalibrationModel parse_model(const toml::table& root) {
  const toml::node* node = root.get("model");
  const toml::table& mt = keys::read_table(*node, "model");
  NoKeys none;
  model_table().read(mt, "model", none);
  const std::string law = io::get_string_or(mt, "law", "model", "gent");
  if (law != "gent" && law != "gent-hgo")
    throw InputError("model.law", "\"" + law + "\"", "calibration supports the Gent + HGO (+ QLV) model only: law = \"gent\"");
  CalibrationModel m;
  m.G = add_parameter(m, mt, "G", "model", "G", true, 0.0, kInf);
  m.Jm = add_parameter(m, mt, "Jm", "model", "Jm", true, 0.0, kInf);
  m.K = add_parameter(m, mt, "K", "model", "K", true, 0.0, kInf);
  if (const toml::node* fibers = mt.get("fibers")) {
    parse_fibers(mt, *fibers, m);
  } else {
    for (const char* k : {"k1", "k2", "kappa", "fiber_invariant", "tension_only"})
      if (mt.contains(k)) throw InputError(keys::join_key("model", k), keys::describe_value(*mt.get(k)), "only meaningful with [[model.fibers]]");
  }
  if (const toml::node* ve = mt.get("viscoelastic")) parse_viscoelastic(*ve, m);
  m.spec(m.values());  // the initial values must make an admissible material (InputError names model.<field>)
  return m;
}

/// Where a curve's data and load come from.
struct CurveSource {
  std::string key;                       ///< ".file", ".run" or ".campaign" (for messages)
  std::filesystem::path file;
  std::string default_name;
  const CaseRecord* record = nullptr;    ///< campaign curves
  toml::table load_from_run;             ///< the run's or case's [load] when the curve gives none
};

/// Campaign stores read so far (several curves from one store read it once).
using StoreCache = std::map<std::filesystem::path, std::map<std::string, CaseRecord>>;

std::filesystem::path resolve(const std::filesystem::path& base_dir, const std::string& p) {
  return std::filesystem::path(p).is_absolute() ? std::filesystem::path(p) : base_dir / p;
}

void campaign_source(const CurveKeys& k, const std::string& cp, const std::filesystem::path& base_dir, StoreCache& stores,
                     CurveSource& src) {
  // A case of a `softhom sweep` store: its response table, and its scene's [load] unless given.
  std::filesystem::path store = resolve(base_dir, k.campaign);
  if (std::filesystem::is_directory(store)) store /= "campaign.h5";
  if (!std::filesystem::exists(store)) throw InputError(cp + ".campaign", store.string(), "no campaign store there (run softhom sweep first)");
  if (!stores.count(store)) {
    try {
      stores[store] = read_store(store);
    } catch (const std::exception& e) {
      throw InputError(cp + ".campaign", store.string(), e.what());
    }
  }
  const auto& recs = stores.at(store);
  const auto it = recs.find(k.case_id);
  if (it == recs.end())
    throw InputError(cp + ".case", k.case_id,
                     "no such case in " + store.string() + " (" + std::to_string(recs.size()) + " cases; see its cases.csv)");
  src.record = &it->second;
  src.file = store;
  src.default_name = k.case_id;
  if (!k.load) {
    const toml::table scene = io::parse_scene(src.record->scene_text, store.string() + ":" + k.case_id);
    const auto* lt = scene["load"].as_table();
    if (!lt) throw InputError(cp + ".case", k.case_id, "the stored scene has no [load]: give [curves.load] explicitly");
    src.load_from_run = *lt;
  }
}

void run_source(const CurveKeys& k, const std::string& cp, const std::filesystem::path& base_dir, CurveSource& src) {
  const std::filesystem::path dir = resolve(base_dir, k.run);
  src.file = dir / "response.csv";
  src.default_name = std::filesystem::path(k.run).filename().string();
  if (k.load) return;
  std::ifstream js(dir / "summary.json");
  if (!js) throw InputError(cp + ".run", k.run, "no summary.json in that directory (give [curves.load] explicitly)");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(js);
  } catch (const std::exception& e) {
    throw InputError(cp + ".run", k.run, std::string("summary.json is not valid JSON: ") + e.what());
  }
  if (!j.contains("scene") || !j["scene"].is_object() || !j["scene"].contains("load") || !j["scene"]["load"].is_object())
    throw InputError(cp + ".run", k.run, "summary.json has no scene.load echo: give [curves.load] explicitly");
  for (const auto& [key, x] : j["scene"]["load"].items()) json_into_table(src.load_from_run, key, x);
}

CurveSource curve_source(const toml::table& ct, const CurveKeys& k, const std::string& cp, const std::filesystem::path& base_dir,
                         StoreCache& stores, std::size_t index) {
  if (int(ct.contains("file")) + int(ct.contains("run")) + int(ct.contains("campaign")) != 1)
    throw InputError(cp + ".file", "", "give exactly one of file = \"data.csv\", run = \"DIR\" (a softhom output directory) "
                                       "or campaign = \"DIR\" with case = \"ID\" (a softhom sweep store)");
  CurveSource src;
  src.key = ct.contains("file") ? ".file" : ct.contains("run") ? ".run" : ".campaign";
  src.default_name = "curve" + std::to_string(index);
  if (ct.contains("file")) {
    src.file = resolve(base_dir, k.file);
    src.default_name = std::filesystem::path(k.file).stem().string();
    if (!k.load) throw InputError(cp + ".load", "", "missing: the load control of the curve ([curves.load], as a softhom point [load])");
  } else if (ct.contains("campaign")) {
    campaign_source(k, cp, base_dir, stores, src);
  } else {
    run_source(k, cp, base_dir, src);
  }
  if (ct.contains("case") && !src.record) throw InputError(cp + ".case", "", "only with campaign = \"DIR\"");
  if (!std::filesystem::exists(src.file)) throw InputError(cp + src.key, src.file.string(), "file not found");
  return src;
}

/// The curve's table: the store's response table, or the CSV file (its errors name the curve field,
/// the file and the line).
CsvData curve_table(const CurveSource& src, const std::string& cp) {
  CsvData csv;
  if (src.record) {
    csv.columns = src.record->columns;
    for (std::size_t r = 0; r < src.record->rows(); ++r)
      csv.rows.emplace_back(src.record->data.begin() + std::ptrdiff_t(r * src.record->columns.size()),
                            src.record->data.begin() + std::ptrdiff_t((r + 1) * src.record->columns.size()));
    return csv;
  }
  try {
    return read_csv(src.file);
  } catch (const InputError& e) {
    throw InputError(cp + src.key, e.field(), (e.value().empty() ? "" : e.value() + ": ") +
                                                  std::string(e.what()).substr(e.field().size() + (e.value().empty() ? 0 : 3 + e.value().size()) + 2));
  }
}

void check_quantities(const CalCurve& c, const std::string& cp, std::size_t families) {
  for (const auto& [key, q] : {std::pair<const char*, const std::string*>{"x", &c.x}, {"y", &c.y}})
    if (!is_model_quantity(*q, families)) {
      std::string fib = families == 1 ? ", fiber1_angle_deg"
                        : families > 1 ? ", fiber1_angle_deg..fiber" + std::to_string(families) + "_angle_deg" : "";
      throw InputError(cp + "." + key, "\"" + *q + "\"", "not a model quantity (t, F11..F33, P11..P33, sigma11..sigma33" + fib + ")");
    }
  if (c.x == c.y) throw InputError(cp + ".y", "\"" + c.y + "\"", "same as x");
}

void set_curve_data(CalCurve& c, const CsvData& csv, const CurveKeys& k, const toml::table& ct, const std::string& cp,
                    const std::string& src_key) {
  const std::string xcol = k.x_column.empty() ? c.x : k.x_column, ycol = k.y_column.empty() ? c.y : k.y_column;
  const int xi = csv.column(xcol), yi = csv.column(ycol);
  auto list = [&] {
    std::string s;
    for (const auto& n : csv.columns) s += (s.empty() ? "" : ", ") + n;
    return s;
  };
  if (xi < 0)
    throw InputError(cp + (ct.contains("x_column") ? ".x_column" : ".x"), xcol, "no such column in " + c.file.string() + " (columns: " + list() + ")");
  if (yi < 0)
    throw InputError(cp + (ct.contains("y_column") ? ".y_column" : ".y"), ycol, "no such column in " + c.file.string() + " (columns: " + list() + ")");
  for (const auto& row : csv.rows) {
    c.x_data.push_back(row[std::size_t(xi)]);
    c.y_data.push_back(row[std::size_t(yi)]);
  }
  if (c.x_data.size() < 2) throw InputError(cp + src_key, c.file.string(), "needs at least two data rows");
  const double dir = c.x_data[1] > c.x_data[0] ? 1.0 : -1.0;
  for (std::size_t r = 1; r < c.x_data.size(); ++r)
    if (!(dir * (c.x_data[r] - c.x_data[r - 1]) > 0.0))
      throw InputError(cp + ".x", c.x, "data x must be strictly monotone (row " + std::to_string(r + 1) +
                                           "); use x = \"t\" for a path that holds or reverses");
  const auto [ymin, ymax] = std::minmax_element(c.y_data.begin(), c.y_data.end());
  c.y_range = *ymax - *ymin;
  if (!(c.y_range > 0.0)) throw InputError(cp + ".y", c.y, "data y is constant: nothing to fit (it also normalises the residual)");
}

/// x = "t": the driver reports exactly at the data times, merged into the control's output times. A
/// data time within 1e-7 of the path length of a control time is that time (CSV round-off).
void merge_data_times(CalCurve& c, const std::string& cp) {
  const double end = c.control.times.back();
  std::vector<double> times = c.control.times;
  for (double& t : c.x_data) {
    if (t < -1e-7 * end || t > end * (1.0 + 1e-7))
      throw InputError(cp + ".x", "t = " + format_number(t), "data time outside the load path [0, " + format_number(end) + "]");
    double best = 0.0, gap = std::abs(t);
    for (double tc : c.control.times)
      if (std::abs(tc - t) < gap) gap = std::abs(tc - t), best = tc;
    if (gap <= 1e-7 * end) t = best;
    else times.push_back(t);
  }
  std::sort(times.begin(), times.end());
  times.erase(std::unique(times.begin(), times.end()), times.end());
  c.control.times = times;
}

CalCurve parse_curve(const toml::table& ct, const std::string& cp, std::size_t index, const std::filesystem::path& base_dir,
                     std::size_t families, StoreCache& stores) {
  CurveKeys k;
  curve_table().read(ct, cp, k);
  CalCurve c;
  CurveSource src = curve_source(ct, k, cp, base_dir, stores, index);
  c.file = src.file;
  c.name = ct.contains("name") ? k.name : src.default_name;
  if (c.name.empty() || c.name.find_first_of("/\\,\"\n") != std::string::npos)
    throw InputError(cp + ".name", "\"" + c.name + "\"", "must be non-empty without / \\ , or quotes (a file name and a CSV cell)");
  c.control = io::parse_load(k.load ? *k.load : src.load_from_run, cp + ".load");
  if (ct.contains("load_rotation_deg")) {
    // The whole experiment turned by β about e3 (e.g. an RVE case with fibers at α in its load frame
    // is a model with fibers at α0 loaded along a direction rotated by β = α − α0, spec §7).
    const double b = k.load_rotation_deg * std::numbers::pi / 180.0;
    Mat3 Rz = Mat3::Identity();
    Rz(0, 0) = Rz(1, 1) = std::cos(b);
    Rz(1, 0) = std::sin(b);
    Rz(0, 1) = -std::sin(b);
    c.control.frame = Rz * c.control.frame;
  }
  c.x = k.x;
  c.y = k.y;
  check_quantities(c, cp, families);
  set_curve_data(c, curve_table(src, cp), k, ct, cp, src.key);
  if (c.x == "t") merge_data_times(c, cp);
  c.holdout = k.holdout;
  c.weight = k.weight;
  return c;
}

}  // namespace

CalibrationInput parse_calibration(const toml::table& root, const std::filesystem::path& base_dir) {
  NoKeys none;
  root_table().read(root, "", none);
  CalibrationInput in;
  if (const toml::node* d = root.get("description")) in.description = keys::read_text(*d, "description");
  in.model = parse_model(root);
  solver_table().read_optional(root.get("solver"), "solver", in.solver);
  OutputKeys out;
  output_table().read_optional(root.get("output"), "output", out);
  in.plot = out.plot;

  const toml::array& carr = keys::read_array(*root.get("curves"), "curves");
  if (carr.empty()) throw InputError("curves", "", "missing: give at least one [[curves]] table");
  std::size_t families = 0;
  for (const auto& f : in.model.fibers) families += f.plus_minus ? 2 : 1;
  std::set<std::string> names;
  std::size_t fit_points = 0;
  StoreCache stores;
  for (std::size_t i = 0; i < carr.size(); ++i) {
    const std::string cp = keys::index_field("curves", i);
    CalCurve c = parse_curve(keys::read_table(*carr.get(i), cp), cp, i, base_dir, families, stores);
    if (!names.insert(c.name).second) throw InputError(cp + ".name", "\"" + c.name + "\"", "duplicate curve name");
    if (!c.holdout) fit_points += c.x_data.size();
    in.curves.push_back(std::move(c));
  }
  if (fit_points == 0) throw InputError("curves", "", "no curve with role = \"fit\"");
  if (fit_points < in.model.free_indices().size())
    throw InputError("curves", std::to_string(fit_points) + " fit points",
                     "fewer data points than free parameters (" + std::to_string(in.model.free_indices().size()) + ")");
  return in;
}

std::vector<keys::TableDoc> calibration_tables() {
  return {root_table().describe(), model_table().describe(), parameter_table().describe(), fiber_table().describe(),
           viscoelastic_table().describe(), term_table().describe(), curve_table().describe(), solver_table().describe(),
           output_table().describe()};
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

CalibrationResult calibrate(const CalibrationInput& in, const CalibrationProgress& progress) {
  const auto wall_start = std::chrono::steady_clock::now();
  CalibrationResult res;
  FitProblem fp(in);
  const int n = fp.unknown_count(), m = fp.residual_count();
  const std::vector<int>& free = fp.free();
  auto say = [&](const std::string& s) {
    if (progress) progress(s);
  };

  std::vector<double> best_u(static_cast<std::size_t>(n), 0.0);
  double best_cost = std::numeric_limits<double>::infinity();
  std::vector<double> r(static_cast<std::size_t>(m));

  if (n == 0) {
    std::string err;
    if (fp.residuals(nullptr, r.data(), &err)) {
      best_cost = 0.0;
      for (double x : r) best_cost += 0.5 * x * x;
      res.best_start = 0;
    } else {
      res.warnings.push_back("model evaluation failed at the given (all fixed) parameters: " + err);
    }
    StartReport sr;
    sr.initial_cost = sr.final_cost = best_cost;
    sr.usable = std::isfinite(best_cost);
    sr.termination = "no free parameters: evaluated only";
    res.starts.push_back(sr);
  } else {
    FitCost cost(fp);
    std::mt19937_64 rng(in.solver.seed);
    for (int s = 0; s < in.solver.starts; ++s) {
      std::vector<double> u(static_cast<std::size_t>(n));
      for (int k = 0; k < n; ++k) {
        if (s == 0) u[k] = fp.to_u(k, in.model.parameters[free[k]].value);
        else u[k] = std::uniform_real_distribution<double>(fp.u_lower(k), fp.u_upper(k))(rng);
        u[k] = std::clamp(u[k], fp.u_lower(k), fp.u_upper(k));
      }
      StartReport sr;
      for (int k = 0; k < n; ++k) sr.initial.push_back(fp.from_u(k, u[k]));
      std::string err;
      if (!fp.residuals(u.data(), r.data(), &err)) {
        sr.termination = "initial point not evaluable: " + err;
        sr.initial_cost = sr.final_cost = std::numeric_limits<double>::quiet_NaN();
        sr.final = sr.initial;
        say("start " + std::to_string(s) + ": " + sr.termination);
        res.starts.push_back(sr);
        continue;
      }
      ceres::Problem::Options popt;
      popt.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
      ceres::Problem problem(popt);
      problem.AddResidualBlock(&cost, nullptr, u.data());
      for (int k = 0; k < n; ++k) {
        problem.SetParameterLowerBound(u.data(), k, fp.u_lower(k));
        problem.SetParameterUpperBound(u.data(), k, fp.u_upper(k));
      }
      ceres::Solver::Options opt;
      opt.minimizer_type = ceres::TRUST_REGION;
      opt.trust_region_strategy_type = in.solver.dogleg ? ceres::DOGLEG : ceres::LEVENBERG_MARQUARDT;
      opt.linear_solver_type = ceres::DENSE_QR;
      opt.max_num_iterations = in.solver.max_iterations;
      opt.function_tolerance = in.solver.function_tolerance;
      opt.parameter_tolerance = in.solver.parameter_tolerance;
      opt.gradient_tolerance = in.solver.gradient_tolerance;
      opt.max_num_consecutive_invalid_steps = 20;  // failed evaluations (locking) just shrink the region
      opt.num_threads = 1;
      opt.logging_type = ceres::SILENT;
      opt.minimizer_progress_to_stdout = false;
      ceres::Solver::Summary summary;
      ceres::Solve(opt, &problem, &summary);
      sr.initial_cost = summary.initial_cost;
      sr.final_cost = summary.final_cost;
      sr.iterations = int(summary.iterations.size()) - 1;
      sr.usable = summary.IsSolutionUsable();
      sr.termination = ceres::TerminationTypeToString(summary.termination_type) + std::string(": ") + summary.message;
      for (int k = 0; k < n; ++k) sr.final.push_back(std::clamp(fp.from_u(k, u[k]), in.model.parameters[free[k]].min,
                                                                in.model.parameters[free[k]].max));
      std::ostringstream msg;
      msg << "start " << s << ": cost " << sr.initial_cost << " -> " << sr.final_cost << " in " << sr.iterations
          << " iterations (" << ceres::TerminationTypeToString(summary.termination_type) << ")";
      say(msg.str());
      if (sr.usable && summary.final_cost < best_cost) {
        best_cost = summary.final_cost;
        best_u = u;
        res.best_start = s;
      }
      res.starts.push_back(sr);
    }
  }

  res.values = in.model.values();
  res.success = res.best_start >= 0;
  if (res.success && n > 0) res.values = fp.values_from_u(best_u.data());
  res.final_cost = res.success ? best_cost : std::numeric_limits<double>::quiet_NaN();
  res.residuals = m;
  res.dof = m - n;

  // Parameter statistics from the Jacobian at the optimum: Cov_u = s² (JᵀJ)⁻¹, s² = 2 cost / (m − n),
  // mapped to physical units with dp/du (p for log parameters, scale for linear ones).
  for (std::size_t i = 0; i < in.model.parameters.size(); ++i) {
    const CalParameter& q = in.model.parameters[i];
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
  res.correlation = Eigen::MatrixXd::Constant(n, n, std::numeric_limits<double>::quiet_NaN());
  if (res.success && n > 0) {
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> J(m, n);
    std::vector<double> r0(static_cast<std::size_t>(m));
    if (fp.residuals(best_u.data(), r0.data()) && fp.jacobian(best_u.data(), r0.data(), J.data())) {
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
      res.residual_variance = m > n ? 2.0 * best_cost / double(m - n) : std::numeric_limits<double>::quiet_NaN();
      Eigen::VectorXd d(n);
      for (int k = 0; k < n; ++k) d[k] = fp.dp_du(k, res.values[free[k]]);
      const Eigen::MatrixXd cov = res.residual_variance * d.asDiagonal() * cov_u * d.asDiagonal();
      for (int k = 0; k < n; ++k) {
        if (unidentified[std::size_t(k)]) {
          res.warnings.push_back(in.model.parameters[free[k]].name +
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
    } else {
      res.warnings.push_back("Jacobian at the optimum could not be evaluated: no standard errors");
    }
  }
  if (!res.success) res.warnings.push_back("no start converged to a usable solution");

  // Every curve (fit and holdout) at the optimum.
  for (const CalCurve& c : in.curves) {
    CurveFit f = curve_statistics(c, evaluate_curve(in.model, c, res.values, in.solver.point, true));
    ++res.curve_evaluations;
    if (!f.ok) res.warnings.push_back("curve " + c.name + " could not be evaluated at the optimum: " + f.error);
    res.curves.push_back(std::move(f));
  }
  res.model_evaluations = fp.evaluations();
  res.curve_evaluations += fp.curve_evaluations();
  res.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  return res;
}

std::string material_toml(const CalibrationModel& model, const std::vector<double>& v, const std::string& header) {
  std::ostringstream s;
  if (!header.empty()) {
    std::istringstream h(header);
    std::string line;
    while (std::getline(h, line)) s << "# " << line << "\n";
  }
  s << "[material]\n";
  s << "law = \"gent\"\n";
  s << "G = " << format_number(v[model.G]) << "\n";
  s << "Jm = " << format_number(v[model.Jm]) << "\n";
  s << "K = " << format_number(v[model.K]) << "\n";
  if (!model.fibers.empty()) {
    s << "fiber_invariant = \"" << (model.invariant == FiberInvariant::full ? "full" : "isochoric") << "\"\n";
    s << "tension_only = " << (model.tension_only ? "true" : "false") << "\n";
    s << "k1 = " << format_number(v[model.k1]) << "\n";
    s << "k2 = " << format_number(v[model.k2]) << "\n";
    if (model.kappa >= 0) s << "kappa = " << format_number(v[model.kappa]) << "\n";
    for (const CalFiber& f : model.fibers) {
      s << "\n[[material.fibers]]\nangle_deg = " << format_number(v[f.angle_parameter]) << "\n";
      if (f.plus_minus) s << "\n[[material.fibers]]\nangle_deg = " << format_number(-v[f.angle_parameter]) << "\n";
    }
  }
  if (model.viscoelastic) {
    const MaterialSpec spec = model.spec(v);
    s << "\n[material.viscoelastic]\ng_inf = " << format_number(spec.prony->g_inf) << "\nterms = [";
    for (std::size_t k = 0; k < spec.prony->terms.size(); ++k)
      s << (k ? ", " : "") << "{g = " << format_number(spec.prony->terms[k].g) << ", tau = " << format_number(spec.prony->terms[k].tau) << "}";
    s << "]\n";
  }
  return s.str();
}

nlohmann::json result_json(const CalibrationInput& in, const CalibrationResult& res) {
  using nlohmann::json;
  auto finite_or_null = [](double x) { return std::isfinite(x) ? json(x) : json(nullptr); };
  json j;
  j["success"] = res.success;
  json params = json::array();
  std::vector<std::string> free_names;
  for (const auto& p : res.parameters) {
    json q{{"name", p.name}, {"value", p.value}, {"free", p.free}};
    if (p.free) {
      free_names.push_back(p.name);
      q["initial"] = p.initial;
      q["min"] = p.min;
      q["max"] = p.max;
      q["at_bound"] = p.at_bound;
      q["std_error"] = p.std_error ? finite_or_null(*p.std_error) : json(nullptr);
      q["rel_std_error"] = p.std_error && p.value != 0.0 ? finite_or_null(*p.std_error / std::abs(p.value)) : json(nullptr);
    }
    params.push_back(q);
  }
  j["parameters"] = params;
  json corr = json::array();
  for (int a = 0; a < res.correlation.rows(); ++a) {
    json row = json::array();
    for (int b = 0; b < res.correlation.cols(); ++b) row.push_back(finite_or_null(res.correlation(a, b)));
    corr.push_back(row);
  }
  j["correlation"] = {{"parameters", free_names}, {"matrix", corr}};
  j["fit"] = {{"cost", finite_or_null(res.final_cost)},
              {"cost_definition", "0.5 * sum_c weight_c * NRMSE_c^2 over fit curves"},
              {"residual_variance", finite_or_null(res.residual_variance)},
              {"residuals", res.residuals},
              {"dof", res.dof},
              {"jtj_condition", finite_or_null(res.jtj_condition)},
              {"best_start", res.best_start},
              {"method", in.solver.dogleg ? "dogleg" : "levenberg_marquardt"}};
  json curves = json::array();
  double hold_sum = 0.0, fit_sum = 0.0;
  int hold_n = 0, fit_n = 0;
  for (std::size_t i = 0; i < res.curves.size(); ++i) {
    const CurveFit& f = res.curves[i];
    const CalCurve& c = in.curves[i];
    json q{{"index", i}, {"name", f.name}, {"role", f.holdout ? "holdout" : "fit"}, {"weight", f.weight},
           {"file", c.file.string()}, {"load", c.control.name}, {"x", c.x}, {"y", c.y}, {"points", f.points},
           {"ok", f.ok}};
    if (f.ok) {
      q["r2"] = f.r2;
      q["nrmse"] = f.nrmse;
      q["rmse"] = f.rmse;
      q["max_abs_error"] = f.max_abs_error;
      (f.holdout ? hold_sum : fit_sum) += f.nrmse;
      ++(f.holdout ? hold_n : fit_n);
    } else {
      q["error"] = f.error;
    }
    curves.push_back(q);
  }
  j["curves"] = curves;
  j["mean_nrmse_fit"] = fit_n ? json(fit_sum / fit_n) : json(nullptr);
  j["mean_nrmse_holdout"] = hold_n ? json(hold_sum / hold_n) : json(nullptr);
  json starts = json::array();
  for (const auto& s : res.starts)
    starts.push_back({{"initial", s.initial}, {"final", s.final}, {"initial_cost", finite_or_null(s.initial_cost)},
                      {"final_cost", finite_or_null(s.final_cost)}, {"iterations", s.iterations}, {"usable", s.usable},
                      {"termination", s.termination}});
  j["starts"] = starts;
  j["model_evaluations"] = res.model_evaluations;
  j["curve_evaluations"] = res.curve_evaluations;
  j["wall_time_s"] = res.wall_time_s;
  j["warnings"] = res.warnings;
  return j;
}

std::string comparison_csv(const CalibrationResult& res) {
  // The curve column is the curve's name (validated: no comma, quote or newline), the index its
  // position in [[curves]]; numbers in shortest round-trip form like every other response.csv.
  std::string out = "curve,index,x,data,model\n";
  for (std::size_t i = 0; i < res.curves.size(); ++i) {
    const CurveFit& f = res.curves[i];
    if (!f.ok) continue;
    for (std::size_t k = 0; k < f.x.size(); ++k)
      out += f.name + "," + std::to_string(i) + "," + format_number(f.x[k]) + "," + format_number(f.data[k]) + "," +
             format_number(f.model[k]) + "\n";
  }
  return out;
}

void write_calibration_files(const std::filesystem::path& dir, const CalibrationInput& in, const CalibrationResult& res) {
  std::ostringstream header;
  header << "softhom calibrate: fitted Gent + HGO" << (in.model.viscoelastic ? " + QLV" : "") << " material ("
         << (res.success ? "converged" : "NOT converged") << ", cost " << res.final_cost << ").\n"
         << "A `softhom point` [material] table: cat material.toml load.toml > scene.toml";
  io::write_file_atomic(dir / "material.toml", material_toml(in.model, res.values, header.str()));

  io::write_file_atomic(dir / "response.csv", comparison_csv(res));

  for (const CurveFit& f : res.curves) {
    if (f.run.steps.empty()) continue;
    std::vector<std::string> cols = tensor_columns();
    const std::size_t fam = f.run.steps.front().fiber_angle_deg.size();
    for (std::size_t k = 1; k <= fam; ++k) cols.push_back("fiber" + std::to_string(k) + "_angle_deg");
    io::CsvTable t(cols);
    for (const auto& s : f.run.steps) {
      std::vector<double> row{s.t};
      for (const Mat3* mm : {&s.F, &s.P, &s.sigma})
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j) row.push_back((*mm)(i, j));
      row.insert(row.end(), s.fiber_angle_deg.begin(), s.fiber_angle_deg.end());
      t.add_row(row);
    }
    t.write(dir / "curves" / (f.name + ".csv"));
  }
}

}  // namespace softhom::studies
