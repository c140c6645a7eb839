// Reading a calibration: the [model] with its parameters, the [[curves]] with their data and loads
// (CSV files, `softhom point`/`rve` output directories, campaign stores), the declared keys.
#include "softhom/studies/calibration.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <set>
#include <sstream>

#include "softhom/io/files.hpp"
#include "softhom/core/keys.hpp"
#include "softhom/io/scene.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/studies/campaign.hpp"

namespace softhom::studies {
namespace {

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

}  // namespace

int CsvData::column(const std::string& name) const {
  for (std::size_t i = 0; i < columns.size(); ++i)
    if (columns[i] == name) return int(i);
  return -1;
}

namespace {

/// A CSV cell as a message shows it: control bytes (a NUL, say) as \xNN, so the text stays one line
/// and is not cut at the NUL.
std::string printable(const std::string& cell) {
  std::string out;
  for (unsigned char ch : cell) {
    if (ch >= 0x20 && ch != 0x7f) {
      out += char(ch);
      continue;
    }
    char hex[8];
    std::snprintf(hex, sizeof hex, "\\x%02x", ch);
    out += hex;
  }
  return out;
}

/// The table of CSV text read from `file` (errors name the file and the line).
CsvData parse_csv(const std::string& text, const std::string& file) {
  // Spreadsheet programs save "CSV UTF-8" with a byte-order mark: it belongs to no field.
  const std::string_view bom = "\xEF\xBB\xBF";
  std::istringstream in(text.starts_with(bom) ? text.substr(bom.size()) : text);
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
    const std::string where = file + " line " + std::to_string(lineno);
    if (cells.size() != d.columns.size())
      throw InputError(where, "", std::to_string(cells.size()) + " fields, the header has " + std::to_string(d.columns.size()));
    std::vector<double> row;
    for (std::size_t j = 0; j < cells.size(); ++j) {
      const std::string& c = cells[j];
      char* end = nullptr;
      const double v = std::strtod(c.c_str(), &end);
      if (c.empty() || end != c.c_str() + c.size() || !std::isfinite(v))
        throw InputError(where, "'" + printable(c) + "'", "not a finite number (column " + printable(d.columns[j]) + ")");
      row.push_back(v);
    }
    d.rows.push_back(std::move(row));
  }
  if (d.columns.empty()) throw InputError(file, "", "empty CSV file (no header)");
  return d;
}

}  // namespace

CsvData read_csv(const std::filesystem::path& path) {
  return parse_csv(io::read_input_file(path, path.string(), io::kCsvFile), path.string());
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
    k.custom("law", "string", "\"gent\" (Gent matrix + HGO fibers) or \"fiber-composite\" (+ GL, GT)", r, "\"gent\"")
        .custom("G", kParameter, "shear modulus", r, "required", "> 0", "MPa")
        .custom("Jm", kParameter, "Gent locking parameter", r, "required", "> 0", "-")
        .custom("K", kParameter, "bulk modulus", r, "required", "> 0", "MPa")
        .custom("k1", kParameter, "HGO fiber stiffness (with fibers)", r, "required with fibers", ">= 0", "MPa")
        .custom("k2", kParameter, "HGO exponential coefficient (with fibers)", r, "required with fibers", ">= 0", "-")
        .custom("kappa", kParameter, "GOH fiber dispersion shared by all families", r, "0", "[0, 1/3]", "-")
        .custom("GL", kParameter, "added fiber-matrix shear modulus (law = \"fiber-composite\")", r, "required with it", ">= 0", "MPa")
        .custom("GT", kParameter, "added transverse shear modulus (law = \"fiber-composite\")", r, "required with it", ">= 0", "MPa")
        .custom("Ef", kParameter, "stretch-linear fiber modulus (law = \"fiber-composite\")", r, "required with it", ">= 0", "MPa")
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
  const bool composite = law == "fiber-composite";
  if (law != "gent" && law != "gent-hgo" && !composite)
    throw InputError("model.law", "\"" + law + "\"",
                     "calibration supports law = \"gent\" (Gent + HGO, + QLV) and \"fiber-composite\"");
  CalibrationModel m;
  m.G = add_parameter(m, mt, "G", "model", "G", true, 0.0, kInf);
  m.Jm = add_parameter(m, mt, "Jm", "model", "Jm", true, 0.0, kInf);
  m.K = add_parameter(m, mt, "K", "model", "K", true, 0.0, kInf);
  if (composite) {
    if (!mt.contains("fibers")) throw InputError("model.fibers", "", "law = \"fiber-composite\" needs [[model.fibers]]");
    m.GL = add_parameter(m, mt, "GL", "model", "GL", false, 0.0, kInf);
    m.GT = add_parameter(m, mt, "GT", "model", "GT", false, 0.0, kInf);
    m.Ef = add_parameter(m, mt, "Ef", "model", "Ef", false, 0.0, kInf);
  } else {
    for (const char* k : {"GL", "GT", "Ef"})
      if (mt.contains(k))
        throw InputError(keys::join_key("model", k), keys::describe_value(*mt.get(k)), "a parameter of law = \"fiber-composite\" only");
  }
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
  io::check_input_file(store, cp + ".campaign", io::kDataFile);
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
  if (!std::filesystem::exists(dir / "summary.json"))
    throw InputError(cp + ".run", k.run, "no summary.json in that directory (give [curves.load] explicitly)");
  const std::string text = io::read_input_file(dir / "summary.json", cp + ".run", io::kJsonFile);
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
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
  const std::string text = io::read_input_file(src.file, cp + src.key, io::kCsvFile);
  try {
    return parse_csv(text, src.file.string());
  } catch (const InputError& e) {
    const std::string what = e.what();
    const std::size_t head = e.field().size() + (e.value().empty() ? 0 : 3 + e.value().size()) + 2;  // "field = value: "
    throw InputError(cp + src.key, e.field(), (e.value().empty() ? "" : e.value() + ": ") + what.substr(std::min(head, what.size())));
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
  // The residual's norm sums squares of the data's size, normalised by the range: both must stay finite
  // (±1e308 made them inf, and the fit's summary non-finite after the run).
  double squares = 0.0;
  for (double y : c.y_data) squares += y * y;
  if (!std::isfinite(c.y_range) || !std::isfinite(squares))
    throw InputError(cp + ".y", c.y, "data y spans " + format_number(*ymin) + " to " + format_number(*ymax) +
                                         ": too large for the residual's norm (its squares or range overflow a double)");
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

/// Refuses a fit whose worst case cannot finish: starts × max_iterations × model evaluations per
/// iteration (central differences: 2 per free parameter + 1) × the load steps of the fit curves, in
/// material-point steps. The limit, 1e9 steps, is about 7 hours at the rate measured on the shipped
/// example_point.toml (2330 curve evaluations of ~30 steps in 1.7 s: 4e4 steps/s, one thread).
void refuse_unbounded_fit(const CalibrationInput& in) {
  constexpr double kMaxPointSteps = 1e9, kStepsPerSecond = 4e4;
  double fit_steps = 0.0;
  for (const CalCurve& c : in.curves)
    if (!c.holdout) fit_steps += double(c.control.times.size());
  const double per_iteration = 2.0 * double(in.model.free_indices().size()) + 1.0;
  const double work = double(in.solver.starts) * double(in.solver.max_iterations) * per_iteration * fit_steps;
  if (work <= kMaxPointSteps) return;
  const auto g = [](double x) {
    std::ostringstream s;
    s.precision(2);
    s << x;
    return s.str();
  };
  throw InputError("solver.max_iterations", std::to_string(in.solver.max_iterations),
                   "the fit may need up to " + g(work) + " material-point steps (" + std::to_string(in.solver.starts) +
                       " starts x " + std::to_string(in.solver.max_iterations) + " iterations x " + g(per_iteration) +
                       " evaluations per iteration x " + g(fit_steps) + " load steps of the fit curves), about " +
                       format_number(std::ceil(work / kStepsPerSecond / 3600.0)) + " hours at 4e4 steps/s; at most " + g(kMaxPointSteps) +
                       " are accepted: lower starts, max_iterations or the curves' steps");
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
  refuse_unbounded_fit(in);
  return in;
}

std::vector<keys::TableDoc> calibration_tables() {
  return {root_table().describe(), model_table().describe(), parameter_table().describe(), fiber_table().describe(),
           viscoelastic_table().describe(), term_table().describe(), curve_table().describe(), solver_table().describe(),
           output_table().describe()};
}

}  // namespace softhom::studies
