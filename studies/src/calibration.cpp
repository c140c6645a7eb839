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
#include "softhom/io/scene.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/studies/campaign.hpp"

namespace softhom::studies {
namespace {

std::string join(const std::string& path, const std::string& key) { return path.empty() ? key : path + "." + key; }

/// Shortest decimal that reads back to the same double (valid TOML / JSON number).
std::string num(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  std::string s(buf, r.ptr);
  return s;
}

std::string show(const toml::node& node) { return io::describe_value(node); }

bool get_bool_or(const toml::table& t, const std::string& key, const std::string& path, bool fallback) {
  const toml::node* node = t.get(key);
  if (!node) return fallback;
  if (auto b = node->value<bool>()) return *b;
  throw InputError(join(path, key), show(*node), "must be true or false");
}

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

/// A parameter entry: a number (fixed), {value, min, max} (free) or {value, fixed = true}.
/// `positive`: the quantity must be > 0 (so a free range needs min > 0 and is fitted in log space).
int add_parameter(CalibrationModel& m, const toml::table& t, const std::string& key, const std::string& path,
                  const std::string& name, bool positive, double lo_limit, double hi_limit) {
  const std::string field = join(path, key);
  const toml::node* node = t.get(key);
  if (!node) throw InputError(field, "", "missing (a number = fixed, or {value, min, max} = free)");
  CalParameter p;
  p.name = name;
  if (const auto* pt = node->as_table()) {
    io::check_keys(*pt, field, {"value", "min", "max", "fixed"});
    p.value = io::get_number(*pt, "value", field);
    p.free = !get_bool_or(*pt, "fixed", field, false);
    if (p.free) {
      p.min = io::get_number(*pt, "min", field);
      p.max = io::get_number(*pt, "max", field);
      if (!(p.min < p.max)) throw InputError(join(field, "max"), num(p.max), "must be > min = " + num(p.min));
      if (p.min < lo_limit || (positive && !(p.min > 0.0)))
        throw InputError(join(field, "min"), num(p.min), positive ? "must be > 0" : "must be >= " + num(lo_limit));
      if (p.max > hi_limit) throw InputError(join(field, "max"), num(p.max), "must be <= " + num(hi_limit));
      if (!(p.value >= p.min && p.value <= p.max))
        throw InputError(join(field, "value"), num(p.value), "initial value outside [min, max] = [" + num(p.min) + ", " + num(p.max) + "]");
      p.log_scale = p.min > 0.0;
      p.scale = std::max(std::abs(p.min), std::abs(p.max));
    } else {
      if (pt->contains("min") || pt->contains("max"))
        throw InputError(join(field, pt->contains("min") ? "min" : "max"), "", "a fixed parameter takes no bounds");
    }
  } else if (auto v = node->value<double>()) {
    if (!std::isfinite(*v)) throw InputError(field, show(*node), "must be finite");
    p.value = *v;
  } else {
    throw InputError(field, show(*node), "must be a number (fixed) or a table {value, min, max} (free)");
  }
  if (!p.free && (p.value < lo_limit || p.value > hi_limit || (positive && !(p.value > 0.0))))
    throw InputError(field, num(p.value), positive ? "must be > 0" : "outside the admissible range");
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
        throw InputError("model.viscoelastic.terms", "sum(g) = " + num(sum), "Prony weights must sum to < 1 (g_inf = 1 - sum(g) > 0)");
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
    if (cells.size() != d.columns.size())
      throw InputError(path.string(), "line " + std::to_string(lineno),
                       std::to_string(cells.size()) + " fields, header has " + std::to_string(d.columns.size()));
    std::vector<double> row;
    for (const auto& c : cells) {
      char* end = nullptr;
      const double v = std::strtod(c.c_str(), &end);
      if (c.empty() || end != c.c_str() + c.size() || !std::isfinite(v))
        throw InputError(path.string(), "line " + std::to_string(lineno), "not a finite number: '" + c + "'");
      row.push_back(v);
    }
    d.rows.push_back(std::move(row));
  }
  if (d.columns.empty()) throw InputError(path.string(), "", "empty CSV file (no header)");
  return d;
}

// ---------------------------------------------------------------------------------------------------

CalibrationInput parse_calibration(const toml::table& root, const std::filesystem::path& base_dir) {
  io::check_keys(root, "", {"description", "model", "curves", "solver", "output"});
  CalibrationInput in;
  in.description = io::get_string_or(root, "description", "", "");

  // [model]
  const auto* mt = root["model"].as_table();
  if (!mt) throw InputError("model", "", "missing [model] table");
  io::check_keys(*mt, "model", {"law", "G", "Jm", "K", "k1", "k2", "kappa", "fiber_invariant", "tension_only", "fibers", "viscoelastic"});
  const std::string law = io::get_string_or(*mt, "law", "model", "gent");
  if (law != "gent" && law != "gent-hgo")
    throw InputError("model.law", law, "calibration supports the Gent + HGO (+ QLV) model only: law = \"gent\"");
  CalibrationModel& m = in.model;
  const double inf = std::numeric_limits<double>::infinity();
  m.G = add_parameter(m, *mt, "G", "model", "G", true, 0.0, inf);
  m.Jm = add_parameter(m, *mt, "Jm", "model", "Jm", true, 0.0, inf);
  m.K = add_parameter(m, *mt, "K", "model", "K", true, 0.0, inf);
  if (const toml::node* fibers = mt->get("fibers")) {
    const auto* arr = fibers->as_array();
    if (!arr || arr->empty()) throw InputError("model.fibers", show(*fibers), "must be a non-empty array of tables ([[model.fibers]])");
    m.k1 = add_parameter(m, *mt, "k1", "model", "k1", false, 0.0, inf);
    m.k2 = add_parameter(m, *mt, "k2", "model", "k2", false, 0.0, inf);
    // Optional GOH fiber dispersion, shared by all families; absent = aligned fibers (κ = 0, no parameter).
    if (mt->contains("kappa")) m.kappa = add_parameter(m, *mt, "kappa", "model", "kappa", false, 0.0, 1.0 / 3.0);
    for (std::size_t i = 0; i < arr->size(); ++i) {
      const std::string fp = "model.fibers[" + std::to_string(i) + "]";
      const auto* ft = arr->get(i)->as_table();
      if (!ft) throw InputError(fp, show(*arr->get(i)), "must be a table");
      io::check_keys(*ft, fp, {"angle_deg", "plus_minus"});
      CalFiber f;
      f.angle_parameter = add_parameter(m, *ft, "angle_deg", fp, "fibers[" + std::to_string(i) + "].angle_deg", false, -180.0, 180.0);
      f.plus_minus = get_bool_or(*ft, "plus_minus", fp, false);
      m.fibers.push_back(f);
    }
    const std::string inv = io::get_string_or(*mt, "fiber_invariant", "model", "");
    if (inv == "full") m.invariant = FiberInvariant::full;
    else if (inv == "isochoric") m.invariant = FiberInvariant::isochoric;
    else if (inv.empty())
      throw InputError("model.fiber_invariant", "", "required with fibers: \"full\" (recommended, spec §2) or \"isochoric\"");
    else throw InputError("model.fiber_invariant", inv, "must be \"full\" or \"isochoric\"");
    m.tension_only = get_bool_or(*mt, "tension_only", "model", true);
  } else {
    for (const char* k : {"k1", "k2", "kappa", "fiber_invariant", "tension_only"})
      if (mt->contains(k)) throw InputError(join("model", k), show(*mt->get(k)), "only meaningful with [[model.fibers]]");
  }
  if (const toml::node* ve = mt->get("viscoelastic")) {
    const std::string vp = "model.viscoelastic";
    const auto* vt = ve->as_table();
    if (!vt) throw InputError(vp, show(*ve), "must be a table");
    io::check_keys(*vt, vp, {"g_inf", "tau", "terms"});
    m.viscoelastic = true;
    if (vt->contains("terms")) {
      if (vt->contains("g_inf") || vt->contains("tau"))
        throw InputError(join(vp, vt->contains("g_inf") ? "g_inf" : "tau"), "",
                         "with terms = [...], g_inf = 1 - sum(g) is derived; give either g_inf + tau or terms");
      const auto* arr = vt->get("terms")->as_array();
      if (!arr || arr->empty()) throw InputError(join(vp, "terms"), "", "must be a non-empty array of {g, tau} tables");
      for (std::size_t k = 0; k < arr->size(); ++k) {
        const std::string tp = join(vp, "terms[" + std::to_string(k) + "]");
        const auto* tt = arr->get(k)->as_table();
        if (!tt) throw InputError(tp, show(*arr->get(k)), "must be a table {g = ..., tau = ...}");
        io::check_keys(*tt, tp, {"g", "tau"});
        const std::string np = "viscoelastic.terms[" + std::to_string(k) + "]";
        m.prony_g.push_back(add_parameter(m, *tt, "g", tp, np + ".g", true, 0.0, 1.0));
        m.prony_tau.push_back(add_parameter(m, *tt, "tau", tp, np + ".tau", true, 0.0, inf));
      }
    } else {
      m.g_inf = add_parameter(m, *vt, "g_inf", vp, "viscoelastic.g_inf", true, 0.0, 1.0);
      if (m.parameters[m.g_inf].free && !(m.parameters[m.g_inf].max < 1.0))
        throw InputError(join(vp, "g_inf.max"), num(m.parameters[m.g_inf].max), "must be < 1 (g = 1 - g_inf must stay > 0)");
      m.prony_tau.push_back(add_parameter(m, *vt, "tau", vp, "viscoelastic.tau", true, 0.0, inf));
    }
  }
  m.spec(m.values());  // the initial values must make an admissible material (InputError names model.<field>)

  // [solver]
  CalSolverOptions& so = in.solver;
  if (const toml::node* sn = root.get("solver")) {
    const auto* st = sn->as_table();
    if (!st) throw InputError("solver", show(*sn), "must be a table");
    io::check_keys(*st, "solver", {"method", "starts", "seed", "max_iterations", "function_tolerance", "parameter_tolerance",
                                   "gradient_tolerance", "fd_step", "point_tolerance", "point_max_iterations", "point_max_cutbacks"});
    const std::string method = io::get_string_or(*st, "method", "solver", "levenberg_marquardt");
    if (method == "dogleg") so.dogleg = true;
    else if (method != "levenberg_marquardt")
      throw InputError("solver.method", method, "must be \"levenberg_marquardt\" or \"dogleg\"");
    auto whole = [&](const char* key, double fallback, double lo, double hi) {
      const double v = io::get_number_or(*st, key, "solver", fallback);
      if (!(v >= lo && v <= hi) || v != std::floor(v))
        throw InputError(join("solver", key), num(v), "must be a whole number from " + num(lo) + " to " + num(hi));
      return v;
    };
    auto positive_small = [&](const char* key, double fallback) {
      const double v = io::get_number_or(*st, key, "solver", fallback);
      if (!(v > 0.0 && v < 1.0)) throw InputError(join("solver", key), num(v), "must lie in (0, 1)");
      return v;
    };
    so.starts = int(whole("starts", so.starts, 1, 1000));
    so.seed = std::uint64_t(whole("seed", double(so.seed), 0, 9007199254740992.0));
    so.max_iterations = int(whole("max_iterations", so.max_iterations, 1, 100000));
    so.function_tolerance = positive_small("function_tolerance", so.function_tolerance);
    so.parameter_tolerance = positive_small("parameter_tolerance", so.parameter_tolerance);
    so.gradient_tolerance = positive_small("gradient_tolerance", so.gradient_tolerance);
    so.fd_step = positive_small("fd_step", so.fd_step);
    so.point.tolerance = positive_small("point_tolerance", so.point.tolerance);
    so.point.max_iterations = int(whole("point_max_iterations", so.point.max_iterations, 1, 1000));
    so.point.max_cutbacks = int(whole("point_max_cutbacks", so.point.max_cutbacks, 0, 60));
  }
  if (const toml::node* on = root.get("output")) {
    const auto* ot = on->as_table();
    if (!ot) throw InputError("output", show(*on), "must be a table");
    io::check_keys(*ot, "output", {"plot"});
    in.plot = get_bool_or(*ot, "plot", "output", true);
  }

  // [[curves]]
  const toml::node* cn = root.get("curves");
  const auto* carr = cn ? cn->as_array() : nullptr;
  if (!carr || carr->empty()) throw InputError("curves", "", "missing: give at least one [[curves]] table");
  std::size_t families = 0;
  for (const auto& f : m.fibers) families += f.plus_minus ? 2 : 1;
  std::set<std::string> names;
  std::size_t fit_points = 0;
  std::map<std::filesystem::path, std::map<std::string, CaseRecord>> stores;  // campaign stores read so far
  for (std::size_t i = 0; i < carr->size(); ++i) {
    const std::string cp = "curves[" + std::to_string(i) + "]";
    const auto* ct = carr->get(i)->as_table();
    if (!ct) throw InputError(cp, show(*carr->get(i)), "must be a table ([[curves]])");
    io::check_keys(*ct, cp, {"name", "file", "run", "campaign", "case", "load", "load_rotation_deg", "x", "y", "x_column",
                             "y_column", "weight", "role"});
    CalCurve c;
    if (int(ct->contains("file")) + int(ct->contains("run")) + int(ct->contains("campaign")) != 1)
      throw InputError(cp + ".file", "", "give exactly one of file = \"data.csv\", run = \"DIR\" (a softhom output directory) "
                                         "or campaign = \"DIR\" with case = \"ID\" (a softhom sweep store)");
    const std::string src_key = ct->contains("file") ? ".file" : ct->contains("run") ? ".run" : ".campaign";
    const CaseRecord* record = nullptr;  // campaign curves
    toml::table load_from_run;
    const toml::table* load = ct->get("load") ? ct->get("load")->as_table() : nullptr;
    if (ct->get("load") && !load) throw InputError(cp + ".load", show(*ct->get("load")), "must be a table ([curves.load])");
    std::string default_name = "curve" + std::to_string(i);
    if (ct->contains("file")) {
      const std::string f = io::get_string_or(*ct, "file", cp, "");
      c.file = std::filesystem::path(f).is_absolute() ? std::filesystem::path(f) : base_dir / f;
      default_name = std::filesystem::path(f).stem().string();
      if (!load) throw InputError(cp + ".load", "", "missing: the load control of the curve ([curves.load], as a softhom point [load])");
    } else if (ct->contains("campaign")) {
      // A case of a `softhom sweep` store: its response table, and its scene's [load] unless given.
      const std::string d = io::get_string_or(*ct, "campaign", cp, "");
      std::filesystem::path store = std::filesystem::path(d).is_absolute() ? std::filesystem::path(d) : base_dir / d;
      if (std::filesystem::is_directory(store)) store /= "campaign.h5";
      if (!std::filesystem::exists(store)) throw InputError(cp + ".campaign", store.string(), "no campaign store there (run softhom sweep first)");
      if (!stores.count(store)) {
        try {
          stores[store] = read_store(store);
        } catch (const std::exception& e) {
          throw InputError(cp + ".campaign", store.string(), e.what());
        }
      }
      const std::string id = io::get_string_or(*ct, "case", cp, "");
      const auto& recs = stores.at(store);
      const auto it = recs.find(id);
      if (it == recs.end())
        throw InputError(cp + ".case", id, "no such case in " + store.string() + " (" + std::to_string(recs.size()) + " cases; see its cases.csv)");
      record = &it->second;
      c.file = store;
      default_name = id;
      if (!load) {
        const toml::table scene = io::parse_scene(record->scene_text, store.string() + ":" + id);
        const auto* lt = scene["load"].as_table();
        if (!lt) throw InputError(cp + ".case", id, "the stored scene has no [load]: give [curves.load] explicitly");
        load_from_run = *lt;
        load = &load_from_run;
      }
    } else {
      const std::string r = io::get_string_or(*ct, "run", cp, "");
      const std::filesystem::path dir = std::filesystem::path(r).is_absolute() ? std::filesystem::path(r) : base_dir / r;
      c.file = dir / "response.csv";
      default_name = std::filesystem::path(r).filename().string();
      if (!load) {
        std::ifstream js(dir / "summary.json");
        if (!js) throw InputError(cp + ".run", r, "no summary.json in that directory (give [curves.load] explicitly)");
        nlohmann::json j;
        try {
          j = nlohmann::json::parse(js);
        } catch (const std::exception& e) {
          throw InputError(cp + ".run", r, std::string("summary.json is not valid JSON: ") + e.what());
        }
        if (!j.contains("scene") || !j["scene"].is_object() || !j["scene"].contains("load") || !j["scene"]["load"].is_object())
          throw InputError(cp + ".run", r, "summary.json has no scene.load echo: give [curves.load] explicitly");
        for (const auto& [k, x] : j["scene"]["load"].items()) json_into_table(load_from_run, k, x);
        load = &load_from_run;
      }
    }
    if (ct->contains("case") && !record) throw InputError(cp + ".case", "", "only with campaign = \"DIR\"");
    if (!std::filesystem::exists(c.file)) throw InputError(cp + src_key, c.file.string(), "file not found");
    c.name = io::get_string_or(*ct, "name", cp, default_name);
    if (c.name.empty() || c.name.find_first_of("/\\,\"\n") != std::string::npos)
      throw InputError(cp + ".name", c.name, "must be non-empty without / \\ , or quotes (used as a file name)");
    if (!names.insert(c.name).second) throw InputError(cp + ".name", c.name, "duplicate curve name");
    c.control = io::parse_load(*load, cp + ".load");
    if (ct->contains("load_rotation_deg")) {
      // The whole experiment turned by β about e3 (e.g. an RVE case with fibers at α in its load frame
      // is a model with fibers at α0 loaded along a direction rotated by β = α − α0, spec §7).
      const double b = io::get_number_or(*ct, "load_rotation_deg", cp, 0.0) * std::numbers::pi / 180.0;
      if (!std::isfinite(b)) throw InputError(cp + ".load_rotation_deg", num(b), "must be a finite angle in degrees");
      Mat3 Rz = Mat3::Identity();
      Rz(0, 0) = Rz(1, 1) = std::cos(b);
      Rz(1, 0) = std::sin(b);
      Rz(0, 1) = -std::sin(b);
      c.control.frame = Rz * c.control.frame;
    }
    c.x = io::get_string_or(*ct, "x", cp, "t");
    c.y = io::get_string_or(*ct, "y", cp, "P11");
    for (const auto& [key, q] : {std::pair<const char*, const std::string*>{"x", &c.x}, {"y", &c.y}})
      if (!is_model_quantity(*q, families)) {
        std::string fib = families == 1 ? ", fiber1_angle_deg"
                          : families > 1 ? ", fiber1_angle_deg..fiber" + std::to_string(families) + "_angle_deg" : "";
        throw InputError(cp + "." + key, *q, "not a model quantity (t, F11..F33, P11..P33, sigma11..sigma33" + fib + ")");
      }
    if (c.x == c.y) throw InputError(cp + ".y", c.y, "same as x");
    const std::string xcol = io::get_string_or(*ct, "x_column", cp, c.x);
    const std::string ycol = io::get_string_or(*ct, "y_column", cp, c.y);
    CsvData csv;
    if (record) {
      csv.columns = record->columns;
      for (std::size_t r = 0; r < record->rows(); ++r)
        csv.rows.emplace_back(record->data.begin() + std::ptrdiff_t(r * record->columns.size()),
                              record->data.begin() + std::ptrdiff_t((r + 1) * record->columns.size()));
    } else {
      try {
        csv = read_csv(c.file);
      } catch (const InputError& e) {
        throw InputError(cp + src_key, c.file.string(), e.what());
      }
    }
    const int xi = csv.column(xcol), yi = csv.column(ycol);
    auto list = [&] {
      std::string s;
      for (const auto& n : csv.columns) s += (s.empty() ? "" : ", ") + n;
      return s;
    };
    if (xi < 0) throw InputError(cp + (ct->contains("x_column") ? ".x_column" : ".x"), xcol, "no such column in " + c.file.string() + " (columns: " + list() + ")");
    if (yi < 0) throw InputError(cp + (ct->contains("y_column") ? ".y_column" : ".y"), ycol, "no such column in " + c.file.string() + " (columns: " + list() + ")");
    for (const auto& row : csv.rows) {
      c.x_data.push_back(row[std::size_t(xi)]);
      c.y_data.push_back(row[std::size_t(yi)]);
    }
    if (c.x_data.size() < 2) throw InputError(cp + src_key, c.file.string(), "needs at least two data rows");
    const double dir = c.x_data[1] > c.x_data[0] ? 1.0 : -1.0;
    for (std::size_t k = 1; k < c.x_data.size(); ++k)
      if (!(dir * (c.x_data[k] - c.x_data[k - 1]) > 0.0))
        throw InputError(cp + ".x", c.x, "data x must be strictly monotone (row " + std::to_string(k + 1) +
                                             "); use x = \"t\" for a path that holds or reverses");
    const auto [ymin, ymax] = std::minmax_element(c.y_data.begin(), c.y_data.end());
    c.y_range = *ymax - *ymin;
    if (!(c.y_range > 0.0)) throw InputError(cp + ".y", c.y, "data y is constant: nothing to fit (it also normalises the residual)");
    if (c.x == "t") {
      // The driver reports exactly at the data times: merge them into the control's output times.
      // A data time within 1e-7 of the path length of a control time is that time (CSV round-off).
      const double end = c.control.times.back();
      std::vector<double> times = c.control.times;
      for (double& t : c.x_data) {
        if (t < -1e-7 * end || t > end * (1.0 + 1e-7))
          throw InputError(cp + ".x", "t = " + num(t), "data time outside the load path [0, " + num(end) + "]");
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
    const std::string role = io::get_string_or(*ct, "role", cp, "fit");
    if (role == "holdout") c.holdout = true;
    else if (role != "fit") throw InputError(cp + ".role", role, "must be \"fit\" or \"holdout\"");
    c.weight = io::get_number_or(*ct, "weight", cp, 1.0);
    if (!(c.weight > 0.0)) throw InputError(cp + ".weight", num(c.weight), "must be > 0");
    if (!c.holdout) fit_points += c.x_data.size();
    in.curves.push_back(std::move(c));
  }
  if (fit_points == 0) throw InputError("curves", "", "no curve with role = \"fit\"");
  if (fit_points < m.free_indices().size())
    throw InputError("curves", std::to_string(fit_points) + " fit points",
                     "fewer data points than free parameters (" + std::to_string(m.free_indices().size()) + ")");
  return in;
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
          e.error = "data time " + num(curve.x_data[i]) + " is not an output time of the run";
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
    if (p.at_bound) res.warnings.push_back(q.name + " = " + num(p.value) + " is at a bound: widen [min, max] or fix it");
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
        res.warnings.push_back("JᵀJ is ill-conditioned (condition " + num(res.jtj_condition) +
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
  s << "G = " << num(v[model.G]) << "\n";
  s << "Jm = " << num(v[model.Jm]) << "\n";
  s << "K = " << num(v[model.K]) << "\n";
  if (!model.fibers.empty()) {
    s << "fiber_invariant = \"" << (model.invariant == FiberInvariant::full ? "full" : "isochoric") << "\"\n";
    s << "tension_only = " << (model.tension_only ? "true" : "false") << "\n";
    s << "k1 = " << num(v[model.k1]) << "\n";
    s << "k2 = " << num(v[model.k2]) << "\n";
    if (model.kappa >= 0) s << "kappa = " << num(v[model.kappa]) << "\n";
    for (const CalFiber& f : model.fibers) {
      s << "\n[[material.fibers]]\nangle_deg = " << num(v[f.angle_parameter]) << "\n";
      if (f.plus_minus) s << "\n[[material.fibers]]\nangle_deg = " << num(-v[f.angle_parameter]) << "\n";
    }
  }
  if (model.viscoelastic) {
    const MaterialSpec spec = model.spec(v);
    s << "\n[material.viscoelastic]\ng_inf = " << num(spec.prony->g_inf) << "\nterms = [";
    for (std::size_t k = 0; k < spec.prony->terms.size(); ++k)
      s << (k ? ", " : "") << "{g = " << num(spec.prony->terms[k].g) << ", tau = " << num(spec.prony->terms[k].tau) << "}";
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

void write_calibration_files(const std::filesystem::path& dir, const CalibrationInput& in, const CalibrationResult& res) {
  std::ostringstream header;
  header << "softhom calibrate: fitted Gent + HGO" << (in.model.viscoelastic ? " + QLV" : "") << " material ("
         << (res.success ? "converged" : "NOT converged") << ", cost " << res.final_cost << ").\n"
         << "A `softhom point` [material] table: cat material.toml load.toml > scene.toml";
  io::write_file_atomic(dir / "material.toml", material_toml(in.model, res.values, header.str()));

  io::CsvTable cmp({"curve", "x", "data", "model"});
  for (std::size_t i = 0; i < res.curves.size(); ++i) {
    const CurveFit& f = res.curves[i];
    if (!f.ok) continue;
    for (std::size_t k = 0; k < f.x.size(); ++k) cmp.add_row({double(i), f.x[k], f.data[k], f.model[k]});
  }
  cmp.write(dir / "response.csv");

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
