// Sweep campaigns: the campaign definition (campaign.hpp) expanded into validated RVE scenes, one per
// case. Every key is declared once (campaign_keys()); every definition is validated, used or not.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <set>
#include <sstream>

#include "softhom/core/keys.hpp"
#include "softhom/io/scene.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/studies/campaign.hpp"
#include "softhom/studies/campaign_definition.hpp"
#include "softhom/studies/rve_fe_scene.hpp"
#include "softhom/studies/rve_scene.hpp"

namespace softhom::studies {
namespace {
/// Numbers in case ids and CSV parameters: 10 significant digits (ids are store keys: keep stable).
std::string parameter_text(double v) {
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
    // Names become case ids, HDF5 group names and CSV cells: no NUL or control characters.
    const std::string s = keys::read_text(node, field);
    if (s.empty()) throw InputError(field, keys::describe_value(node), "must be a name (string)");
    a.v = s;
    return a;
  }
  if (axis == "resolution") {
    // The same entry range as microstructure.grid (keys::read_int refuses fractions and overflow).
    const keys::Range entries = keys::closed_range(1, 65536);
    if (node.is_array()) a.grid = keys::read_ints<int>(node, field, entries, 2, 3);
    else a.grid = {keys::read_int<int>(node, field, entries), 0};
    if (a.grid.size() == 2 && a.grid[1] == 0) a.grid[1] = a.grid[0];
    a.v = double(a.grid[0]);
    return a;
  }
  const auto d = node.value<double>();
  if (!d || !std::isfinite(*d)) throw InputError(field, keys::describe_value(node), "must be a number");
  if (axis == "volume_fraction" && !(*d >= 0.0 && *d < 1.0)) throw InputError(field, keys::describe_value(node), "must lie in [0, 1)");
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
      throw InputError(path + "." + key, "",
                       "unknown axis" + keys::did_you_mean(key, axes) +
                           " (matrix, section, angle, volume_fraction, arrangement, resolution, load)");
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
  std::string s = parameter_text(v);
  return s;
}

/// One value per axis of a case, the base scene's where the case gives none.
struct CaseAxes {
  std::string matrix, load, section, arrangement;
  double vf = 0.0, angle = 0.0;
  std::vector<int> grid{32, 32};
  bool base_section = false;  // no section axis: the base scene's section is kept
  bool matrix_only = false;   // volume fraction 0: the homogeneous cell
};

CaseAxes case_axes(const Definitions& defs, const std::map<std::string, AxisValue>& values, const std::string& field) {
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
  CaseAxes a;
  a.matrix = std::get<std::string>(get("matrix")->v);
  a.load = std::get<std::string>(get("load")->v);
  a.vf = get("volume_fraction") ? std::get<double>(get("volume_fraction")->v) : base_number("volume_fraction", 0.23);
  a.angle = get("angle") ? std::get<double>(get("angle")->v) : base_number("fiber_angle_deg", 45.0);
  // Without a section axis the base scene's section is kept (named after its shape), else "circle".
  a.base_section = !get("section") && base_micro && base_micro->contains("shape");
  a.section = get("section") ? std::get<std::string>(get("section")->v) : base_string("shape", "circle");
  a.arrangement = get("arrangement") ? std::get<std::string>(get("arrangement")->v) : base_string("arrangement", "square");
  if (get("resolution")) a.grid = get("resolution")->grid;
  else if (base_micro && (*base_micro)["grid"]) {
    const toml::node& g = *(*base_micro)["grid"].node();
    const keys::Range entries = keys::closed_range(1, 65536);
    if (g.is_array()) a.grid = keys::read_ints<int>(g, "base.microstructure.grid", entries, 2, 3);
    else a.grid.assign(2, keys::read_int<int>(g, "base.microstructure.grid", entries));
  }
  a.matrix_only = a.vf == 0.0;
  if (a.matrix_only) {
    // The homogeneous cell does not depend on these: one case per matrix, resolution and load.
    a.section = "none";
    a.arrangement = "none";
    a.angle = 0.0;
  }
  return a;
}

/// The case's [microstructure]: its section (unless the base scene's is kept), arrangement, angle,
/// volume fraction and grid.
void set_microstructure(toml::table& scene, const Definitions& defs, const CaseAxes& a, const std::string& field) {
  toml::table& micro = subtable(scene, "microstructure");
  if (!a.matrix_only) {
    if (!a.base_section) {
      toml::table sec;
      if (const auto it = defs.sections.find(a.section); it != defs.sections.end()) sec = it->second;
      else sec = builtin_section(a.section);
      if (sec.empty())
        throw InputError(field + ".section", a.section,
                         "not defined: add [sections." + a.section + "] or use circle, square");
      for (const char* k : {"shape", "radius", "width", "height", "section_rotation_deg", "fiber_count", "min_gap", "seed"})
        micro.erase(k);
      merge_into(micro, sec);
    }
    micro.insert_or_assign("arrangement", a.arrangement);
    micro.insert_or_assign("fiber_angle_deg", a.angle);
  } else {
    for (const char* k : {"shape", "radius", "width", "height", "section_rotation_deg", "fiber_count", "min_gap", "seed",
                          "arrangement", "cell_size"})
      micro.erase(k);
    micro.insert_or_assign("fiber_angle_deg", 0.0);
  }
  micro.insert_or_assign("volume_fraction", a.vf);
  toml::array g;
  for (int n : a.grid) g.push_back(n);
  micro.insert_or_assign("grid", g);
}

/// The case's [phases] (the matrix by definition or preset, glass fibers unless the base gives some)
/// and [load] (by definition or built in).
void set_phases_and_load(toml::table& scene, const Definitions& defs, const CaseAxes& a, const std::string& field) {
  toml::table& phases = subtable(scene, "phases");
  if (const auto it = defs.matrices.find(a.matrix); it != defs.matrices.end()) phases.insert_or_assign("matrix", it->second);
  else phases.insert_or_assign("matrix", toml::table{{"preset", a.matrix}});
  if (!phases.contains("fiber")) phases.insert_or_assign("fiber", toml::table{{"preset", "glass"}});
  if (const auto it = defs.loads.find(a.load); it != defs.loads.end()) scene.insert_or_assign("load", it->second);
  else if (toml::table l = builtin_load(a.load); !l.empty()) scene.insert_or_assign("load", l);
  else
    throw InputError(field + ".load", a.load,
                     "not defined: add [loads." + a.load + "] or use tension, compression, equibiaxial, shear, relaxation");
}

/// The case id: its name, else made of its axis values (characters unsafe in paths and CSV replaced);
/// `with_grid`: the resolution, which only the FFT engine has.
std::string case_id(const CaseAxes& a, const std::string& name, bool with_grid) {
  std::string id_text;
  if (!name.empty()) {
    id_text = name;
  } else {
    std::ostringstream id;
    id << a.matrix << "-";
    if (a.matrix_only) id << "matrix";
    else id << a.section << "-a" << id_number(a.angle) << "-vf" << id_number(a.vf) << "-" << a.arrangement;
    if (with_grid) {
      id << "-n" << a.grid[0];
      for (std::size_t k = 1; k < a.grid.size(); ++k) id << "x" << a.grid[k];
    }
    id << "-" << a.load;
    id_text = id.str();
  }
  for (char& ch : id_text)
    if (ch == '/' || ch == ' ' || ch == ',' || ch == '"') ch = '_';
  return id_text;
}

/// What the campaign keeps of a case scene, parsed as `softhom rve` parses it with the tables of its
/// engine (every key checked, nothing meshed or planned).
struct CaseScene {
  std::string engine;
  MixedControl control;
  bool elastic = true;
};

bool without_history(const MaterialPtr& matrix, const MaterialPtr& fiber) {
  return matrix->state_size() == 0 && (!fiber || fiber->state_size() == 0);
}

CaseScene parse_case_scene(const toml::table& scene) {
  CaseScene c;
  c.engine = rve_scene_engine(scene);
  if (c.engine == "auto")
    throw InputError("solver.engine", "\"auto\"",
                     "a campaign case runs the engine it names, \"fft\" or \"fe\", at the resolution it gives "
                     "(the cases of a campaign are compared with each other)");
  if (c.engine == "fe") {
    const FeRveSetup setup = parse_fe_rve_setup(scene, true);
    (void)parse_rve_output(scene, &setup.control);
    c.control = setup.control;
    c.elastic = without_history(setup.phases.matrix, setup.phases.fiber);
  } else {
    const RveSceneSetup setup = parse_rve_scene(scene);
    c.control = setup.control;
    c.elastic = without_history(setup.matrix, setup.fiber);
  }
  return c;
}

/// Builds one case from one value per axis.
CampaignCase make_case(const Definitions& defs, const std::map<std::string, AxisValue>& values, const std::string& name,
                       const toml::table* override_table, const std::string& field, const std::string& context = "") {
  const CaseAxes a = case_axes(defs, values, field);
  CampaignCase c;
  c.parameters = {{"matrix", a.matrix},           {"section", a.section},
                  {"angle", a.angle},             {"volume_fraction", a.vf},
                  {"arrangement", a.arrangement}, {"resolution", double(a.grid[0])},
                  {"load", a.load}};
  toml::table scene = defs.base;
  scene.erase("output");
  set_microstructure(scene, defs, a, field);
  set_phases_and_load(scene, defs, a, field);
  if (override_table) merge_into(scene, *override_table);
  // Validate the scene exactly as `softhom rve` would (errors name the case).
  try {
    c.id = case_id(a, name, rve_scene_engine(scene) != "fe");
    CaseScene parsed = parse_case_scene(scene);
    c.engine = parsed.engine;
    c.control = std::move(parsed.control);
    c.elastic = parsed.elastic;
  } catch (const InputError& e) {
    const std::string id = c.id.empty() ? case_id(a, name, true) : c.id;
    throw InputError((context.empty() ? "case " + id : context) + ": " + e.field(), e.value(), std::string(e.what()).substr(
        std::min(std::string(e.what()).size(), e.field().size() + (e.value().empty() ? 0 : 3 + e.value().size()) + 2)));
  }
  if (c.engine == "fe" && values.count("resolution"))
    throw InputError(field + ".resolution", id_number(std::get<double>(values.at("resolution").v)),
                     "case " + c.id + " runs on the FE engine (solver.engine = \"fe\"), which has no grid: "
                     "its resolution is solver.mesh_size (in [base.solver] or the case's override)");
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

/// Names of [matrices.*], [sections.*] and [loads.*] become case ids and HDF5 groups.
std::string definition_name(const std::string& key, const std::string& field) {
  for (unsigned char c : key)
    if (c < 0x20 || c == 0x7f) throw InputError(field, "", "a name must not contain NUL or control characters");
  return key;
}

std::map<std::string, toml::table> named_tables(const toml::node* node, const std::string& key) {
  std::map<std::string, toml::table> m;
  if (!node) return m;
  for (const auto& [k, v] : keys::read_table(*node, key)) {
    const std::string field = key + "." + std::string(k.str());
    m[definition_name(std::string(k.str()), field)] = keys::read_table(v, field);
  }
  return m;
}

// --- Declared keys ------------------------------------------------------------------------------

/// Cases a campaign may expand to. Every case is validated and stored up front (and one 32² case costs
/// about a second of one core), so a product beyond this is a mistake in the axes, not a study.
constexpr double kMaxCases = 1e5;
constexpr double kSecondsPerCase = 1.0;  ///< lower bound of one 32² case on one core (for the message)

struct CampaignKeys {
  std::string description;
  std::string base_scene;
  const toml::node *base = nullptr, *matrices = nullptr, *sections = nullptr, *loads = nullptr;
  const toml::node *sweep = nullptr, *cases = nullptr, *campaign = nullptr;
};

template <class O>
typename keys::KeyTable<O>::Apply keep(const toml::node* O::*member) {
  return [member](const toml::node& n, const std::string&, O& o) { o.*member = &n; };
}

const keys::KeyTable<CampaignKeys>& campaign_table() {
  using O = CampaignKeys;
  static const keys::KeyTable<O> t = [] {
    keys::KeyTable<O> k("", "A sweep campaign: a base RVE scene and axes whose Cartesian products (and explicit cases) are run.");
    k.text("description", &O::description, "free text, stored with the campaign")
        .custom("base", "table", "an RVE scene giving everything the axes do not set", keep(&O::base))
        .text("base_scene", &O::base_scene, "or: an RVE scene file, relative to the campaign file")
        .custom("matrices", "table of tables", "[matrices.NAME]: a [phases.matrix] table (otherwise NAME is a preset)",
                keep(&O::matrices))
        .custom("sections", "table of tables", "[sections.NAME]: fiber-section keys (built in: circle, square)",
                keep(&O::sections))
        .custom("loads", "table of tables",
                "[loads.NAME]: a [load] table (built in: tension, compression, equibiaxial, shear, relaxation)",
                keep(&O::loads))
        .custom("sweep", "table or list of tables", "axes → lists; each [[sweep]] is one Cartesian product", keep(&O::sweep))
        .custom("cases", "list of tables", "explicit cases: one value per axis, name, override", keep(&O::cases))
        .custom("campaign", "table", "[campaign] switches", keep(&O::campaign));
    return k;
  }();
  return t;
}

struct CampaignSwitches {
  bool warm_start = true;
};

const keys::KeyTable<CampaignSwitches>& switches_table() {
  static const keys::KeyTable<CampaignSwitches> t = [] {
    keys::KeyTable<CampaignSwitches> k("campaign", "Campaign switches.");
    k.flag("warm_start", &CampaignSwitches::warm_start,
           "run cases whose load paths lie on each other's once, along the longest (--no-warm-start overrides)");
    return k;
  }();
  return t;
}

/// [sections.NAME]: the [microstructure] keys a section sets (their values are checked by the RVE
/// scene parser when the section is expanded, used or not).
struct SectionKeys {};
const keys::KeyTable<SectionKeys>& section_table() {
  static const keys::KeyTable<SectionKeys> t = [] {
    auto checked_later = [](const toml::node&, const std::string&, SectionKeys&) {};
    keys::KeyTable<SectionKeys> k("sections.<name>", "A fiber section: [microstructure] keys of the RVE scene.");
    k.custom("shape", "choice", "fiber cross-section (as [microstructure] shape)", checked_later)
        .custom("radius", "number", "circle radius", checked_later, "", "> 0", "mm")
        .custom("width", "number", "rectangle width", checked_later, "", "> 0", "mm")
        .custom("height", "number", "rectangle height", checked_later, "", "> 0", "mm")
        .custom("section_rotation_deg", "number", "rotation of the section in its plane", checked_later, "", "", "deg")
        .custom("fiber_count", "integer", "fibers per cell (random arrangement)", checked_later)
        .custom("min_gap", "number", "least distance between fibers (random arrangement)", checked_later, "", ">= 0", "mm")
        .custom("seed", "integer", "random arrangement seed", checked_later);
    return k;
  }();
  return t;
}

struct CaseKeys {
  std::string name;
  const toml::node* override_table = nullptr;
};

/// Number of cases of one product ([sweep] table): the product of its axis lengths.
double product_size(const toml::table& t) {
  double n = 1.0;
  for (const auto& [k, v] : t)
    if (const auto* arr = v.as_array()) n *= double(std::max<std::size_t>(arr->size(), 1));
  return n;
}

void check_campaign_size(const CampaignKeys& keys) {
  double total = 0.0;
  if (keys.sweep) {
    if (const auto* t = keys.sweep->as_table()) total += product_size(*t);
    else if (const auto* arr = keys.sweep->as_array())
      for (const auto& e : *arr)
        if (const auto* t = e.as_table()) total += product_size(*t);
  }
  if (keys.cases)
    if (const auto* arr = keys.cases->as_array()) total += double(arr->size());
  if (total > kMaxCases) {
    const double hours = total * kSecondsPerCase / 3600.0;
    throw InputError(keys.sweep ? "sweep" : "cases", format_number(total) + " cases",
                     "more than " + format_number(kMaxCases) + " cases (at least about " + format_number(std::round(hours)) +
                         " core-hours at ~1 s per 32² case): shorten the axes or split the campaign");
  }
}

/// Every [matrices.*], [sections.*] and [loads.*] definition that no case uses is expanded once with
/// the first case's other values, so that a typo surfaces now, not when a later edit uses it.
void validate_unused(const Definitions& defs, const std::vector<CampaignCase>& cases,
                     const std::map<std::string, AxisValue>& first) {
  std::set<std::string> used_matrices, used_sections, used_loads;
  for (const auto& c : cases)
    for (const auto& p : c.parameters) {
      if (p.name == "matrix") used_matrices.insert(p.text());
      if (p.name == "section") used_sections.insert(p.text());
      if (p.name == "load") used_loads.insert(p.text());
    }
  auto check = [&](const std::map<std::string, toml::table>& named, const std::set<std::string>& used,
                   const std::string& table, const std::string& axis) {
    for (const auto& [name, def] : named) {
      if (used.count(name)) continue;
      const std::string field = table + "." + name;
      std::map<std::string, AxisValue> values = first;
      values[axis].v = name;
      if (axis == "section") {
        const auto vf = values.find("volume_fraction");
        if (vf == values.end() || std::get<double>(vf->second.v) == 0.0) values["volume_fraction"].v = 0.23;
      }
      make_case(defs, values, "unused-" + name, nullptr, field, field + " (not used by any case)");
    }
  };
  check(defs.matrices, used_matrices, "matrices", "matrix");
  check(defs.sections, used_sections, "sections", "section");
  check(defs.loads, used_loads, "loads", "load");
}

}  // namespace

std::string CaseParameter::text() const {
  if (const auto* s = std::get_if<std::string>(&value)) return *s;
  return parameter_text(std::get<double>(value));
}

const std::vector<std::string>& campaign_axes() {
  static const std::vector<std::string> axes{"matrix", "section", "angle", "volume_fraction", "arrangement", "resolution", "load"};
  return axes;
}

namespace {

/// The tables every case takes from [base] ([microstructure], [phases], [solver], ...) are checked
/// now, through the RVE scene parser, on the first case: a typo or a wrong type there would otherwise
/// surface only when the case runs (or never, in --dry-run). Errors name the [base] path.
void check_first_case_scene(const Campaign& camp) {
  if (camp.cases.empty()) return;
  try {
    (void)parse_case_scene(camp.cases.front().scene);
  } catch (const InputError& e) {
    const std::string what = e.what();
    const std::string head = e.field() + (e.value().empty() ? "" : " = " + e.value()) + ": ";
    const std::string reason = what.rfind(head, 0) == 0 ? what.substr(head.size()) : what;
    throw InputError("base." + e.field(), e.value(), reason + " (in case " + camp.cases.front().id + ")");
  }
}

/// The base scene ([base] or base_scene) and the named [matrices.*], [sections.*], [loads.*].
Definitions read_definitions(const toml::table& table, const CampaignKeys& keys, const std::filesystem::path& base_dir) {
  Definitions defs;
  if (keys.base && table.contains("base_scene")) throw InputError("base_scene", "", "give either [base] or base_scene, not both");
  if (keys.base) defs.base = keys::read_table(*keys.base, "base");
  if (table.contains("base_scene")) {
    std::filesystem::path p = keys.base_scene;
    if (p.is_relative()) p = base_dir / p;
    defs.base = io::load_scene(p, "base_scene");
  }
  // The scene tables of the base must be tables: the expansion writes into them, so a number there
  // would silently become an empty table.
  for (const char* t : {"microstructure", "phases", "load", "solver", "output"})
    if (const toml::node* n = defs.base.get(t); n && !n->is_table())
      throw InputError(std::string("base.") + t, keys::describe_value(*n), "must be a table");
  defs.matrices = named_tables(keys.matrices, "matrices");
  defs.sections = named_tables(keys.sections, "sections");
  for (const auto& [name, sec] : defs.sections) {
    SectionKeys unused;
    section_table().read(sec, "sections." + name, unused);
  }
  defs.loads = named_tables(keys.loads, "loads");
  return defs;
}

/// Every case of the [sweep] products and the [[cases]], in order (duplicates kept); `first` gets the
/// first case's axis values (validation of unused definitions).
std::vector<CampaignCase> expand_cases(const Definitions& defs, const CampaignKeys& keys,
                                       std::map<std::string, AxisValue>& first) {
  std::vector<CampaignCase> all;
  auto remember = [&](const AxisMap& axes) {
    if (!first.empty()) return;
    for (const auto& [k, v] : axes) first[k] = v.front();
  };
  if (keys.sweep && keys.sweep->is_table()) {
    const AxisMap axes = parse_axes(*keys.sweep->as_table(), "sweep", false);
    remember(axes);
    expand_product(defs, axes, "sweep", all);
  } else if (keys.sweep && keys.sweep->is_array()) {
    const toml::array& arr = *keys.sweep->as_array();
    for (std::size_t i = 0; i < arr.size(); ++i) {
      const std::string f = keys::index_field("sweep", i);
      const AxisMap axes = parse_axes(keys::read_table(*arr.get(i), f), f, false);
      remember(axes);
      expand_product(defs, axes, f, all);
    }
  } else if (keys.sweep) {
    throw InputError("sweep", keys::describe_value(*keys.sweep), "must be a table ([sweep]) or an array of tables ([[sweep]])");
  }
  if (keys.cases) {
    const toml::array& arr = keys::read_array(*keys.cases, "cases");
    for (std::size_t i = 0; i < arr.size(); ++i) {
      const std::string f = keys::index_field("cases", i);
      const toml::table& s = keys::read_table(*arr.get(i), f);
      const AxisMap axes = parse_axes(s, f, true);
      remember(axes);
      std::map<std::string, AxisValue> values;
      for (const auto& [k, v] : axes) values[k] = v.front();
      const std::string name = s.contains("name") ? keys::read_text(*s.get("name"), f + ".name") : "";
      const toml::table* ov = s.contains("override") ? &keys::read_table(*s.get("override"), f + ".override") : nullptr;
      all.push_back(make_case(defs, values, name, ov, f));
    }
  }
  return all;
}

}  // namespace

Campaign expand_campaign(const toml::table& table, const std::filesystem::path& base_dir) {
  CampaignKeys keys;
  campaign_table().read(table, "", keys);
  Campaign camp;
  camp.description = keys.description;
  const Definitions defs = read_definitions(table, keys, base_dir);
  CampaignSwitches sw;
  switches_table().read_optional(keys.campaign, "campaign", sw);
  camp.warm_start = sw.warm_start;
  check_campaign_size(keys);

  std::map<std::string, AxisValue> first;
  std::vector<CampaignCase> all = expand_cases(defs, keys, first);
  if (all.empty()) throw InputError("sweep", "", "the campaign has no cases (give [sweep] axes or [[cases]])");
  validate_unused(defs, all, first);

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
  check_first_case_scene(camp);
  return camp;
}

std::vector<keys::TableDoc> campaign_tables() {
  return {campaign_table().describe(), switches_table().describe(), section_table().describe()};
}

}  // namespace softhom::studies
