#include "softhom/materials/library.hpp"

#include <cmath>
#include <sstream>

#include "softhom/materials/errors.hpp"

namespace softhom {
namespace {

std::string num(double v) {
  std::ostringstream s;
  s.precision(10);
  s << v;
  return s.str();
}

// Each check names "<prefix>.<field>" so the user sees which line of the scene is wrong.
void require(bool ok, const std::string& prefix, const std::string& field, double value, const std::string& why) {
  if (!ok || !std::isfinite(value)) throw InputError(prefix + "." + field, num(value), why);
}

GentHGOParams gent(double G, double Jm, double K, double k1 = 0.0, double k2 = 0.0) {
  GentHGOParams p;
  p.G = G;
  p.Jm = Jm;
  p.K = K;
  // k1, k2 of the anisotropic sets are stored as the defaults of a fiber family without direction:
  // the scene supplies the directions (see io::parse_material).
  if (k1 > 0.0) p.fibers.push_back({Vec3::Zero(), k1, k2});
  return p;
}

}  // namespace

const std::vector<LawEntry>& law_table() {
  using V = const std::vector<double>&;
  static const std::vector<LawEntry> table = [] {
    const keys::Range positive = keys::above(0.0);
    // Moduli up to 1e9 MPa (1e15 Pa, 10⁴× diamond's): larger ones overflow the stresses of a law's
    // evaluation (E = 1e308 with nu = 0.3 stopped at the first step with a non-finite value).
    const keys::Range modulus = keys::left_open(0.0, 1e9);
    const std::string bulk = "bulk modulus (volumetric energy W_V(J), spec §2)";
    std::vector<LawEntry> t;
    t.push_back({LawKind::gent_hgo, "gent", {"gent-hgo"}, "Gent-HGO",
                 "Gent matrix with optional HGO fiber families (spec §2)",
                 {{"G", "MPa", modulus, "initial shear modulus", false, "required (or from the preset)",
                   [](MaterialSpec& s, V v) { s.gent.G = v[0]; }},
                  {"Jm", "-", positive, "Gent locking parameter (Ī1 - 3 < Jm)", false, "required (or from the preset)",
                   [](MaterialSpec& s, V v) { s.gent.Jm = v[0]; }},
                  {"K", "MPa", modulus, bulk, false, "required (or from the preset)",
                   [](MaterialSpec& s, V v) { s.gent.K = v[0]; }}},
                 nullptr});
    const keys::Range shear_term = keys::closed_range(0.0, 1e9);
    t.push_back({LawKind::fiber_composite, "fiber-composite", {}, "fiber-composite",
                 "transversely isotropic fiber composite: Gent + HGO fiber families + per family a fiber-matrix "
                 "shear term (GL/2)(I5 - I4^2) and a transverse shear term GT (tau - 1), tau = (I1 I4 - I5)/(2 J sqrt(I4)); small-strain "
                 "shear moduli G + GL along and G + GT across the fibers; a stretch-linear fiber term Ef; GL = GT = Ef = 0 is law = \"gent\"",
                 {{"G", "MPa", modulus, "initial shear modulus of the Gent matrix", false, "required",
                   [](MaterialSpec& s, V v) { s.gent.G = v[0]; }},
                  {"Jm", "-", positive, "Gent locking parameter (Ī1 - 3 < Jm)", false, "required",
                   [](MaterialSpec& s, V v) { s.gent.Jm = v[0]; }},
                  {"K", "MPa", modulus, bulk, false, "required", [](MaterialSpec& s, V v) { s.gent.K = v[0]; }},
                  {"GL", "MPa", shear_term, "added longitudinal (fiber-matrix) shear modulus, term in I5 - I4^2", false, "0",
                   [](MaterialSpec& s, V v) { s.fiber_shear.GL = v[0]; }},
                  {"GT", "MPa", shear_term, "added transverse shear modulus, term in tau = (I1 I4 - I5)/(2 J sqrt(I4))", false, "0",
                   [](MaterialSpec& s, V v) { s.fiber_shear.GT = v[0]; }},
                  {"Ef", "MPa", shear_term,
                   "fiber term linear in the fiber stretch, (Ef/2)(sqrt(I4) - 1)^2 per family, in tension and compression "
                   "(rule of mixtures: volume fraction x fiber Young's modulus)", false, "0",
                   [](MaterialSpec& s, V v) { s.fiber_shear.Ef = v[0]; }}},
                 nullptr});
    t.push_back({LawKind::neo_hookean, "neo-hookean", {}, "neo-Hookean",
                 "compressible neo-Hookean; (mu, K) or (E, nu); form = \"isochoric\" | \"lame-log\"",
                 {{"mu", "MPa", modulus, "shear modulus", false, "required unless E, nu (or from the preset)",
                   [](MaterialSpec& s, V v) { s.neo_hookean.mu = v[0]; }},
                  {"K", "MPa", modulus, bulk, false, "required unless E, nu (or from the preset)",
                   [](MaterialSpec& s, V v) { s.neo_hookean.K = v[0]; }},
                  {"E", "MPa", modulus, "Young's modulus (with nu, instead of mu and K)", false, "unset", nullptr},
                  {"nu", "-", keys::open_range(-1.0, 0.5), "Poisson's ratio (with E, instead of mu and K)", false, "unset",
                   nullptr}},
                 [](MaterialSpec& s, const std::map<std::string, std::vector<double>>& given, const std::string& path) {
                   const bool young = given.count("E") || given.count("nu");
                   if (!young) return;
                   if (given.count("mu") || given.count("K"))
                     throw InputError(path + (given.count("mu") ? ".mu" : ".K"), "", "give either (E, nu) or (mu, K)");
                   if (!given.count("E")) throw InputError(path + ".E", "", "missing: nu needs E");
                   if (!given.count("nu")) throw InputError(path + ".nu", "", "missing: E needs nu");
                   const NeoHookeanForm form = s.neo_hookean.form;
                   const double E = given.at("E")[0], nu = given.at("nu")[0];
                   s.neo_hookean = NeoHookeanParams::from_young(E, nu);
                   s.neo_hookean.form = form;
                   // The moduli derived from (E, nu) must be finite: name the key given, not mu or K.
                   if (!std::isfinite(s.neo_hookean.mu) || !std::isfinite(s.neo_hookean.K))
                     throw InputError(path + ".E", format_number(E),
                                      "with nu = " + format_number(nu) + " gives mu = " + format_number(s.neo_hookean.mu) +
                                          ", K = " + format_number(s.neo_hookean.K) + ": too large for a finite modulus");
                 }});
    t.push_back({LawKind::yeoh, "yeoh", {}, "Yeoh", "three-term Yeoh, initial shear modulus 2 C1",
                 {{"C1", "MPa", modulus, "first coefficient (initial shear modulus 2 C1)", false,
                   "required (or from the preset)", [](MaterialSpec& s, V v) { s.yeoh.C1 = v[0]; }},
                  {"C2", "MPa", keys::any_value(), "second coefficient", false, "0",
                   [](MaterialSpec& s, V v) { s.yeoh.C2 = v[0]; }},
                  {"C3", "MPa", keys::at_least(0.0), "third coefficient (>= 0: stable at large stretch)", false, "0",
                   [](MaterialSpec& s, V v) { s.yeoh.C3 = v[0]; }},
                  {"K", "MPa", modulus, bulk, false, "required (or from the preset)",
                   [](MaterialSpec& s, V v) { s.yeoh.K = v[0]; }}},
                 nullptr});
    t.push_back({LawKind::ogden, "ogden", {}, "Ogden", "N-term Ogden (Abaqus convention), initial shear modulus Σ mu_i",
                 {{"mu", "MPa", keys::any_value(), "term moduli mu_i (Σ mu_i > 0)", true, "required (or from the preset)",
                   [](MaterialSpec& s, V v) { s.ogden.mu = v; }},
                  {"alpha", "-", keys::any_value(), "term exponents alpha_i (non-zero, as many as mu)", true,
                   "required (or from the preset)", [](MaterialSpec& s, V v) { s.ogden.alpha = v; }},
                  {"K", "MPa", modulus, bulk, false, "required (or from the preset)",
                   [](MaterialSpec& s, V v) { s.ogden.K = v[0]; }}},
                 nullptr});
    return t;
  }();
  return table;
}

const LawEntry& law_entry(LawKind kind) {
  for (const auto& e : law_table())
    if (e.kind == kind) return e;
  throw std::logic_error("law without a law_table() entry");
}

std::vector<std::string> preset_names() {
  return {"ecoflex", "pdms", "glass", "e-glass", "ecoflex-anisotropic", "pdms-anisotropic", "verify-iso",
          "verify-aniso", "vessel", "microhand-pdms", "cpasmo-gent", "cpasmo-yeoh", "cpasmo-ogden"};
}

MaterialSpec preset_spec(const std::string& name, const std::string& field_prefix) {
  MaterialSpec s;
  s.field_prefix = field_prefix;
  s.preset = name;
  s.law = LawKind::gent_hgo;
  // Spec §6. Presets without a bulk modulus in the source (microhand, cpasmo-yeoh/ogden: modelled as
  // incompressible there) get K = 2000 like every other near-incompressible set of the study.
  if (name == "ecoflex") s.gent = gent(0.017, 14.0, 2000.0);
  else if (name == "pdms") s.gent = gent(0.65, 5.0, 2000.0);
  else if (name == "glass") {
    s.law = LawKind::neo_hookean;
    s.neo_hookean = NeoHookeanParams::from_young(10.0, 0.3);  // the dissertation's fiber, not glass
  } else if (name == "e-glass") {
    // E-glass fiber: E = 72 GPa, ν = 0.22 (the usual handbook values for E-glass).
    s.law = LawKind::neo_hookean;
    s.neo_hookean = NeoHookeanParams::from_young(72000.0, 0.22);
  } else if (name == "ecoflex-anisotropic") s.gent = gent(0.017, 14.0, 2000.0, 0.8, 18.0);
  else if (name == "pdms-anisotropic") s.gent = gent(0.65, 5.0, 2000.0, 0.8, 18.0);
  else if (name == "verify-iso") s.gent = gent(0.026, 0.067, 2000.0);
  else if (name == "verify-aniso") s.gent = gent(0.024, 0.9, 2000.0, 0.8, 503.5);  // k2 = 5.5 for biaxial
  else if (name == "vessel") s.gent = gent(0.0024, 0.9, 2000.0, 0.001, 1.2);
  else if (name == "microhand-pdms") s.gent = gent(0.4, 5.5, 2000.0);
  else if (name == "cpasmo-gent") s.gent = gent(0.014, 14.5, 2000.0);
  else if (name == "cpasmo-yeoh") {
    s.law = LawKind::yeoh;
    s.yeoh = {0.008, 4e-5, 4e-5, 2000.0};
  } else if (name == "cpasmo-ogden") {
    s.law = LawKind::ogden;
    s.ogden = {{0.0111, 1.119e-5, 0.0114}, {2.393, 8.123, -2.168}, 2000.0};
  } else {
    std::string known;
    for (const auto& n : preset_names()) known += (known.empty() ? "" : ", ") + n;
    throw InputError(field_prefix + ".preset", name, "unknown parameter set (known: " + known + ")");
  }
  return s;
}

void validate(const MaterialSpec& s) {
  const std::string& pre = s.field_prefix;
  switch (s.law) {
    case LawKind::fiber_composite:
      require(s.fiber_shear.GL >= 0.0, pre, "GL", s.fiber_shear.GL, "added shear modulus must be >= 0");
      require(s.fiber_shear.GT >= 0.0, pre, "GT", s.fiber_shear.GT, "added shear modulus must be >= 0");
      require(s.fiber_shear.Ef >= 0.0, pre, "Ef", s.fiber_shear.Ef, "fiber modulus must be >= 0");
      if (s.gent.fibers.empty())
        throw InputError(pre + ".fibers", "[]", "the fiber-composite law needs at least one [[fibers]] family");
      [[fallthrough]];
    case LawKind::gent_hgo: {
      const auto& p = s.gent;
      require(p.G > 0.0, pre, "G", p.G, "shear modulus must be > 0");
      require(p.Jm > 0.0, pre, "Jm", p.Jm, "Gent locking parameter must be > 0");
      require(p.K > 0.0, pre, "K", p.K, "bulk modulus must be > 0");
      for (std::size_t i = 0; i < p.fibers.size(); ++i) {
        const std::string f = "fibers[" + std::to_string(i) + "]";
        require(p.fibers[i].k1 >= 0.0, pre, f + ".k1", p.fibers[i].k1, "must be >= 0");
        require(p.fibers[i].k2 >= 0.0, pre, f + ".k2", p.fibers[i].k2, "must be >= 0");
        require(p.fibers[i].kappa >= 0.0 && p.fibers[i].kappa <= 1.0 / 3.0, pre, f + ".kappa", p.fibers[i].kappa,
                "fiber dispersion must lie in [0, 1/3] (0: aligned, 1/3: isotropic)");
        const double norm = p.fibers[i].direction.norm();
        if (!(norm > 1e-12) || !std::isfinite(norm))
          throw InputError(pre + "." + f + ".direction", "[" + num(p.fibers[i].direction.x()) + ", " +
                               num(p.fibers[i].direction.y()) + ", " + num(p.fibers[i].direction.z()) + "]",
                           "fiber direction must be a non-zero vector");
      }
      break;
    }
    case LawKind::neo_hookean:
      require(s.neo_hookean.mu > 0.0, pre, "mu", s.neo_hookean.mu, "shear modulus must be > 0");
      require(s.neo_hookean.K > 0.0, pre, "K", s.neo_hookean.K, "bulk modulus must be > 0");
      break;
    case LawKind::yeoh:
      require(s.yeoh.C1 > 0.0, pre, "C1", s.yeoh.C1, "must be > 0 (initial shear modulus 2 C1)");
      require(s.yeoh.C2 > -1e300, pre, "C2", s.yeoh.C2, "must be finite");
      require(s.yeoh.C3 >= 0.0, pre, "C3", s.yeoh.C3, "must be >= 0 (stability at large stretch)");
      require(s.yeoh.K > 0.0, pre, "K", s.yeoh.K, "bulk modulus must be > 0");
      break;
    case LawKind::ogden: {
      const auto& o = s.ogden;
      if (o.mu.empty() || o.mu.size() != o.alpha.size())
        throw InputError(pre + ".alpha", std::to_string(o.alpha.size()) + " values",
                         "mu and alpha must have the same non-zero length (" + std::to_string(o.mu.size()) + " mu)");
      double mu0 = 0.0;
      for (std::size_t i = 0; i < o.mu.size(); ++i) {
        require(o.alpha[i] != 0.0, pre, "alpha[" + std::to_string(i) + "]", o.alpha[i], "must be non-zero");
        require(o.mu[i] * o.alpha[i] * o.alpha[i] > -1e300, pre, "mu[" + std::to_string(i) + "]", o.mu[i], "must be finite");
        mu0 += o.mu[i];
      }
      require(mu0 > 0.0, pre, "mu", mu0, "initial shear modulus Σ mu_i must be > 0");
      require(o.K > 0.0, pre, "K", o.K, "bulk modulus must be > 0");
      break;
    }
  }
  if (s.prony) {
    const auto& pr = *s.prony;
    const std::string v = pre + ".viscoelastic";
    require(pr.g_inf > 0.0 && pr.g_inf <= 1.0, v, "g_inf", pr.g_inf, "must lie in (0, 1]");
    double sum = pr.g_inf;
    for (std::size_t k = 0; k < pr.terms.size(); ++k) {
      const std::string t = "terms[" + std::to_string(k) + "]";
      require(pr.terms[k].g > 0.0, v, t + ".g", pr.terms[k].g, "Prony weight must be > 0");
      require(pr.terms[k].tau > 0.0, v, t + ".tau", pr.terms[k].tau, "relaxation time must be > 0");
      sum += pr.terms[k].g;
    }
    if (std::abs(sum - 1.0) > 1e-9)
      throw InputError(v + ".terms", "g_inf + sum(g) = " + num(sum), "Prony weights must sum to 1");
  }
}

MaterialPtr build_material(const MaterialSpec& s) {
  validate(s);
  ElasticLawPtr law;
  switch (s.law) {
    case LawKind::gent_hgo: law = make_gent_hgo(s.gent); break;
    case LawKind::fiber_composite: law = make_fiber_composite({s.gent, s.fiber_shear.GL, s.fiber_shear.GT, s.fiber_shear.Ef}); break;
    case LawKind::neo_hookean: law = make_neo_hookean(s.neo_hookean); break;
    case LawKind::yeoh: law = make_yeoh(s.yeoh); break;
    case LawKind::ogden: law = make_ogden(s.ogden); break;
  }
  return make_material(law, s.prony);
}

}  // namespace softhom
