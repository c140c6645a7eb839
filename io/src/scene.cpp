#include "softhom/io/scene.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <set>
#include <sstream>

#include "softhom/materials/errors.hpp"

namespace softhom::io {
namespace {

std::string join(const std::string& path, const std::string& key) { return path.empty() ? key : path + "." + key; }

}  // namespace

namespace {

std::string show(const toml::node& node) { return describe_value(node); }

double as_number(const toml::node& node, const std::string& field) {
  if (auto v = node.value<double>()) {
    if (!std::isfinite(*v)) throw InputError(field, show(node), "must be a finite number");
    return *v;
  }
  throw InputError(field, show(node), "must be a number");
}

Vec3 as_vec3(const toml::node& node, const std::string& field) {
  const auto* arr = node.as_array();
  if (!arr || arr->size() != 3) throw InputError(field, show(node), "must be an array of 3 numbers");
  Vec3 v;
  for (int i = 0; i < 3; ++i) v[i] = as_number(*arr->get(std::size_t(i)), field + "[" + std::to_string(i) + "]");
  return v;
}

std::vector<double> as_numbers(const toml::node& node, const std::string& field) {
  const auto* arr = node.as_array();
  if (!arr) return {as_number(node, field)};
  std::vector<double> out;
  for (std::size_t i = 0; i < arr->size(); ++i) out.push_back(as_number(*arr->get(i), field + "[" + std::to_string(i) + "]"));
  return out;
}

/// [[t0, v0], [t1, v1], ...] with t increasing, or a number v reached by a linear ramp from `start`
/// over `duration`.
PiecewiseLinear as_path(const toml::table& table, const std::string& key, const std::string& path,
                        double start) {
  const std::string field = join(path, key);
  const toml::node* node = table.get(key);
  if (!node) throw InputError(field, "", "missing");
  PiecewiseLinear f;
  f.t.clear();
  f.v.clear();
  if (const auto* arr = node->as_array(); arr && arr->size() > 0 && arr->get(0)->is_array()) {
    for (std::size_t k = 0; k < arr->size(); ++k) {
      const std::string fk = field + "[" + std::to_string(k) + "]";
      const auto* pair = arr->get(k)->as_array();
      if (!pair || pair->size() != 2) throw InputError(fk, show(*arr->get(k)), "must be a pair [time, value]");
      const double t = as_number(*pair->get(0), fk + "[0]");
      const double v = as_number(*pair->get(1), fk + "[1]");
      if (!f.t.empty() && !(t > f.t.back()))
        throw InputError(fk + "[0]", std::to_string(t), "times must be strictly increasing");
      if (f.t.empty() && t != 0.0) throw InputError(fk + "[0]", std::to_string(t), "a load path starts at t = 0");
      f.t.push_back(t);
      f.v.push_back(v);
    }
    if (f.t.size() < 2) throw InputError(field, show(*node), "a load path needs at least two points");
    return f;
  }
  const double target = as_number(*node, field);
  const double duration = get_number_or(table, "duration", path, 1.0);
  if (!(duration > 0.0)) throw InputError(join(path, "duration"), std::to_string(duration), "must be > 0");
  f.t = {0.0, duration};
  f.v = {start, target};
  const double hold = get_number_or(table, "hold", path, 0.0);
  if (hold < 0.0) throw InputError(join(path, "hold"), std::to_string(hold), "must be >= 0");
  if (hold > 0.0) {
    f.t.push_back(duration + hold);
    f.v.push_back(target);
  }
  return f;
}

/// Output times: `steps` uniform steps (default 50) or a step `dt`, merged with the path's breakpoints
/// (so a ramp–hold kink is always a step boundary).
std::vector<double> output_times(const toml::table& table, const std::string& path, const std::vector<double>& breaks) {
  const double end = breaks.back();
  std::vector<double> times;
  if (table.contains("dt")) {
    const double dt = get_number(table, "dt", path);
    if (!(dt > 0.0)) throw InputError(join(path, "dt"), std::to_string(dt), "must be > 0");
    if (end / dt > 1e7) throw InputError(join(path, "dt"), std::to_string(dt), "more than 1e7 steps");
    for (double t = dt; t < end * (1.0 - 1e-12); t += dt) times.push_back(t);
  } else {
    const double steps = get_number_or(table, "steps", path, 50.0);
    if (!(steps >= 1.0) || steps != std::floor(steps) || steps > 1e7)
      throw InputError(join(path, "steps"), std::to_string(steps), "must be a whole number from 1 to 1e7");
    for (int k = 1; k < int(steps); ++k) times.push_back(end * k / steps);
  }
  times.push_back(end);
  for (double b : breaks)
    if (b > 0.0) times.push_back(b);
  std::sort(times.begin(), times.end());
  // Merge times closer than a relative 1e-9 (a breakpoint that coincides with a uniform step).
  std::vector<double> merged;
  for (double t : times)
    if (merged.empty() || t - merged.back() > 1e-9 * end) merged.push_back(t);
  return merged;
}

}  // namespace

toml::table parse_scene(std::string_view text, const std::string& source_name) {
  try {
    return toml::parse(text, source_name);
  } catch (const toml::parse_error& e) {
    std::ostringstream s;
    s << "line " << e.source().begin.line << ", column " << e.source().begin.column;
    throw InputError(source_name, s.str(), std::string("TOML syntax error: ") + std::string(e.description()));
  }
}

toml::table load_scene(const std::filesystem::path& path) {
  try {
    return toml::parse_file(path.string());
  } catch (const toml::parse_error& e) {
    std::ostringstream s;
    s << "line " << e.source().begin.line << ", column " << e.source().begin.column;
    if (!std::filesystem::exists(path)) throw InputError("scene", path.string(), "file not found");
    throw InputError(path.string(), s.str(), std::string("TOML syntax error: ") + std::string(e.description()));
  }
}

double get_number(const toml::table& table, const std::string& key, const std::string& path) {
  const toml::node* node = table.get(key);
  if (!node) throw InputError(join(path, key), "", "missing");
  return as_number(*node, join(path, key));
}

double get_number_or(const toml::table& table, const std::string& key, const std::string& path, double fallback) {
  return table.contains(key) ? get_number(table, key, path) : fallback;
}

std::string get_string_or(const toml::table& table, const std::string& key, const std::string& path,
                          const std::string& fallback) {
  const toml::node* node = table.get(key);
  if (!node) return fallback;
  if (auto s = node->value<std::string>()) return *s;
  throw InputError(join(path, key), show(*node), "must be a string");
}

bool get_bool_or(const toml::table& table, const std::string& key, const std::string& path, bool fallback) {
  const toml::node* node = table.get(key);
  if (!node) return fallback;
  if (auto b = node->value<bool>()) return *b;
  throw InputError(join(path, key), show(*node), "must be true or false");
}

void check_keys(const toml::table& table, const std::string& path, std::initializer_list<std::string_view> allowed) {
  for (const auto& [key, node] : table) {
    if (std::find(allowed.begin(), allowed.end(), key.str()) == allowed.end()) {
      std::string list;
      for (auto a : allowed) list += (list.empty() ? "" : ", ") + std::string(a);
      throw InputError(join(path, std::string(key.str())), show(node), "unknown key (allowed: " + list + ")");
    }
  }
}

MaterialSpec parse_material(const toml::table& t, const std::string& path) {
  check_keys(t, path, {"preset", "law", "G", "Jm", "K", "mu", "E", "nu", "C1", "C2", "C3", "alpha", "k1", "k2",
                       "kappa", "fiber_invariant", "tension_only", "fibers", "viscoelastic", "form"});
  MaterialSpec s;
  s.field_prefix = path;
  const std::string preset = get_string_or(t, "preset", path, "");
  double k1 = 0.0, k2 = 0.0;
  if (!preset.empty()) {
    s = preset_spec(preset, path);
    if (!s.gent.fibers.empty()) {  // an anisotropic set: its k1, k2 are defaults for the scene's families
      k1 = s.gent.fibers.front().k1;
      k2 = s.gent.fibers.front().k2;
      s.gent.fibers.clear();
    }
  }
  const std::string law = get_string_or(t, "law", path, preset.empty() ? "" : "");
  if (!law.empty()) {
    LawKind kind;
    if (law == "gent" || law == "gent-hgo") kind = LawKind::gent_hgo;
    else if (law == "neo-hookean") kind = LawKind::neo_hookean;
    else if (law == "yeoh") kind = LawKind::yeoh;
    else if (law == "ogden") kind = LawKind::ogden;
    else throw InputError(join(path, "law"), law, "unknown law (gent, neo-hookean, yeoh, ogden)");
    if (!preset.empty() && kind != s.law)
      throw InputError(join(path, "law"), law, "contradicts preset '" + preset + "'");
    s.law = kind;
  } else if (preset.empty()) {
    throw InputError(join(path, "law"), "", "missing: give law = \"gent\" | \"neo-hookean\" | \"yeoh\" | \"ogden\" or a preset");
  }

  auto reject = [&](std::initializer_list<const char*> keys, const char* law_name) {
    for (const char* k : keys)
      if (t.contains(k)) throw InputError(join(path, k), show(*t.get(k)), std::string("not a parameter of the ") + law_name + " law");
  };
  switch (s.law) {
    case LawKind::gent_hgo:
      reject({"mu", "E", "nu", "C1", "C2", "C3", "alpha", "form"}, "Gent-HGO");
      s.gent.G = get_number_or(t, "G", path, s.gent.G);
      s.gent.Jm = get_number_or(t, "Jm", path, s.gent.Jm);
      s.gent.K = get_number_or(t, "K", path, s.gent.K);
      break;
    case LawKind::neo_hookean:
      reject({"G", "Jm", "C1", "C2", "C3", "alpha"}, "neo-Hookean");
      if (t.contains("E") || t.contains("nu")) {
        if (t.contains("mu") || t.contains("K"))
          throw InputError(join(path, "E"), show(*t.get(t.contains("E") ? "E" : "nu")), "give either (E, nu) or (mu, K)");
        const double E = get_number(t, "E", path), nu = get_number(t, "nu", path);
        if (!(E > 0.0)) throw InputError(join(path, "E"), std::to_string(E), "Young's modulus must be > 0");
        if (!(nu > -1.0 && nu < 0.5)) throw InputError(join(path, "nu"), std::to_string(nu), "Poisson's ratio must lie in (-1, 0.5)");
        s.neo_hookean = NeoHookeanParams::from_young(E, nu);
      }
      s.neo_hookean.mu = get_number_or(t, "mu", path, s.neo_hookean.mu);
      s.neo_hookean.K = get_number_or(t, "K", path, s.neo_hookean.K);
      if (t.contains("form")) {  // energy form (laws.hpp NeoHookeanForm); "lame-log" = FANS's law
        const std::string form = get_string_or(t, "form", path, "isochoric");
        if (form == "isochoric") s.neo_hookean.form = NeoHookeanForm::isochoric;
        else if (form == "lame-log") s.neo_hookean.form = NeoHookeanForm::lame_log;
        else throw InputError(join(path, "form"), form, "isochoric or lame-log");
      }
      break;
    case LawKind::yeoh:
      reject({"G", "Jm", "mu", "E", "nu", "alpha", "form"}, "Yeoh");
      s.yeoh.C1 = get_number_or(t, "C1", path, s.yeoh.C1);
      s.yeoh.C2 = get_number_or(t, "C2", path, s.yeoh.C2);
      s.yeoh.C3 = get_number_or(t, "C3", path, s.yeoh.C3);
      s.yeoh.K = get_number_or(t, "K", path, s.yeoh.K);
      break;
    case LawKind::ogden:
      reject({"G", "Jm", "E", "nu", "C1", "C2", "C3", "form"}, "Ogden");
      if (t.contains("mu")) s.ogden.mu = as_numbers(*t.get("mu"), join(path, "mu"));
      if (t.contains("alpha")) s.ogden.alpha = as_numbers(*t.get("alpha"), join(path, "alpha"));
      s.ogden.K = get_number_or(t, "K", path, s.ogden.K);
      break;
  }

  // Fiber families (Gent-HGO only).
  k1 = get_number_or(t, "k1", path, k1);
  k2 = get_number_or(t, "k2", path, k2);
  const double kappa = get_number_or(t, "kappa", path, 0.0);  // GOH dispersion, default for every family
  if (const toml::node* fibers = t.get("fibers")) {
    if (s.law != LawKind::gent_hgo) throw InputError(join(path, "fibers"), "", "fiber families need law = \"gent\"");
    const auto* arr = fibers->as_array();
    if (!arr) throw InputError(join(path, "fibers"), show(*fibers), "must be an array of tables ([[...fibers]])");
    for (std::size_t i = 0; i < arr->size(); ++i) {
      const std::string fp = join(path, "fibers[" + std::to_string(i) + "]");
      const auto* ft = arr->get(i)->as_table();
      if (!ft) throw InputError(fp, show(*arr->get(i)), "must be a table");
      check_keys(*ft, fp, {"direction", "angle_deg", "k1", "k2", "kappa"});
      FiberFamily f;
      if (ft->contains("direction") == ft->contains("angle_deg"))
        throw InputError(fp, "", "give exactly one of direction = [x, y, z] or angle_deg (spec §7: from e2 toward e1)");
      if (ft->contains("direction")) {
        f.direction = as_vec3(*ft->get("direction"), fp + ".direction");
      } else {
        const double a = get_number(*ft, "angle_deg", fp) * std::numbers::pi / 180.0;
        f.direction = Vec3(std::sin(a), std::cos(a), 0.0);
      }
      f.k1 = get_number_or(*ft, "k1", fp, k1);
      f.k2 = get_number_or(*ft, "k2", fp, k2);
      f.kappa = get_number_or(*ft, "kappa", fp, kappa);
      s.gent.fibers.push_back(f);
    }
  }
  if (s.law == LawKind::gent_hgo && s.gent.fibers.empty() && k1 > 0.0 && !preset.empty())
    throw InputError(join(path, "fibers"), "", "preset '" + preset + "' is anisotropic: give at least one [[" + path + ".fibers]] family");
  if (!s.gent.fibers.empty()) {
    const std::string inv = get_string_or(t, "fiber_invariant", path, "");
    if (inv == "full") s.gent.invariant = FiberInvariant::full;
    else if (inv == "isochoric") s.gent.invariant = FiberInvariant::isochoric;
    else if (inv.empty())
      throw InputError(join(path, "fiber_invariant"), "", "required with fibers: \"full\" (recommended, spec §2) or \"isochoric\"");
    else throw InputError(join(path, "fiber_invariant"), inv, "must be \"full\" or \"isochoric\"");
    if (const toml::node* to = t.get("tension_only")) {
      if (auto b = to->value<bool>()) s.gent.tension_only = *b;
      else throw InputError(join(path, "tension_only"), show(*to), "must be true or false");
    }
  }

  if (const toml::node* ve = t.get("viscoelastic")) {
    const std::string vp = join(path, "viscoelastic");
    const auto* vt = ve->as_table();
    if (!vt) throw InputError(vp, show(*ve), "must be a table");
    check_keys(*vt, vp, {"g_inf", "tau", "terms"});
    PronySeries pr;
    pr.g_inf = get_number(*vt, "g_inf", vp);
    if (vt->contains("terms")) {
      if (vt->contains("tau")) throw InputError(join(vp, "tau"), "", "give either tau (one term) or terms");
      const auto* arr = vt->get("terms")->as_array();
      if (!arr) throw InputError(join(vp, "terms"), "", "must be an array of {g, tau} tables");
      for (std::size_t k = 0; k < arr->size(); ++k) {
        const std::string tp = join(vp, "terms[" + std::to_string(k) + "]");
        const auto* tt = arr->get(k)->as_table();
        if (!tt) throw InputError(tp, show(*arr->get(k)), "must be a table {g = ..., tau = ...}");
        check_keys(*tt, tp, {"g", "tau"});
        pr.terms.push_back({get_number(*tt, "g", tp), get_number(*tt, "tau", tp)});
      }
    } else {
      // One term: g = 1 − g∞ (dissertation eq. 2.36).
      pr.terms.push_back({1.0 - pr.g_inf, get_number(*vt, "tau", vp)});
    }
    s.prony = pr;
  }
  validate(s);
  return s;
}

MixedControl parse_load(const toml::table& t, const std::string& path) {
  const std::string type = get_string_or(t, "type", path, "");
  MixedControl c;
  Mat3 frame = Mat3::Identity();
  if (t.contains("direction") || t.contains("in_plane")) {
    const Vec3 d = t.contains("direction") ? as_vec3(*t.get("direction"), join(path, "direction")) : Vec3::UnitX();
    const Vec3 p = t.contains("in_plane") ? as_vec3(*t.get("in_plane"), join(path, "in_plane")) : Vec3::UnitY();
    if (!(d.norm() > 1e-12)) throw InputError(join(path, "direction"), "[0, 0, 0]", "must be a non-zero vector");
    frame = load_frame(d, p);
  }
  std::vector<double> breaks;
  if (type == "uniaxial" || type == "equibiaxial" || type == "pure_shear") {
    check_keys(t, path, {"type", "direction", "in_plane", "stretch", "duration", "hold", "steps", "dt"});
    const PiecewiseLinear stretch = as_path(t, "stretch", path, 1.0);
    for (std::size_t k = 0; k < stretch.v.size(); ++k)
      if (!(stretch.v[k] > 0.0))
        throw InputError(join(path, "stretch"), std::to_string(stretch.v[k]), "stretches must be > 0");
    if (type == "uniaxial") c = uniaxial_control(stretch, frame.col(0), frame.col(1));
    else if (type == "equibiaxial") c = equibiaxial_control(stretch, frame);
    else c = pure_shear_control(stretch, frame);
    breaks = stretch.t;
  } else if (type == "simple_shear") {
    check_keys(t, path, {"type", "direction", "in_plane", "gamma", "duration", "hold", "steps", "dt"});
    const PiecewiseLinear gamma = as_path(t, "gamma", path, 0.0);
    c = simple_shear_control(gamma, frame);
    breaks = gamma.t;
  } else if (type == "mixed") {
    check_keys(t, path, {"type", "direction", "in_plane", "F", "P", "path", "steps", "dt"});
    const PiecewiseLinear factor = as_path(t, "path", path, 0.0);
    const auto* Fa = t.get("F") ? t.get("F")->as_array() : nullptr;
    if (!Fa || Fa->size() != 3) throw InputError(join(path, "F"), "", "must be a 3x3 array of numbers or \"free\"");
    c.frame = frame;
    c.name = "mixed";
    const auto* Pa = t.get("P") ? t.get("P")->as_array() : nullptr;
    for (int i = 0; i < 3; ++i) {
      const auto* row = Fa->get(std::size_t(i))->as_array();
      if (!row || row->size() != 3) throw InputError(join(path, "F[" + std::to_string(i) + "]"), "", "must be a row of 3 entries");
      for (int j = 0; j < 3; ++j) {
        const std::string f = join(path, "F[" + std::to_string(i) + "][" + std::to_string(j) + "]");
        const toml::node& e = *row->get(std::size_t(j));
        const int k = voigt9(i, j);
        if (auto s = e.value<std::string>()) {
          if (*s != "free") throw InputError(f, *s, "must be a number or \"free\"");
          c.kind[k] = ControlKind::stress;
          double target = 0.0;
          if (Pa) {
            const auto* prow = Pa->size() == 3 ? Pa->get(std::size_t(i))->as_array() : nullptr;
            if (!prow || prow->size() != 3) throw InputError(join(path, "P"), "", "must be a 3x3 array of numbers");
            target = as_number(*prow->get(std::size_t(j)), join(path, "P[" + std::to_string(i) + "][" + std::to_string(j) + "]"));
          }
          PiecewiseLinear p = factor;
          for (auto& v : p.v) v *= target;
          c.value[k] = p;
        } else {
          const double final_value = as_number(e, f);
          c.kind[k] = ControlKind::deformation;
          const double start = i == j ? 1.0 : 0.0;
          PiecewiseLinear p = factor;
          for (auto& v : p.v) v = start + v * (final_value - start);
          c.value[k] = p;
        }
      }
    }
    breaks = factor.t;
  } else {
    throw InputError(join(path, "type"), type, "must be uniaxial, equibiaxial, pure_shear, simple_shear or mixed");
  }
  c.times = output_times(t, path, breaks);
  c.validate();
  return c;
}

}  // namespace softhom::io
