// Material tables declared key by key; the law parameters come from law_table() (library.cpp).
#include <cmath>
#include <map>
#include <numbers>
#include <optional>

#include "softhom/materials/errors.hpp"
#include "softhom/materials/scene_keys.hpp"

namespace softhom {
namespace {

/// What a material table says, before the law is known (law parameters are read against the chosen
/// law's declarations).
struct MaterialKeys {
  std::string preset;
  std::string law;
  std::map<std::string, const toml::node*> parameters;
  std::optional<double> k1, k2, kappa;
  std::optional<NeoHookeanForm> form;
  std::optional<FiberInvariant> invariant;
  std::optional<bool> tension_only;
  const toml::node* fibers = nullptr;
  const toml::node* viscoelastic = nullptr;
};

struct FiberKeys {
  std::vector<double> direction;
  std::optional<double> angle_deg, k1, k2, kappa;
};

struct ViscoKeys {
  double g_inf = 1.0;
  std::optional<double> tau;
  const toml::node* terms = nullptr;
};

const keys::Range kFiberStiffness = keys::at_least(0.0);
const keys::Range kDispersion = keys::closed_range(0.0, 1.0 / 3.0);

std::vector<std::string> law_names() {
  std::vector<std::string> n;
  for (const auto& e : law_table()) n.push_back(e.name);
  return n;
}

std::string quoted_list(const std::vector<std::string>& names) {
  std::string s;
  for (std::size_t i = 0; i < names.size(); ++i) s += (i ? (i + 1 == names.size() ? " or " : ", ") : "") + ("\"" + names[i] + "\"");
  return s;
}

/// Every parameter name of every law, with the laws that have it (for the shared declaration).
std::map<std::string, std::vector<const LawEntry*>> parameter_owners() {
  std::map<std::string, std::vector<const LawEntry*>> owners;
  for (const auto& e : law_table())
    for (const auto& p : e.parameters) owners[p.name].push_back(&e);
  return owners;
}

const keys::Choices<NeoHookeanForm>& form_choices() {
  static const keys::Choices<NeoHookeanForm> c{{{"isochoric", NeoHookeanForm::isochoric}, {"lame-log", NeoHookeanForm::lame_log}}, {{"lame_log", "lame-log"}}};
  return c;
}
const keys::Choices<FiberInvariant>& invariant_choices() {
  static const keys::Choices<FiberInvariant> c{{{"full", FiberInvariant::full}, {"isochoric", FiberInvariant::isochoric}}, {}};
  return c;
}

const keys::KeyTable<MaterialKeys>& material_keys() {
  using M = MaterialKeys;
  static const keys::KeyTable<MaterialKeys> t = [] {
    keys::KeyTable<MaterialKeys> k("material", "a constitutive law: a named parameter set and/or a law with its parameters");
    std::string presets;
    for (const auto& n : preset_names()) presets += (presets.empty() ? "" : ", ") + ("\"" + n + "\"");
    k.custom("preset", "choice",
             "named parameter set of spec §6 (its values are defaults for the keys below); \"glass\" is the "
             "dissertation's fiber (E = 10 MPa, nu = 0.3: about 7000 times softer than glass), \"e-glass\" real E-glass "
             "fiber (E = 72 GPa, nu = 0.22)",
             [](const toml::node& n, const std::string& f, M& m) {
               m.preset = keys::read_text(n, f);
               const auto names = preset_names();
               if (std::find(names.begin(), names.end(), m.preset) == names.end())
                 throw InputError(f, keys::describe_value(n), "unknown parameter set" + keys::did_you_mean(m.preset, names) +
                                                                " (known: " + quoted_list(names) + ")");
             },
             "unset", presets);
    std::string laws;
    for (const auto& e : law_table()) laws += (laws.empty() ? "" : ", ") + ("\"" + e.name + "\"");
    k.custom("law", "choice", "constitutive law (required unless a preset is given; must agree with it)",
             [](const toml::node& n, const std::string& f, M& m) {
               const std::string s = keys::read_text(n, f);
               for (const auto& e : law_table()) {
                 if (e.name == s) return void(m.law = s);
                 for (const auto& a : e.aliases)
                   if (a == s) return void(m.law = e.name);
               }
               throw InputError(f, keys::describe_value(n), "must be " + quoted_list(law_names()) + keys::did_you_mean(s, law_names()));
             },
             "from the preset", laws);
    for (const auto& [name, owners] : parameter_owners()) {
      std::string which, unit = owners.front()->parameters.front().unit;
      for (const auto* e : owners) {
        which += (which.empty() ? "" : ", ") + e->name;
        for (const auto& p : e->parameters)
          if (p.name == name) unit = p.unit;
      }
      const std::string key = name;
      const std::size_t last = which.rfind(", ");
      if (last != std::string::npos) which.replace(last, 2, " and ");
      k.custom(name, "number", "parameter of the " + which + (owners.size() > 1 ? " laws" : " law") + " (see the law tables below)",
               [key](const toml::node& n, const std::string&, M& m) { m.parameters[key] = &n; },
               "per law", "per law", unit);
    }
    k.custom("k1", "number", "fiber stiffness, default of every fiber family (HGO, spec §2)",
             [](const toml::node& n, const std::string& f, M& m) { m.k1 = keys::read_number(n, f, kFiberStiffness); },
             "from the preset, else 0", kFiberStiffness.describe(), "MPa")
        .custom("k2", "number", "fiber exponential coefficient, default of every fiber family",
                [](const toml::node& n, const std::string& f, M& m) { m.k2 = keys::read_number(n, f, kFiberStiffness); },
                "from the preset, else 0", kFiberStiffness.describe(), "-")
        .custom("kappa", "number", "fiber dispersion (GOH; 0: aligned, 1/3: isotropic), default of every family",
                [](const toml::node& n, const std::string& f, M& m) { m.kappa = keys::read_number(n, f, kDispersion); },
                "0", kDispersion.describe(), "-")
        .custom("form", "choice", "neo-Hookean energy form (\"lame-log\": the FANS law)",
                [](const toml::node& n, const std::string& f, M& m) { m.form = keys::read_choice(n, f, form_choices()); },
                "\"isochoric\"", "\"isochoric\", \"lame-log\"")
        .custom("fiber_invariant", "choice", "fiber invariant I4 of C (\"full\", recommended, spec §2) or of C̄; required with fibers",
                [](const toml::node& n, const std::string& f, M& m) { m.invariant = keys::read_choice(n, f, invariant_choices()); },
                "required with fibers", "\"full\", \"isochoric\"")
        .custom("tension_only", "true/false", "a fiber family contributes only while stretched (I4 > 1)",
                [](const toml::node& n, const std::string& f, M& m) { m.tension_only = keys::read_flag(n, f); }, "true")
        .custom("fibers", "array of tables", "[[<path>.fibers]] fiber families (Gent-HGO and fiber-composite)",
                [](const toml::node& n, const std::string&, M& m) { m.fibers = &n; }, "none")
        .custom("viscoelastic", "table", "[<path>.viscoelastic] QLV relaxation (Prony series)",
                [](const toml::node& n, const std::string&, M& m) { m.viscoelastic = &n; }, "none");
    return k;
  }();
  return t;
}

const keys::KeyTable<FiberKeys>& fiber_keys() {
  using F = FiberKeys;
  static const keys::KeyTable<FiberKeys> t = [] {
    keys::KeyTable<FiberKeys> k("material.fibers[]", "one fiber family: exactly one of direction or angle_deg");
    k.numbers("direction", &F::direction, keys::any_value(), 3, 3, "-", "reference direction a0 [x, y, z] (normalised; non-zero)")
        .default_text("unset")
        .number("angle_deg", &F::angle_deg, keys::any_value(), "deg", "in-plane angle from e2 toward e1 (spec §7)")
        .number("k1", &F::k1, kFiberStiffness, "MPa", "fiber stiffness").default_text("the table's k1")
        .number("k2", &F::k2, kFiberStiffness, "-", "exponential coefficient").default_text("the table's k2")
        .number("kappa", &F::kappa, kDispersion, "-", "dispersion").default_text("the table's kappa");
    return k;
  }();
  return t;
}

const keys::KeyTable<ViscoKeys>& visco_keys() {
  using V = ViscoKeys;
  static const keys::KeyTable<ViscoKeys> t = [] {
    keys::KeyTable<ViscoKeys> k("material.viscoelastic", "QLV relaxation D(t) = g_inf + Σ g_k exp(-t/tau_k); weights sum to 1");
    k.number("g_inf", &V::g_inf, keys::left_open(0.0, 1.0), "-", "long-time relative modulus").required()
        .number("tau", &V::tau, keys::above(0.0), "s", "relaxation time of one term g = 1 - g_inf (instead of terms)")
        .custom("terms", "array of tables", "Prony terms [{g = ..., tau = ...}, ...] (instead of tau)",
                [](const toml::node& n, const std::string&, V& v) { v.terms = &n; }, "none");
    return k;
  }();
  return t;
}

const keys::KeyTable<PronyTerm>& term_keys() {
  static const keys::KeyTable<PronyTerm> t = [] {
    keys::KeyTable<PronyTerm> k("material.viscoelastic.terms[]", "one Prony term");
    k.number("g", &PronyTerm::g, keys::above(0.0), "-", "relative weight").required()
        .number("tau", &PronyTerm::tau, keys::above(0.0), "s", "relaxation time").required();
    return k;
  }();
  return t;
}

/// Reads the chosen law's parameters; a key of another law is refused naming this law's parameters.
void read_law_parameters(const MaterialKeys& m, const LawEntry& law, const std::string& path, MaterialSpec& s) {
  std::map<std::string, std::vector<double>> given;
  for (const auto& [name, node] : m.parameters) {
    const std::string field = keys::join_key(path, name);
    const LawParameter* p = nullptr;
    for (const auto& q : law.parameters)
      if (q.name == name) p = &q;
    if (!p) {
      std::string own;
      for (const auto& q : law.parameters) own += (own.empty() ? "" : ", ") + q.name;
      throw InputError(field, keys::describe_value(*node), "not a parameter of the " + law.display + " law (its parameters: " + own + ")");
    }
    given[name] = p->list ? keys::read_numbers(*node, field, p->range, 1, std::size_t(-1), true)
                          : std::vector<double>{keys::read_number(*node, field, p->range)};
    if (p->set) p->set(s, given[name]);
  }
  if (law.finish) law.finish(s, given, path);
}

FiberFamily read_fiber(const toml::node& node, const std::string& fp, const FiberFamily& defaults) {
  FiberKeys k;
  const auto present = fiber_keys().read(keys::read_table(node, fp), fp, k);
  if (present.count("direction") == present.count("angle_deg"))
    throw InputError(fp, "", "give exactly one of direction = [x, y, z] or angle_deg (spec §7: from e2 toward e1)");
  FiberFamily f = defaults;
  if (k.angle_deg) {
    // Reduced to one turn first: the angle as written is exact modulo 360, and a huge one (1e308)
    // overflowed to inf in radians, a NaN direction.
    const double a = std::fmod(*k.angle_deg, 360.0) * std::numbers::pi / 180.0;
    f.direction = Vec3(std::sin(a), std::cos(a), 0.0);
  } else {
    f.direction = Vec3(k.direction[0], k.direction[1], k.direction[2]);
    if (!(f.direction.norm() > 1e-12)) throw InputError(fp + ".direction", keys::describe_value(*node.as_table()->get("direction")), "must be a non-zero vector");
  }
  if (k.k1) f.k1 = *k.k1;
  if (k.k2) f.k2 = *k.k2;
  if (k.kappa) f.kappa = *k.kappa;
  return f;
}

PronySeries read_viscoelastic(const toml::node& node, const std::string& vp) {
  ViscoKeys v;
  visco_keys().read(keys::read_table(node, vp), vp, v);
  PronySeries pr;
  pr.g_inf = v.g_inf;
  if (v.terms) {
    if (v.tau) throw InputError(keys::join_key(vp, "tau"), format_number(*v.tau), "give either tau (one term) or terms");
    const toml::array& arr = keys::read_array(*v.terms, keys::join_key(vp, "terms"));
    for (std::size_t k = 0; k < arr.size(); ++k) {
      const std::string tp = keys::index_field(keys::join_key(vp, "terms"), k);
      PronyTerm term;
      term_keys().read(keys::read_table(*arr.get(k), tp), tp, term);
      pr.terms.push_back(term);
    }
  } else {
    if (!v.tau) throw InputError(keys::join_key(vp, "tau"), "", "missing: give tau (one term) or terms");
    pr.terms.push_back({1.0 - pr.g_inf, *v.tau});  // one term: g = 1 − g∞ (dissertation eq. 2.36)
  }
  return pr;
}

}  // namespace

MaterialSpec parse_material(const toml::table& t, const std::string& path) {
  MaterialKeys m;
  material_keys().read(t, path, m);
  MaterialSpec s;
  s.field_prefix = path;
  FiberFamily family_defaults;
  if (!m.preset.empty()) {
    s = preset_spec(m.preset, path);
    if (!s.gent.fibers.empty()) {  // an anisotropic set: its k1, k2 are defaults for the scene's families
      family_defaults.k1 = s.gent.fibers.front().k1;
      family_defaults.k2 = s.gent.fibers.front().k2;
      s.gent.fibers.clear();
    }
  }
  if (!m.law.empty()) {
    const LawEntry* law = nullptr;
    for (const auto& e : law_table())
      if (e.name == m.law) law = &e;
    if (!m.preset.empty() && law->kind != s.law)
      throw InputError(keys::join_key(path, "law"), "\"" + m.law + "\"", "contradicts preset '" + m.preset + "'");
    s.law = law->kind;
  } else if (m.preset.empty()) {
    throw InputError(keys::join_key(path, "law"), "", "missing: give law = " + quoted_list(law_names()) + " or a preset");
  }
  const LawEntry& law = law_entry(s.law);
  if (m.form) {
    if (s.law != LawKind::neo_hookean)
      throw InputError(keys::join_key(path, "form"), "", "not a parameter of the " + law.display + " law (neo-Hookean only)");
    s.neo_hookean.form = *m.form;
  }
  read_law_parameters(m, law, path, s);

  // Fiber families (Gent-HGO and fiber-composite).
  if (m.k1) family_defaults.k1 = *m.k1;
  if (m.k2) family_defaults.k2 = *m.k2;
  if (m.kappa) family_defaults.kappa = *m.kappa;
  if (m.fibers) {
    const std::string fp = keys::join_key(path, "fibers");
    if (!has_fiber_families(s.law)) throw InputError(fp, "", "fiber families need law = \"gent\" or \"fiber-composite\"");
    const toml::array& arr = keys::read_array(*m.fibers, fp);
    for (std::size_t i = 0; i < arr.size(); ++i) s.gent.fibers.push_back(read_fiber(*arr.get(i), keys::index_field(fp, i), family_defaults));
  }
  if (s.law == LawKind::gent_hgo && s.gent.fibers.empty() && family_defaults.k1 > 0.0 && !m.preset.empty())
    throw InputError(keys::join_key(path, "fibers"), "",
                     "preset '" + m.preset + "' is anisotropic: give at least one [[" + path + ".fibers]] family");
  if (!s.gent.fibers.empty()) {
    if (!m.invariant)
      throw InputError(keys::join_key(path, "fiber_invariant"), "", "required with fibers: \"full\" (recommended, spec §2) or \"isochoric\"");
    s.gent.invariant = *m.invariant;
    if (m.tension_only) s.gent.tension_only = *m.tension_only;
  }
  if (m.viscoelastic) s.prony = read_viscoelastic(*m.viscoelastic, keys::join_key(path, "viscoelastic"));
  validate(s);
  return s;
}

std::vector<keys::TableDoc> material_tables(const std::string& path) {
  std::vector<keys::TableDoc> docs;
  keys::TableDoc main = material_keys().describe();
  main.path = path;
  docs.push_back(main);
  for (const auto& e : law_table()) {
    keys::TableDoc d{path + " (law = \"" + e.name + "\")", e.display + ": " + e.doc, {}};
    for (const auto& p : e.parameters)
      d.keys.push_back({p.name, p.list ? "number or list of numbers" : "number", p.default_text, p.range.describe(), p.unit, p.doc, {}});
    docs.push_back(d);
  }
  for (keys::TableDoc d : {fiber_keys().describe(), visco_keys().describe(), term_keys().describe()}) {
    d.path.replace(0, std::string("material").size(), path);
    docs.push_back(d);
  }
  return docs;
}

}  // namespace softhom
