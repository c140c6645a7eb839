// Load tables declared key by key: the control type, its path and the output steps.
#include <algorithm>
#include <cmath>
#include <optional>

#include "softhom/materials/errors.hpp"
#include "softhom/materials/scene_keys.hpp"

namespace softhom {
namespace {

enum class LoadType { uniaxial, equibiaxial, pure_shear, simple_shear, mixed };

struct LoadKeys {
  LoadType type = LoadType::uniaxial;
  std::vector<double> direction{1.0, 0.0, 0.0};
  std::vector<double> in_plane{0.0, 1.0, 0.0};
  const toml::node* stretch = nullptr;
  const toml::node* gamma = nullptr;
  const toml::node* path = nullptr;
  const toml::node* F = nullptr;
  const toml::node* P = nullptr;
  double duration = 1.0;
  double hold = 0.0;
  int steps = 50;
  std::optional<double> dt;
};

const keys::Choices<LoadType>& type_choices() {
  static const keys::Choices<LoadType> c{{{"uniaxial", LoadType::uniaxial},
                                        {"equibiaxial", LoadType::equibiaxial},
                                        {"pure-shear", LoadType::pure_shear},
                                        {"simple-shear", LoadType::simple_shear},
                                        {"mixed", LoadType::mixed}},
                                       {{"pure_shear", "pure-shear"}, {"simple_shear", "simple-shear"}}};
  return c;
}

const keys::KeyTable<LoadKeys>& load_keys() {
  using L = LoadKeys;
  static const keys::KeyTable<LoadKeys> t = [] {
    keys::KeyTable<LoadKeys> k("load", "the macroscopic load path (mixed deformation/stress control, load frame)");
    auto node_of = [](const toml::node* L::*member) {
      return [member](const toml::node& n, const std::string&, L& l) { l.*member = &n; };
    };
    k.choice("type", &L::type, type_choices(), "control type").required()
        .numbers("direction", &L::direction, keys::any_value(), 3, 3, "-", "load axis e1' of the load frame (non-zero)")
        .numbers("in_plane", &L::in_plane, keys::any_value(), 3, 3, "-", "second axis of the load frame (orthogonalised)")
        .custom("stretch", "number or [[t, λ], ...]", "uniaxial/equibiaxial/pure-shear: stretch path (a number: linear ramp from 1 over duration; pairs: times from 0, increasing)",
                node_of(&L::stretch), "required for these types", "> 0")
        .custom("gamma", "number or [[t, γ], ...]", "simple-shear: shear path (a number: ramp from 0 over duration)",
                node_of(&L::gamma), "required for simple-shear")
        .custom("F", "3x3 of numbers or \"free\"", "mixed: final deformation gradient entries; \"free\" = stress-controlled",
                node_of(&L::F), "required for mixed")
        .custom("P", "3x3 of numbers", "mixed: final first Piola-Kirchhoff stress of the free entries", node_of(&L::P), "0", "", "MPa")
        .custom("path", "number or [[t, s], ...]", "mixed: load factor path from 0 to 1 (F, P scale with it)", node_of(&L::path),
                "required for mixed")
        .number("duration", &L::duration, keys::above(0.0), "s", "ramp time of a scalar stretch or gamma")
        .number("hold", &L::hold, keys::at_least(0.0), "s", "hold time after a scalar ramp")
        .integer("steps", &L::steps, keys::closed_range(1.0, kMaxOutputSteps), "-",
                 "uniform output steps over the path (at most 1e6: each is a converged solve and a response row; finer resolution is the solver's cut-backs)")
        .number("dt", &L::dt, keys::above(0.0), "s", "output step length instead of steps (at most 1e6 steps)");
    return k;
  }();
  return t;
}

/// [[t0, v0], [t1, v1], ...] (t from 0, strictly increasing, finite), or a number v reached by a linear
/// ramp from `start` over `duration` (then a `hold`).
PiecewiseLinear as_path(const toml::node& node, const std::string& field, const LoadKeys& k, bool ramp_keys, double start) {
  PiecewiseLinear f;
  f.t.clear();
  f.v.clear();
  if (const auto* arr = node.as_array(); arr && arr->size() > 0 && arr->get(0)->is_array()) {
    for (std::size_t i = 0; i < arr->size(); ++i) {
      const std::string fi = keys::index_field(field, i);
      const std::vector<double> pair = keys::read_numbers(*arr->get(i), fi, keys::any_value(), 2, 2);
      const toml::node& tn = *arr->get(i)->as_array()->get(0);
      if (f.t.empty() && pair[0] != 0.0) throw InputError(fi + "[0]", keys::describe_value(tn), "a load path starts at t = 0");
      if (!f.t.empty() && !(pair[0] > f.t.back()))
        throw InputError(fi + "[0]", keys::describe_value(tn), "times must be strictly increasing");
      f.t.push_back(pair[0]);
      f.v.push_back(pair[1]);
    }
    if (f.t.size() < 2) throw InputError(field, keys::describe_value(node), "a load path needs at least two points");
    return f;
  }
  if (node.is_array()) throw InputError(field, keys::describe_value(node), "must be a number or a list of [time, value] pairs");
  const double target = keys::read_number(node, field);
  const double duration = ramp_keys ? k.duration : 1.0;
  f.t = {0.0, duration};
  f.v = {start, target};
  if (ramp_keys && k.hold > 0.0) {
    f.t.push_back(duration + k.hold);
    f.v.push_back(target);
  }
  return f;
}

/// Output times: `steps` uniform steps or a step `dt`, merged with the path's breakpoints (so a
/// ramp–hold kink is always a step boundary).
std::vector<double> output_times(const LoadKeys& k, const std::string& path, const std::vector<double>& breaks) {
  const double end = breaks.back();
  std::vector<double> times;
  if (k.dt) {
    const double dt = *k.dt;
    if (end / dt > kMaxOutputSteps)
      throw InputError(keys::join_key(path, "dt"), format_number(dt), "more than 1e6 output steps over the path (t_end = " + format_number(end) + ")");
    for (double t = dt; t < end * (1.0 - 1e-12); t += dt) times.push_back(t);
  } else {
    for (int s = 1; s < k.steps; ++s) times.push_back(end * (double(s) / k.steps));  // end * s overflowed near 1e308
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

/// Output times that underflow to 0 or overflow to inf come from keys the scene gave: the message names
/// the key (duration, hold, dt, else steps) with its value as written, not a derived load.times[i].
void check_time_scale(const std::vector<double>& times, double end, const std::set<std::string>& present,
                      const LoadKeys& k, const std::string& path) {
  bool ok = !times.empty() && times.front() > 0.0 && std::isfinite(end);
  for (std::size_t i = 0; ok && i < times.size(); ++i) ok = std::isfinite(times[i]) && (i == 0 || times[i] > times[i - 1]);
  if (ok) return;
  const std::string why = "gives output times from " + format_number(times.front()) + " to " + format_number(times.back()) +
                          " over a path ending at t = " + format_number(end) + ": a step must be a positive, finite time";
  if (present.count("duration")) throw InputError(keys::join_key(path, "duration"), format_number(k.duration), why);
  if (present.count("hold")) throw InputError(keys::join_key(path, "hold"), format_number(k.hold), why);
  if (k.dt) throw InputError(keys::join_key(path, "dt"), format_number(*k.dt), why);
  throw InputError(keys::join_key(path, "steps"), std::to_string(k.steps), why);
}

/// Keys that belong to other load types are refused (a typo'd type must not ignore its path).
void refuse_foreign(const std::set<std::string>& present, const std::string& path, const std::string& type,
                    std::initializer_list<const char*> foreign) {
  for (const char* key : foreign)
    if (present.count(key)) throw InputError(keys::join_key(path, key), "", "not a key of load type \"" + type + "\"");
}

Vec3 vec3(const std::vector<double>& v) { return Vec3(v[0], v[1], v[2]); }

/// A stress target P[i][j] where F[i][j] is prescribed (a number) cannot act: it was ignored. Zero, the
/// filler of a full P matrix, is accepted; anything else is refused naming the P entry.
void refuse_stress_at_prescribed(const toml::array* Pa, const std::string& p_key, int i, int j, const std::string& f_field) {
  if (!Pa) return;
  const std::string pi = keys::index_field(p_key, std::size_t(i));
  const toml::array* row = Pa->get(std::size_t(i)) ? Pa->get(std::size_t(i))->as_array() : nullptr;
  if (!row || !row->get(std::size_t(j))) return;  // the row's own shape is checked where it is read
  const toml::node& e = *row->get(std::size_t(j));
  const std::string field = keys::index_field(pi, std::size_t(j));
  const auto* integer = e.as_integer();
  const auto* floating = e.as_floating_point();
  if ((integer && integer->get() == 0) || (floating && floating->get() == 0.0)) return;
  throw InputError(field, keys::describe_value(e),
                   "a stress target applies to a \"free\" entry of F only; " + f_field +
                       " is prescribed (give 0 here, or \"free\" there)");
}

MixedControl mixed_control(const toml::table& t, const LoadKeys& k, const std::string& path, const Mat3& frame,
                           std::vector<double>& breaks) {
  if (!k.path) throw InputError(keys::join_key(path, "path"), "", "missing: the load factor path of a mixed load");
  const PiecewiseLinear factor = as_path(*k.path, keys::join_key(path, "path"), k, false, 0.0);
  if (!k.F) throw InputError(keys::join_key(path, "F"), "", "missing: a 3x3 array of numbers or \"free\"");
  const toml::array& Fa = keys::read_array(*k.F, keys::join_key(path, "F"));
  if (Fa.size() != 3) throw InputError(keys::join_key(path, "F"), keys::describe_value(*k.F), "must be a 3x3 array of numbers or \"free\"");
  const toml::array* Pa = k.P ? &keys::read_array(*k.P, keys::join_key(path, "P")) : nullptr;
  if (Pa && Pa->size() != 3) throw InputError(keys::join_key(path, "P"), keys::describe_value(*k.P), "must be a 3x3 array of numbers");
  MixedControl c;
  c.frame = frame;
  c.name = "mixed";
  for (int i = 0; i < 3; ++i) {
    const std::string fi = keys::index_field(keys::join_key(path, "F"), std::size_t(i));
    const toml::array& row = keys::read_array(*Fa.get(std::size_t(i)), fi);
    if (row.size() != 3) throw InputError(fi, keys::describe_value(*Fa.get(std::size_t(i))), "must be a row of 3 entries");
    for (int j = 0; j < 3; ++j) {
      const std::string f = keys::index_field(fi, std::size_t(j));
      const toml::node& e = *row.get(std::size_t(j));
      const int kk = voigt9(i, j);
      PiecewiseLinear p = factor;
      if (e.is_string()) {
        if (keys::read_text(e, f) != "free") throw InputError(f, keys::describe_value(e), "must be a number or \"free\"");
        c.kind[kk] = ControlKind::stress;
        double target = 0.0;
        if (Pa) {
          const std::string pi = keys::index_field(keys::join_key(path, "P"), std::size_t(i));
          const toml::array& prow = keys::read_array(*Pa->get(std::size_t(i)), pi);
          if (prow.size() != 3) throw InputError(pi, keys::describe_value(*Pa->get(std::size_t(i))), "must be a row of 3 numbers");
          target = keys::read_number(*prow.get(std::size_t(j)), keys::index_field(pi, std::size_t(j)));
        }
        for (auto& v : p.v) v *= target;
      } else {
        const double final_value = keys::read_number(e, f);
        refuse_stress_at_prescribed(Pa, keys::join_key(path, "P"), i, j, f);
        c.kind[kk] = ControlKind::deformation;
        const double start = i == j ? 1.0 : 0.0;
        for (auto& v : p.v) v = start + v * (final_value - start);
      }
      c.value[kk] = p;
    }
  }
  (void)t;
  breaks = factor.t;
  return c;
}

}  // namespace

MixedControl parse_load(const toml::table& t, const std::string& path) {
  LoadKeys k;
  const std::set<std::string> present = load_keys().read(t, path, k);
  const std::string type = type_choices().name_of(k.type);
  if (present.count("dt") && present.count("steps"))
    throw InputError(keys::join_key(path, "dt"), format_number(*k.dt), "give either steps or dt");
  Mat3 frame = Mat3::Identity();
  if (present.count("direction") || present.count("in_plane")) {
    if (!(vec3(k.direction).norm() > 1e-12))
      throw InputError(keys::join_key(path, "direction"), keys::describe_value(*t.get("direction")), "must be a non-zero vector");
    const Vec3 d = vec3(k.direction), q = vec3(k.in_plane);
    // An in_plane given along the direction cannot set the second axis (one was picked silently).
    if (present.count("in_plane") && !((q - q.dot(d.normalized()) * d.normalized()).norm() > 1e-9 * q.norm()))
      throw InputError(keys::join_key(path, "in_plane"), keys::describe_value(*t.get("in_plane")),
                       "is parallel to direction [" + format_number(d.x()) + ", " + format_number(d.y()) + ", " +
                           format_number(d.z()) + "]" +
                           " (or zero): it must have a component across the load direction");
    frame = load_frame(d, q);
  }
  MixedControl c;
  std::vector<double> breaks;
  switch (k.type) {
    case LoadType::uniaxial:
    case LoadType::equibiaxial:
    case LoadType::pure_shear: {
      refuse_foreign(present, path, type, {"gamma", "F", "P", "path"});
      if (!k.stretch) throw InputError(keys::join_key(path, "stretch"), "", "missing: the stretch path");
      const PiecewiseLinear stretch = as_path(*k.stretch, keys::join_key(path, "stretch"), k, true, 1.0);
      for (double v : stretch.v)
        if (!(v > 0.0)) throw InputError(keys::join_key(path, "stretch"), format_number(v), "stretches must be > 0");
      if (k.type == LoadType::uniaxial) c = uniaxial_control(stretch, frame.col(0), frame.col(1));
      else if (k.type == LoadType::equibiaxial) c = equibiaxial_control(stretch, frame);
      else c = pure_shear_control(stretch, frame);
      breaks = stretch.t;
      break;
    }
    case LoadType::simple_shear: {
      refuse_foreign(present, path, type, {"stretch", "F", "P", "path"});
      if (!k.gamma) throw InputError(keys::join_key(path, "gamma"), "", "missing: the shear path");
      const PiecewiseLinear gamma = as_path(*k.gamma, keys::join_key(path, "gamma"), k, true, 0.0);
      c = simple_shear_control(gamma, frame);
      breaks = gamma.t;
      break;
    }
    case LoadType::mixed:
      refuse_foreign(present, path, type, {"stretch", "gamma", "duration", "hold"});
      c = mixed_control(t, k, path, frame, breaks);
      break;
  }
  c.times = output_times(k, path, breaks);
  check_time_scale(c.times, breaks.back(), present, k, path);
  c.validate();
  return c;
}

std::vector<keys::TableDoc> load_tables(const std::string& path) {
  keys::TableDoc d = load_keys().describe();
  d.path = path;
  return {d};
}

}  // namespace softhom
