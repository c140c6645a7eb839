// Sweep campaigns: expansion of the campaign file into RVE scenes, and the resumable parallel runner.
#include "softhom/studies/campaign.hpp"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <functional>
#include <iostream>
#include <mutex>
#include <optional>
#include <set>
#include <sstream>
#include <thread>

#include "softhom/io/files.hpp"
#include "softhom/io/scene.hpp"
#include "softhom/io/summary.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/materials/interrupt.hpp"
#include "softhom/studies/rve_scene.hpp"

namespace softhom::studies {

// The Debian HDF5 build is not thread-safe: the store and imported phase images go through this.
std::mutex& hdf5_mutex() {
  static std::mutex m;
  return m;
}

namespace {

using Clock = std::chrono::steady_clock;

std::string format_number(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.10g", v);
  return buf;
}

std::string fnv1a_hex(const std::string& s) {
  std::uint64_t h = 1469598103934665603ull;
  for (unsigned char c : s) {
    h ^= c;
    h *= 1099511628211ull;
  }
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  return buf;
}

std::string toml_text(const toml::table& t) {
  std::ostringstream os;
  os << t;
  return os.str();
}

/// Deep merge: tables merge recursively, everything else replaces.
void merge_into(toml::table& dst, const toml::table& src) {
  for (const auto& [k, v] : src) {
    if (const auto* st = v.as_table()) {
      if (auto* dt = dst[k].as_table()) {
        merge_into(*dt, *st);
        continue;
      }
    }
    dst.insert_or_assign(k, v);
  }
}

toml::table& subtable(toml::table& t, const std::string& key) {
  if (!t[key].is_table()) t.insert_or_assign(key, toml::table{});
  return *t[key].as_table();
}

// Built-in sections and loads (spec §7: circular r = 0.2 mm, square 0.07 mm; tension to 1.8,
// compression to 0.6, ramp to 1.5 in 20 s + 20 s hold).
toml::table builtin_section(const std::string& name) {
  if (name == "circle") return toml::table{{"shape", "circle"}, {"radius", 0.2}};
  if (name == "square") return toml::table{{"shape", "square"}, {"width", 0.07}};
  return {};
}

toml::table builtin_load(const std::string& name) {
  if (name == "tension") return toml::table{{"type", "uniaxial"}, {"stretch", 1.8}, {"duration", 1.0}, {"steps", 16}};
  if (name == "compression")
    return toml::table{{"type", "uniaxial"}, {"stretch", 0.6}, {"duration", 1.0}, {"steps", 16}};
  if (name == "equibiaxial")
    return toml::table{{"type", "equibiaxial"}, {"stretch", 1.3}, {"duration", 1.0}, {"steps", 12}};
  if (name == "shear") return toml::table{{"type", "simple-shear"}, {"gamma", 0.5}, {"duration", 1.0}, {"steps", 10}};
  if (name == "relaxation") {
    toml::array path{toml::array{0.0, 1.0}, toml::array{20.0, 1.5}, toml::array{40.0, 1.5}};
    return toml::table{{"type", "uniaxial"}, {"stretch", path}, {"steps", 20}};
  }
  return {};
}

struct AxisValue {
  std::variant<std::string, double> v;
  std::vector<int> grid;  // resolution only
};

/// Axis values of one product or explicit case; absent axes stay empty (→ defaults).
using AxisMap = std::map<std::string, std::vector<AxisValue>>;

AxisValue parse_axis_value(const std::string& axis, const toml::node& node, const std::string& field) {
  AxisValue a;
  if (axis == "matrix" || axis == "section" || axis == "arrangement" || axis == "load") {
    const auto s = node.value<std::string>();
    if (!s || s->empty()) throw InputError(field, io::describe_value(node), "must be a name (string)");
    a.v = *s;
    return a;
  }
  if (axis == "resolution") {
    if (const auto* arr = node.as_array()) {
      for (std::size_t k = 0; k < arr->size(); ++k) {
        const auto n = (*arr)[k].value<double>();
        if (!n || *n < 1 || *n != std::floor(*n))
          throw InputError(field, io::describe_value(node), "grid entries must be positive integers");
        a.grid.push_back(int(*n));
      }
      if (a.grid.size() < 2 || a.grid.size() > 3) throw InputError(field, io::describe_value(node), "give n, [n1, n2] or [n1, n2, n3]");
    } else {
      const auto n = node.value<double>();
      if (!n || *n < 1 || *n != std::floor(*n)) throw InputError(field, io::describe_value(node), "must be a positive integer or a grid");
      a.grid = {int(*n), int(*n)};
    }
    a.v = double(a.grid[0]);
    return a;
  }
  const auto d = node.value<double>();
  if (!d || !std::isfinite(*d)) throw InputError(field, io::describe_value(node), "must be a number");
  if (axis == "volume_fraction" && !(*d >= 0.0 && *d < 1.0)) throw InputError(field, io::describe_value(node), "must lie in [0, 1)");
  a.v = *d;
  return a;
}

AxisMap parse_axes(const toml::table& t, const std::string& path, bool single) {
  AxisMap m;
  for (const auto& [k, v] : t) {
    const std::string key(k.str());
    if (single && (key == "name" || key == "override")) continue;
    const auto& axes = campaign_axes();
    if (std::find(axes.begin(), axes.end(), key) == axes.end())
      throw InputError(path + "." + key, "", "unknown axis (matrix, section, angle, volume_fraction, arrangement, resolution, load)");
    const std::string field = path + "." + key;
    if (single) {
      m[key].push_back(parse_axis_value(key, v, field));
      continue;
    }
    const auto* arr = v.as_array();
    // resolution = [24, 24] is ambiguous: a list of two resolutions. Grids need [[24, 24]].
    if (!arr) {
      m[key].push_back(parse_axis_value(key, v, field));
      continue;
    }
    if (arr->empty()) throw InputError(field, "[]", "an axis needs at least one value");
    for (std::size_t i = 0; i < arr->size(); ++i)
      m[key].push_back(parse_axis_value(key, (*arr)[i], field + "[" + std::to_string(i) + "]"));
  }
  return m;
}

struct Definitions {
  toml::table base;
  std::map<std::string, toml::table> matrices, sections, loads;
};

std::string id_number(double v) {
  std::string s = format_number(v);
  return s;
}

/// Builds one case from one value per axis.
CampaignCase make_case(const Definitions& defs, const std::map<std::string, AxisValue>& values, const std::string& name,
                       const toml::table* override_table, const std::string& field) {
  auto get = [&](const std::string& axis) -> const AxisValue* {
    const auto it = values.find(axis);
    return it == values.end() ? nullptr : &it->second;
  };
  const toml::table* base_micro = defs.base["microstructure"].as_table();
  auto base_number = [&](const char* key, double fallback) {
    if (base_micro)
      if (const auto v = (*base_micro)[key].value<double>()) return *v;
    return fallback;
  };
  auto base_string = [&](const char* key, const std::string& fallback) {
    if (base_micro)
      if (const auto v = (*base_micro)[key].value<std::string>()) return *v;
    return fallback;
  };

  if (!get("matrix")) throw InputError(field + ".matrix", "", "missing (every case needs a matrix)");
  if (!get("load")) throw InputError(field + ".load", "", "missing (every case needs a load case)");
  const std::string matrix = std::get<std::string>(get("matrix")->v);
  const std::string load = std::get<std::string>(get("load")->v);
  double vf = get("volume_fraction") ? std::get<double>(get("volume_fraction")->v) : base_number("volume_fraction", 0.23);
  double angle = get("angle") ? std::get<double>(get("angle")->v) : base_number("fiber_angle_deg", 45.0);
  // Without a section axis the base scene's section is kept (named after its shape), else "circle".
  const bool base_section = !get("section") && base_micro && base_micro->contains("shape");
  std::string section = get("section") ? std::get<std::string>(get("section")->v) : base_string("shape", "circle");
  std::string arrangement = get("arrangement") ? std::get<std::string>(get("arrangement")->v) : base_string("arrangement", "square");
  std::vector<int> grid{32, 32};
  if (get("resolution")) grid = get("resolution")->grid;
  else if (base_micro && (*base_micro)["grid"]) {
    if (const auto* arr = (*base_micro)["grid"].as_array()) {
      grid.clear();
      for (const auto& e : *arr) grid.push_back(int(e.value<double>().value_or(0)));
    } else {
      const int g = int((*base_micro)["grid"].value<double>().value_or(32));
      grid = {g, g};
    }
  }
  const bool matrix_only = vf == 0.0;
  if (matrix_only) {
    // The homogeneous cell does not depend on these: one case per matrix, resolution and load.
    section = "none";
    arrangement = "none";
    angle = 0.0;
  }

  CampaignCase c;
  c.parameters = {{"matrix", matrix},     {"section", section},
                  {"angle", angle},       {"volume_fraction", vf},
                  {"arrangement", arrangement}, {"resolution", double(grid[0])},
                  {"load", load}};

  toml::table scene = defs.base;
  scene.erase("output");
  toml::table& micro = subtable(scene, "microstructure");
  if (!matrix_only) {
    if (!base_section) {
      toml::table sec;
      if (const auto it = defs.sections.find(section); it != defs.sections.end()) sec = it->second;
      else sec = builtin_section(section);
      if (sec.empty())
        throw InputError(field + ".section", section, "not defined: add [sections." + section + "] or use circle, square");
      for (const char* k : {"shape", "radius", "width", "height", "section_rotation_deg", "fiber_count", "min_gap", "seed"})
        micro.erase(k);
      merge_into(micro, sec);
    }
    micro.insert_or_assign("arrangement", arrangement);
    micro.insert_or_assign("fiber_angle_deg", angle);
  } else {
    for (const char* k : {"shape", "radius", "width", "height", "section_rotation_deg", "fiber_count", "min_gap", "seed",
                          "arrangement", "cell_size"})
      micro.erase(k);
    micro.insert_or_assign("fiber_angle_deg", 0.0);
  }
  micro.insert_or_assign("volume_fraction", vf);
  toml::array g;
  for (int n : grid) g.push_back(n);
  micro.insert_or_assign("grid", g);

  toml::table& phases = subtable(scene, "phases");
  if (const auto it = defs.matrices.find(matrix); it != defs.matrices.end()) phases.insert_or_assign("matrix", it->second);
  else phases.insert_or_assign("matrix", toml::table{{"preset", matrix}});
  if (!phases.contains("fiber")) phases.insert_or_assign("fiber", toml::table{{"preset", "glass"}});
  if (const auto it = defs.loads.find(load); it != defs.loads.end()) scene.insert_or_assign("load", it->second);
  else if (toml::table l = builtin_load(load); !l.empty()) scene.insert_or_assign("load", l);
  else
    throw InputError(field + ".load", load,
                     "not defined: add [loads." + load + "] or use tension, compression, equibiaxial, shear, relaxation");
  if (override_table) merge_into(scene, *override_table);

  if (!name.empty()) {
    c.id = name;
  } else {
    std::ostringstream id;
    id << matrix << "-";
    if (matrix_only) id << "matrix";
    else id << section << "-a" << id_number(angle) << "-vf" << id_number(vf) << "-" << arrangement;
    id << "-n" << grid[0];
    for (std::size_t k = 1; k < grid.size(); ++k) id << "x" << grid[k];
    id << "-" << load;
    c.id = id.str();
  }
  for (char& ch : c.id)
    if (ch == '/' || ch == ' ' || ch == ',' || ch == '"') ch = '_';

  // Validate the scene exactly as `softhom rve` would (errors name the case).
  try {
    const RveSceneSetup setup = parse_rve_scene(scene);
    c.control = setup.control;
    c.elastic = setup.matrix->state_size() == 0 && setup.fiber->state_size() == 0;
  } catch (const InputError& e) {
    throw InputError("case " + c.id + ": " + e.field(), e.value(), std::string(e.what()).substr(
        std::min(std::string(e.what()).size(), e.field().size() + (e.value().empty() ? 0 : 3 + e.value().size()) + 2)));
  }
  c.scene = scene;
  c.scene_text = toml_text(scene);
  c.scene_hash = fnv1a_hex(c.scene_text);
  toml::table no_load = scene;
  no_load.erase("load");
  c.microstructure_hash = fnv1a_hex(toml_text(no_load));
  return c;
}

void expand_product(const Definitions& defs, const AxisMap& axes, const std::string& field, std::vector<CampaignCase>& out) {
  const auto& names = campaign_axes();
  std::vector<std::string> present;
  for (const auto& a : names)
    if (axes.count(a)) present.push_back(a);
  std::vector<std::size_t> idx(present.size(), 0);
  while (true) {
    std::map<std::string, AxisValue> values;
    for (std::size_t k = 0; k < present.size(); ++k) values[present[k]] = axes.at(present[k])[idx[k]];
    out.push_back(make_case(defs, values, "", nullptr, field));
    // Last axis fastest.
    int k = int(present.size()) - 1;
    while (k >= 0 && ++idx[k] == axes.at(present[k]).size()) idx[k--] = 0;
    if (k < 0) break;
  }
}

std::map<std::string, toml::table> named_tables(const toml::table& t, const char* key) {
  std::map<std::string, toml::table> m;
  if (!t.contains(key)) return m;
  const auto* tab = t[key].as_table();
  if (!tab) throw InputError(key, "", "must be a table of named tables");
  for (const auto& [k, v] : *tab) {
    const auto* sub = v.as_table();
    if (!sub) throw InputError(std::string(key) + "." + std::string(k.str()), io::describe_value(v), "must be a table");
    m[std::string(k.str())] = *sub;
  }
  return m;
}

}  // namespace

std::string CaseParameter::text() const {
  if (const auto* s = std::get_if<std::string>(&value)) return *s;
  return format_number(std::get<double>(value));
}

const std::vector<std::string>& campaign_axes() {
  static const std::vector<std::string> axes{"matrix", "section", "angle", "volume_fraction", "arrangement", "resolution", "load"};
  return axes;
}

bool is_timing_stat(const std::string& name) {
  return name == "wall_time_s" || name == "solve_time_s" || name == "fft_planning_s";
}

Campaign expand_campaign(const toml::table& table, const std::filesystem::path& base_dir) {
  io::check_keys(table, "", {"description", "base", "base_scene", "matrices", "sections", "loads", "sweep", "cases", "campaign"});
  Campaign camp;
  camp.description = io::get_string_or(table, "description", "", "");
  Definitions defs;
  if (table.contains("base") && table.contains("base_scene"))
    throw InputError("base_scene", "", "give either [base] or base_scene, not both");
  if (const auto* b = table["base"].as_table()) defs.base = *b;
  else if (table.contains("base")) throw InputError("base", "", "must be a table (an RVE scene)");
  if (table.contains("base_scene")) {
    const std::string f = io::get_string_or(table, "base_scene", "", "");
    std::filesystem::path p = f;
    if (p.is_relative()) p = base_dir / p;
    if (!std::filesystem::exists(p)) throw InputError("base_scene", f, "file not found");
    defs.base = io::load_scene(p);
  }
  defs.matrices = named_tables(table, "matrices");
  defs.sections = named_tables(table, "sections");
  defs.loads = named_tables(table, "loads");
  if (const auto* c = table["campaign"].as_table()) {
    io::check_keys(*c, "campaign", {"warm_start"});
    camp.warm_start = (*c)["warm_start"].value_or(true);
  }

  std::vector<CampaignCase> all;
  if (const auto* s = table["sweep"].as_table()) {
    expand_product(defs, parse_axes(*s, "sweep", false), "sweep", all);
  } else if (const auto* arr = table["sweep"].as_array()) {
    for (std::size_t i = 0; i < arr->size(); ++i) {
      const std::string f = "sweep[" + std::to_string(i) + "]";
      const auto* s = (*arr)[i].as_table();
      if (!s) throw InputError(f, "", "must be a table of axes");
      expand_product(defs, parse_axes(*s, f, false), f, all);
    }
  } else if (table.contains("sweep")) {
    throw InputError("sweep", "", "must be a table ([sweep]) or an array of tables ([[sweep]])");
  }
  if (const auto* arr = table["cases"].as_array()) {
    for (std::size_t i = 0; i < arr->size(); ++i) {
      const std::string f = "cases[" + std::to_string(i) + "]";
      const auto* s = (*arr)[i].as_table();
      if (!s) throw InputError(f, "", "must be a table");
      const AxisMap axes = parse_axes(*s, f, true);
      std::map<std::string, AxisValue> values;
      for (const auto& [k, v] : axes) values[k] = v.front();
      const std::string name = io::get_string_or(*s, "name", f, "");
      const toml::table* ov = (*s)["override"].as_table();
      if (s->contains("override") && !ov) throw InputError(f + ".override", "", "must be a table (merged into the case scene)");
      all.push_back(make_case(defs, values, name, ov, f));
    }
  } else if (table.contains("cases")) {
    throw InputError("cases", "", "must be an array of tables ([[cases]])");
  }
  if (all.empty()) throw InputError("sweep", "", "the campaign has no cases (give [sweep] axes or [[cases]])");

  // Union: identical cases from several products count once; one id with two different scenes is an error.
  std::map<std::string, std::string> seen;
  for (auto& c : all) {
    const auto it = seen.find(c.id);
    if (it != seen.end()) {
      if (it->second != c.scene_hash)
        throw InputError("cases", c.id, "two different cases have this id (give explicit cases a distinct name)");
      continue;
    }
    seen[c.id] = c.scene_hash;
    camp.cases.push_back(std::move(c));
  }
  return camp;
}

// ---------------------------------------------------------------------------------------------
// Runner.

namespace {

bool near(double a, double b) { return std::abs(a - b) <= 1e-12 * std::max({1.0, std::abs(a), std::abs(b)}); }

/// Where case A's load path lies on case B's: B passes A's state of time t at time c·t; returns c, or
/// nothing when A's path is not the beginning of B's. Same frame and control kinds, every component
/// agrees, A.value(t) = B.value(c t) on [0, t_A] (piecewise linear: checking both breakpoint sets and
/// A's output times suffices), and c t_A ≤ t_B.
/// rescale (elastic cells, whose response depends on the path of the controlled values only, not on
/// time or steps): c from the component that changes most along A, and A's output times may fall
/// anywhere on B's path ("tension to λ = 1.5 in 16 steps" lies on "tension to λ = 1.8 in 16 steps").
/// Otherwise (history-dependent phases) c = 1 and A's output times must be B's first ones, so that B
/// computes exactly A's time steps: other steps would change the time integration, not just round-off.
std::optional<double> path_scale(const MixedControl& A, const MixedControl& B, bool rescale) {
  if (A.times.empty() || B.times.empty()) return std::nullopt;
  if (!(A.frame - B.frame).isZero(0.0)) return std::nullopt;
  for (int k = 0; k < 9; ++k)
    if (A.kind[k] != B.kind[k]) return std::nullopt;
  const double tA = A.times.back(), tB = B.times.back();
  double c = 1.0;
  if (rescale) {
    int kmax = -1;
    double dmax = 0.0;
    for (int k = 0; k < 9; ++k) {
      const double d = std::abs(A.value[k](tA) - A.value[k](0.0));
      if (d > dmax) dmax = d, kmax = k;
    }
    if (kmax < 0) return std::nullopt;  // nothing changes along A: no path to share
    const PiecewiseLinear& f = B.value[kmax];
    const double target = A.value[kmax](tA);
    std::vector<double> ts{0.0};
    for (double t : f.t)
      if (t > 0.0 && t < tB) ts.push_back(t);
    ts.push_back(tB);
    double s = -1.0;  // first time at which B's component reaches A's end value
    for (std::size_t i = 1; i < ts.size() && s < 0.0; ++i) {
      const double v0 = f(ts[i - 1]), v1 = f(ts[i]);
      if (v1 != v0 && (target - v0) * (target - v1) <= 0.0)
        s = ts[i - 1] + (target - v0) / (v1 - v0) * (ts[i] - ts[i - 1]);
    }
    if (!(s > 0.0)) return std::nullopt;
    c = near(s, tA) ? 1.0 : s / tA;
  } else {
    if (B.times.size() < A.times.size()) return std::nullopt;
    for (std::size_t i = 0; i < A.times.size(); ++i)
      if (!near(A.times[i], B.times[i])) return std::nullopt;
  }
  if (c * tA > tB * (1.0 + 1e-12)) return std::nullopt;
  std::vector<double> ts = A.times;
  ts.push_back(0.0);
  for (int k = 0; k < 9; ++k) {
    for (double t : A.value[k].t)
      if (t <= tA) ts.push_back(t);
    for (double t : B.value[k].t)
      if (t <= c * tA) ts.push_back(t / c);
  }
  for (int k = 0; k < 9; ++k)
    for (double t : ts)
      if (!near(A.value[k](t), B.value[k](c * t))) return std::nullopt;
  return c;
}

/// Total variation of the controlled values along the path: orders the cases of one path.
double path_extent(const MixedControl& A) {
  double e = 0.0;
  const double tA = A.times.back();
  for (int k = 0; k < 9; ++k) {
    std::vector<double> ts{0.0};
    for (double t : A.value[k].t)
      if (t > 0.0 && t < tA) ts.push_back(t);
    ts.push_back(tA);
    for (std::size_t i = 1; i < ts.size(); ++i) e += std::abs(A.value[k](ts[i]) - A.value[k](ts[i - 1]));
  }
  return e;
}

/// B restarted at t0 (t ↦ t − t0), for continuing a solver that is at B's state at t0.
MixedControl shifted(const MixedControl& B, double t0) {
  MixedControl s = B;
  for (int c = 0; c < 9; ++c) {
    const PiecewiseLinear& f = B.value[c];
    PiecewiseLinear g{{0.0}, {f(t0)}};
    for (std::size_t k = 0; k < f.t.size(); ++k)
      if (f.t[k] > t0 && !near(f.t[k], t0)) {
        g.t.push_back(f.t[k] - t0);
        g.v.push_back(f.v[k]);
      }
    s.value[c] = g;
  }
  s.times.clear();
  for (double t : B.times)
    if (t > t0 && !near(t, t0)) s.times.push_back(t - t0);
  return s;
}

std::string hms(double s) {
  if (!(s >= 0) || !std::isfinite(s)) return "?";
  const long t = std::lround(s);
  char buf[32];
  if (t >= 3600) std::snprintf(buf, sizeof buf, "%ldh%02ldm", t / 3600, (t / 60) % 60);
  else if (t >= 60) std::snprintf(buf, sizeof buf, "%ldm%02lds", t / 60, t % 60);
  else std::snprintf(buf, sizeof buf, "%.1fs", s);
  return buf;
}

// ---------------------------------------------------------------------------------------------
// Schedule: which cases run, grouped into chains that share one load path.

struct Chain {
  std::vector<int> members;  // indices into campaign.cases; each one's path is the beginning of the next's
  std::vector<bool> store;   // member must be (re)stored
  int last = 0;              // run up to this member (the last one to store)
};

/// Case ids are HDF5 group names and file-name-like keys: refused before anything runs or is written.
void check_case_ids(const Campaign& campaign) {
  for (const auto& c : campaign.cases)
    if (const std::string problem = case_id_problem(c.id); !problem.empty())
      throw InputError("case id", "\"" + escape_control_characters(c.id) + "\"",
                       problem + " (ids name HDF5 groups; rename the case or the axis value)");
}

/// What must run: absent, changed, or failed with --retry-failed.
std::vector<bool> cases_to_run(const Campaign& campaign, const std::map<std::string, CaseRecord>& stored, bool retry_failed) {
  std::vector<bool> todo(campaign.cases.size(), false);
  for (std::size_t i = 0; i < campaign.cases.size(); ++i) {
    const auto& c = campaign.cases[i];
    const auto it = stored.find(c.id);
    todo[i] = it == stored.end() || it->second.scene_hash != c.scene_hash || (retry_failed && it->second.status != "ok");
  }
  return todo;
}

/// Chains within one microstructure: cases whose load paths lie on each other's (path_scale) run as
/// one path. Deterministic from the campaign alone, so a resumed run computes each case the same way.
std::vector<Chain> plan_chains(const Campaign& campaign, const std::vector<bool>& todo, bool warm) {
  std::vector<Chain> chains;
  std::map<std::string, std::vector<int>> groups;
  std::vector<std::string> group_order;
  for (std::size_t i = 0; i < campaign.cases.size(); ++i) {
    const auto& c = campaign.cases[i];
    const std::string key = warm ? c.microstructure_hash : "single:" + c.id;
    if (!groups.count(key)) group_order.push_back(key);
    groups[key].push_back(int(i));
  }
  for (const auto& key : group_order) {
    std::vector<int> members = groups[key];
    std::vector<double> extent(campaign.cases.size(), 0.0);
    for (int m : members) extent[m] = path_extent(campaign.cases[m].control);
    std::stable_sort(members.begin(), members.end(), [&](int a, int b) {
      if (extent[a] != extent[b]) return extent[a] < extent[b];
      return campaign.cases[a].control.times.back() < campaign.cases[b].control.times.back();
    });
    std::vector<Chain> local;
    for (int m : members) {
      const CampaignCase& c = campaign.cases[m];
      bool placed = false;
      for (auto& ch : local) {
        const CampaignCase& last = campaign.cases[ch.members.back()];
        // Every member must lie on the final path: check against the chain's first member too.
        if (path_scale(last.control, c.control, c.elastic) &&
            path_scale(campaign.cases[ch.members.front()].control, c.control, c.elastic)) {
          ch.members.push_back(m);
          placed = true;
          break;
        }
      }
      if (!placed) local.push_back(Chain{{m}, {}, 0});
    }
    for (auto& ch : local) {
      // Run up to the last member that must be stored; earlier finished members are recomputed
      // (not stored) only because they are on the way. The later members still shape the path's
      // output steps, so a resumed run computes every case exactly as an uninterrupted one.
      int last = -1;
      for (std::size_t k = 0; k < ch.members.size(); ++k) {
        ch.store.push_back(todo[ch.members[k]]);
        if (todo[ch.members[k]]) last = int(k);
      }
      if (last < 0) continue;
      ch.last = last;
      chains.push_back(std::move(ch));
    }
  }
  std::stable_sort(chains.begin(), chains.end(),
                   [](const Chain& a, const Chain& b) { return a.members.front() < b.members.front(); });
  return chains;
}

// ---------------------------------------------------------------------------------------------
// Run one chain (and so one case).

/// The record's parameters: the case's, with the fiber angle NaN for the matrix alone (it has none).
std::vector<CaseParameter> record_parameters(const CampaignCase& c) {
  std::vector<CaseParameter> p = c.parameters;
  bool matrix_only = false;
  for (const auto& q : p)
    if (q.name == "volume_fraction" && !q.is_string() && std::get<double>(q.value) == 0.0) matrix_only = true;
  if (matrix_only)
    for (auto& q : p)
      if (q.name == "angle" && !q.is_string()) q.value = std::nan("");
  return p;
}

CaseRecord base_record(const CampaignCase& c) {
  CaseRecord r;
  r.id = c.id;
  r.parameters = record_parameters(c);
  r.scene_text = c.scene_text;
  r.scene_hash = c.scene_hash;
  r.columns = rve_response_columns();
  return r;
}

void finish_record(CaseRecord& r, const std::vector<rve::RveStep>& steps) {
  r.data.clear();
  double newton = 0, krylov = 0, cutbacks = 0;
  for (const auto& s : steps) {
    const auto row = rve_response_row(s);
    r.data.insert(r.data.end(), row.begin(), row.end());
    newton += s.newton_iterations;
    krylov += s.krylov_iterations;
    cutbacks += s.cutbacks;
  }
  r.stats["steps"] = steps.empty() ? 0.0 : double(steps.size() - 1);
  r.stats["newton_iterations"] = newton;
  r.stats["krylov_iterations"] = krylov;
  r.stats["cutbacks"] = cutbacks;
}

/// The output times of a chain on its final path (the union of all members', mapped by path_scale)
/// and, per member, the index in it of each of the member's own output times.
struct PathPlan {
  std::vector<double> times;                  // S
  std::vector<std::vector<std::size_t>> idx;  // idx[k][i]: S index of member k's i-th output time
};

std::optional<PathPlan> plan_path(const Campaign& campaign, const std::vector<int>& members) {
  const std::size_t K = members.size();
  const CampaignCase& fin = campaign.cases[members.back()];
  std::vector<double> scale(K, 1.0);
  for (std::size_t k = 0; k + 1 < K; ++k) {
    const CampaignCase& c = campaign.cases[members[k]];
    const auto sc = path_scale(c.control, fin.control, c.elastic);
    if (!sc) return std::nullopt;
    scale[k] = *sc;
  }
  PathPlan plan;
  std::vector<double> S;
  for (std::size_t k = 0; k < K; ++k)
    for (double t : campaign.cases[members[k]].control.times) S.push_back(k + 1 == K ? t : scale[k] * t);
  std::sort(S.begin(), S.end());
  for (double t : S)
    if (plan.times.empty() || !near(plan.times.back(), t)) plan.times.push_back(t);
  const auto& U = plan.times;
  plan.idx.resize(K);
  for (std::size_t k = 0; k < K; ++k)
    for (double t : campaign.cases[members[k]].control.times) {
      const double x = k + 1 == K ? t : scale[k] * t;
      std::size_t j = std::size_t(std::lower_bound(U.begin(), U.end(), x) - U.begin());
      if (j == U.size() || (j > 0 && std::abs(U[j - 1] - x) < std::abs(U[j] - x))) --j;
      plan.idx[k].push_back(j);
    }
  return plan;
}

/// What a chain needs besides its members: where results go and whether to stop.
struct ChainContext {
  const Campaign& campaign;
  std::filesystem::path dir;
  int threads_per_job = 1;
  std::function<bool()> stopping;                   // abandon the chain before its next member
  std::function<void()> case_started;               // a member to be stored starts
  std::function<void(CaseRecord&&)> case_finished;  // ... and ends (its record)
  std::atomic<long>* newton_computed = nullptr;
};

/// The solver of a chain's microstructure (made for its first member).
std::unique_ptr<rve::FftRveSolver> make_solver(const ChainContext& ctx, const CampaignCase& c, CaseRecord& r) {
  RveSceneSetup setup;
  {
    // Imported phase images are read with HDF5.
    std::lock_guard<std::mutex> lock(hdf5_mutex());
    setup = parse_rve_scene(c.scene);
  }
  setup.solver.plan.threads = ctx.threads_per_job;
  // FFTW_MEASURE picks plans by timing, so two runs can differ in round-off; the campaign's
  // wisdom file makes a resumed run reuse the plans of the first one (and skips measuring).
  if (setup.solver.plan.wisdom_file.empty()) setup.solver.plan.wisdom_file = ctx.dir / "fftw.wisdom";
  auto solver = std::make_unique<rve::FftRveSolver>(setup.image, setup.matrix, setup.fiber, setup.fiber_angle_deg,
                                                    setup.control.frame, setup.solver);
  r.stats["fft_planning_s"] = solver->planning_seconds();
  r.info["geometry"] = setup.geometry_note;
  r.info["fft"] = solver->fft_description();
  return solver;
}

/// Member k of a chain: continues the shared path up to the member's last output time (if not
/// reached yet) and reads the member's rows off it. Returns its record; `failed` when the path ended
/// before the member's end.
CaseRecord run_member(const ChainContext& ctx, const std::vector<int>& members, const PathPlan& plan, int k,
                      std::unique_ptr<rve::FftRveSolver>& solver, std::vector<rve::RveStep>& path, bool& failed) {
  const Campaign& campaign = ctx.campaign;
  const CampaignCase& c = campaign.cases[members[k]];
  const CampaignCase& fin = campaign.cases[members.back()];
  const std::vector<double>& S = plan.times;
  const std::vector<std::size_t>& idx = plan.idx[k];
  CaseRecord r = base_record(c);
  r.stats["threads"] = ctx.threads_per_job;
  const auto t0 = Clock::now();
  std::vector<rve::RveStep> steps;
  double newton = 0, krylov = 0, cutbacks = 0;
  failed = false;
  try {
    const std::size_t done = path.empty() ? 0 : path.size() - 1;  // entries of S reached
    if (k > 0) r.info["warm_start_from"] = campaign.cases[members[k - 1]].id;
    if (members.size() > 1 && k + 1 < int(members.size())) r.info["on_path_of"] = fin.id;
    rve::RveRunResult result;
    result.completed = true;
    if (idx.back() + 1 > done) {
      MixedControl seg = done == 0 ? fin.control : shifted(fin.control, S[done - 1]);
      seg.times.clear();
      for (std::size_t j = done; j <= idx.back(); ++j) seg.times.push_back(done == 0 ? S[j] : S[j] - S[done - 1]);
      if (!solver) solver = make_solver(ctx, c, r);
      result = solver->run(seg);
      for (std::size_t st = done == 0 ? 0 : 1; st < result.steps.size(); ++st) {
        path.push_back(result.steps[st]);
        newton += result.steps[st].newton_iterations;
        krylov += result.steps[st].krylov_iterations;
        cutbacks += result.steps[st].cutbacks;
      }
      for (const auto& line : result.log) r.info["log"] += line + "\n";
    }
    r.stats["voxels"] = double(solver->grid().voxels());
    r.stats["volume_fraction_achieved"] = solver->achieved_volume_fraction();
    if (!path.empty()) steps.push_back(path[0]);
    for (std::size_t i = 0; i < idx.size() && idx[i] + 1 < path.size(); ++i) {
      rve::RveStep st = path[idx[i] + 1];
      st.t = c.control.times[i];  // the exact output time of a cold run
      steps.push_back(st);
    }
    failed = !result.completed || steps.size() != idx.size() + 1;
    r.status = failed ? "failed" : "ok";
    r.error = result.completed ? (failed ? "the shared load path ended early" : "") : result.error;
  } catch (const std::exception& e) {
    r.status = "failed";
    r.error = e.what();
    failed = true;
  }
  finish_record(r, steps);
  // Work done for this member (its segment of the path), not the rows it shares with others.
  r.stats["newton_iterations"] = newton;
  r.stats["krylov_iterations"] = krylov;
  r.stats["cutbacks"] = cutbacks;
  if (ctx.newton_computed) *ctx.newton_computed += long(newton);
  r.stats["wall_time_s"] = std::chrono::duration<double>(Clock::now() - t0).count();
  return r;
}

/// One chain: the final member's load path is run once, in segments that end at each member's last
/// output time. A segment continues from the solver's converged state at the end of the previous one
/// (the warm start). A member that fails ends the shared path; the members after it then run cold,
/// each on its own.
void run_chain(const ChainContext& ctx, const std::vector<int>& members, const std::vector<bool>& store, int last) {
  const std::optional<PathPlan> plan = plan_path(ctx.campaign, members);
  if (!plan) {  // not expected (chains are built with path_scale); run the members on their own
    for (int j = 0; j <= last; ++j) run_chain(ctx, {members[j]}, {store[j]}, 0);
    return;
  }
  std::unique_ptr<rve::FftRveSolver> solver;
  std::vector<rve::RveStep> path;  // path[0]: t = 0; path[j + 1]: at plan->times[j]
  for (int k = 0; k <= last; ++k) {
    if (ctx.stopping()) return;
    if (store[k]) ctx.case_started();
    bool failed = false;
    CaseRecord r = run_member(ctx, members, *plan, k, solver, path, failed);
    if (store[k]) ctx.case_finished(std::move(r));
    if (failed) {
      for (int j = k + 1; j <= last; ++j) run_chain(ctx, {members[j]}, {store[j]}, 0);
      return;
    }
  }
}

// ---------------------------------------------------------------------------------------------
// The scheduler: `jobs` threads take chains in order; finished records queue up for the writer.

class ChainScheduler {
 public:
  ChainScheduler(const Campaign& campaign, const std::filesystem::path& dir, std::vector<Chain> chains, int jobs,
                 int threads_per_job, std::atomic<long>& newton,
                 std::function<void(const CaseRecord&)> on_case_finished = {})
      : chains_(std::move(chains)),
        on_case_finished_(std::move(on_case_finished)),
        ctx_{campaign, dir, threads_per_job, [this] { return stopping(); }, [this] { case_started(); },
             [this](CaseRecord&& r) { case_finished(std::move(r)); }, &newton},
        workers_alive_(jobs) {
    for (int j = 0; j < jobs; ++j) threads_.emplace_back([this, threads_per_job] { work(threads_per_job); });
  }
  ~ChainScheduler() {
    cancel();
    join();
  }
  ChainScheduler(const ChainScheduler&) = delete;
  ChainScheduler& operator=(const ChainScheduler&) = delete;

  /// Waits (at most `poll`) for finished records and moves them to `batch`; false once every worker
  /// ended and nothing is left. `running`: the members being computed.
  bool wait(std::vector<CaseRecord>& batch, int& running, std::chrono::milliseconds poll) {
    std::unique_lock<std::mutex> lock(mu_);
    cv_.wait_for(lock, poll, [&] { return !results_.empty() || workers_alive_ == 0; });
    batch.clear();
    while (!results_.empty()) {
      batch.push_back(std::move(results_.front()));
      results_.pop_front();
    }
    running = running_;
    return !batch.empty() || workers_alive_ > 0;
  }
  /// No new chain or member starts; records still arriving are dropped (a simulated kill, a write
  /// failure).
  void cancel() {
    std::lock_guard<std::mutex> lock(mu_);
    cancelled_ = true;
    results_.clear();
  }
  void join() {
    for (auto& t : threads_)
      if (t.joinable()) t.join();
  }

 private:
  bool stopping() {
    std::lock_guard<std::mutex> lock(mu_);
    return cancelled_ || stop_requested();
  }
  void case_started() {
    std::lock_guard<std::mutex> lock(mu_);
    ++running_;
  }
  void case_finished(CaseRecord&& r) {
    if (on_case_finished_) on_case_finished_(r);
    std::lock_guard<std::mutex> lock(mu_);
    --running_;
    // On a signal the case in flight is abandoned unless it finished (the engine stops at its next
    // check and reports the interruption, which must not be stored as a failure).
    const bool keep = !cancelled_ && !(stop_requested() && r.status != "ok");
    if (keep) results_.push_back(std::move(r));
    cv_.notify_all();
  }
  void work(int threads_per_job) {
    omp_set_num_threads(threads_per_job);
    while (true) {
      std::size_t ci;
      {
        std::lock_guard<std::mutex> lock(mu_);
        if (cancelled_ || stop_requested() || next_chain_ >= chains_.size()) break;
        ci = next_chain_++;
      }
      run_chain(ctx_, chains_[ci].members, chains_[ci].store, chains_[ci].last);
    }
    std::lock_guard<std::mutex> lock(mu_);
    --workers_alive_;
    cv_.notify_all();
  }

  std::vector<Chain> chains_;
  std::function<void(const CaseRecord&)> on_case_finished_;
  ChainContext ctx_;
  std::mutex mu_;
  std::condition_variable cv_;
  std::deque<CaseRecord> results_;
  std::size_t next_chain_ = 0;
  int running_ = 0, workers_alive_ = 0;
  bool cancelled_ = false;
  std::vector<std::thread> threads_;
};

// ---------------------------------------------------------------------------------------------
// Record: counts and progress lines of the finished cases.

void count_and_log(SweepReport& report, const CaseRecord& r, bool quiet) {
  ++report.finished;
  if (r.status != "ok") ++report.failed;
  if (r.info.count("warm_start_from")) ++report.warm_started;
  const auto wall = r.stats.find("wall_time_s");
  const double seconds = wall == r.stats.end() ? 0.0 : wall->second;
  report.case_time_s += seconds;
  if (quiet) return;
  std::cerr << "[sweep] " << r.id << ": " << r.status;
  if (r.status != "ok") std::cerr << " (" << r.error << ")";
  const auto warm = r.info.find("warm_start_from");
  std::cerr << ", " << r.rows() << " rows, " << hms(seconds) << (warm != r.info.end() ? ", warm from " + warm->second : "")
            << "\n";
}

void log_progress(const SweepReport& report, int to_run, int running, Clock::time_point start) {
  const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
  const int left = to_run - report.finished;
  const double eta = report.finished > 0 ? elapsed / report.finished * left : -1.0;
  std::cerr << "[sweep] done " << report.finished << "/" << to_run << " (failed " << report.failed << "), running "
            << running << ", skipped " << report.skipped << " | elapsed " << hms(elapsed) << ", ETA "
            << (left == 0 ? "0s" : hms(eta)) << "\n";
}

}  // namespace

SweepReport run_campaign(const Campaign& campaign, const std::filesystem::path& dir, const SweepOptions& options) {
  const auto start = Clock::now();
  check_case_ids(campaign);
  SweepReport report;
  report.total = int(campaign.cases.size());

  // Write: the directory is ours until `store` goes (lock, stale temporaries removed, store read).
  CampaignStore store(dir);
  report.store = store.store_path();
  report.csv = store.csv_path();
  report.removed_temporaries = store.removed_temporaries();
  if (!options.quiet)
    for (const auto& p : report.removed_temporaries) std::cerr << "[sweep] removed stale temporary " << p.string() << "\n";

  // Schedule.
  const std::vector<bool> todo = cases_to_run(campaign, store.records(), options.retry_failed);
  report.skipped = int(std::count(todo.begin(), todo.end(), false));
  const bool warm = options.warm_start && campaign.warm_start;
  std::vector<Chain> chains = plan_chains(campaign, todo, warm);
  int to_run = 0;
  for (const auto& ch : chains)
    for (bool s : ch.store) to_run += s ? 1 : 0;
  const int total_threads = options.threads > 0 ? options.threads : omp_get_max_threads();
  // Threads per case from the requested jobs, not from the work left: a resumed run then computes
  // every case with the same thread count as an uninterrupted one (OpenMP sums are order dependent).
  // jobs = 0: one single-threaded job per thread — on small cells OpenMP inside a case gains little,
  // and on a loaded machine its spinning barriers cost far more (BENCHMARKS.md, Campaigns).
  const int requested_jobs = options.jobs > 0 ? options.jobs : total_threads;
  const int tpj = std::max(1, total_threads / requested_jobs);
  const int jobs = std::max(1, std::min(requested_jobs, std::max(1, int(chains.size()))));
  report.threads_per_job = tpj;
  if (!options.quiet)
    std::cerr << "[sweep] " << report.total << " cases: " << report.skipped << " already in the store, " << to_run
              << " to run in " << chains.size() << " chains, " << jobs << " job(s) x " << tpj << " thread(s)"
              << (warm ? ", warm starts on" : ", warm starts off") << "\n";
  if (chains.empty()) store.write(campaign);  // a finished campaign: refresh cases.csv (e.g. after edits)

  std::atomic<long> newton_computed{0};
  const bool stop_was_requested = stop_requested();
  {
    const int workers = chains.empty() ? 0 : jobs;
    ChainScheduler scheduler(campaign, dir, std::move(chains), workers, tpj, newton_computed, options.on_case_finished);
    try {
      int committed = 0, running = 0;
      std::vector<CaseRecord> batch;
      while (scheduler.wait(batch, running, std::chrono::milliseconds(100))) {
        if (batch.empty()) continue;
        std::vector<std::string> ids;
        for (auto& r : batch) {
          count_and_log(report, r, options.quiet);
          ids.push_back(r.id);
          store.add(std::move(r));
        }
        store.write(campaign);
        committed += int(batch.size());
        if (options.on_case_stored)
          for (const auto& id : ids) options.on_case_stored(store.records().at(id));
        if (!options.quiet) log_progress(report, to_run, running, start);
        if (options.max_new_cases > 0 && committed >= options.max_new_cases) scheduler.cancel();  // a simulated kill
      }
    } catch (...) {
      // A file that cannot be written ends the run: the engines stop at their next check (the
      // process-wide flag, restored afterwards unless a signal asked for the stop too).
      scheduler.cancel();
      if (!stop_was_requested) request_stop();
      scheduler.join();
      if (!stop_was_requested && stop_signal() == 0) clear_stop_request();
      throw;
    }
    scheduler.join();
  }
  report.interrupted = stop_requested() && report.finished < to_run;
  if (report.interrupted && !options.quiet)
    std::cerr << "[sweep] interrupted: " << report.finished << " of " << to_run
              << " cases finished and stored; rerun the same command to complete the campaign\n";
  report.wall_time_s = std::chrono::duration<double>(Clock::now() - start).count();
  report.newton_iterations = newton_computed;
  return report;
}

}  // namespace softhom::studies
