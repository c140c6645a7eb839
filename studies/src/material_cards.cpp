#include "softhom/studies/material_cards.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <sstream>

#include <Eigen/Dense>

#include "softhom/io/files.hpp"
#include "softhom/materials/errors.hpp"

namespace softhom::studies {
namespace {

/// Shortest round-trip text of a number (what the cards print: values read back bit for bit).
std::string num(double x) { return format_number(x); }

std::string vec_text(const Vec3& v) { return num(v.x()) + "," + num(v.y()) + "," + num(v.z()); }

/// A direction perpendicular to a (for FEBio's mat_axis d; with γ = 0 only a matters).
Vec3 perpendicular(const Vec3& a) {
  const Vec3 trial = std::abs(a.z()) < 0.9 ? Vec3::UnitZ() : Vec3::UnitX();
  return trial.cross(a).normalized();
}

void require_gent(const MaterialSpec& spec, const char* card) {
  if (spec.law != LawKind::gent_hgo)
    throw InputError(spec.field_prefix + ".law", "", std::string("the ") + card + " card is written for the Gent + HGO law only");
}

void require_febio_prony(const MaterialSpec& spec) {
  if (spec.prony && spec.prony->terms.size() > 6)
    throw InputError(spec.field_prefix + ".viscoelastic.terms", std::to_string(spec.prony->terms.size()),
                     "FEBio's viscoelastic materials take at most 6 Prony terms");
}

/// Two elastic laws added (S, CC and the energy): the Abaqus card's matrix + fiber materials on
/// superposed elements.
class SumLaw final : public ElasticLaw {
 public:
  SumLaw(ElasticLawPtr a, ElasticLawPtr b) : a_(std::move(a)), b_(std::move(b)) {}
  std::string describe() const override { return a_->describe() + " + " + b_->describe(); }
  MaterialStatus second_piola(const Mat3& F, const Mat3& C, double J, Mat3& S, Mat9* CC) const override {
    Mat3 S2;
    Mat9 CC2;
    MaterialStatus st = a_->second_piola(F, C, J, S, CC);
    if (st != MaterialStatus::ok) return st;
    st = b_->second_piola(F, C, J, S2, CC ? &CC2 : nullptr);
    if (st != MaterialStatus::ok) return st;
    S += S2;
    if (CC) *CC += CC2;
    return MaterialStatus::ok;
  }
  double energy(const Mat3& C, double J) const override { return a_->energy(C, J) + b_->energy(C, J); }
  double initial_shear_modulus() const override { return a_->initial_shear_modulus() + b_->initial_shear_modulus(); }
  double initial_bulk_modulus() const override { return a_->initial_bulk_modulus() + b_->initial_bulk_modulus(); }
  std::vector<Vec3> fiber_directions() const override { return b_->fiber_directions(); }
  double limit_margin(const Mat3& F) const override { return std::min(a_->limit_margin(F), b_->limit_margin(F)); }
  std::unique_ptr<ElasticLaw> rotated(const Mat3& Q) const override {
    return std::make_unique<SumLaw>(ElasticLawPtr(a_->rotated(Q)), ElasticLawPtr(b_->rotated(Q)));
  }

 private:
  ElasticLawPtr a_, b_;
};

CardCurveDifference compare_run(const CalCurve& c, const PointRunResult& model, const Material& card,
                                const PointSolverOptions& point) {
  CardCurveDifference d;
  d.curve = c.name;
  d.quantity = c.y;
  try {
    const PointRunResult run = run_material_point(card, c.control, point);
    if (!run.completed) {
      d.error = run.error.empty() ? "material-point run stopped early" : run.error;
      return d;
    }
    const std::size_t n = std::min(run.steps.size(), model.steps.size());
    double ymax = 0.0, dy = 0.0, pmax = 0.0, dp = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      const double ym = model_quantity(model.steps[i], c.y), yc = model_quantity(run.steps[i], c.y);
      ymax = std::max(ymax, std::abs(ym));
      dy = std::max(dy, std::abs(yc - ym));
      pmax = std::max(pmax, model.steps[i].P.cwiseAbs().maxCoeff());
      dp = std::max(dp, (run.steps[i].P - model.steps[i].P).cwiseAbs().maxCoeff());
    }
    d.max_rel = ymax > 0.0 ? dy / ymax : dy;
    d.max_rel_all_P = pmax > 0.0 ? dp / pmax : dp;
    d.ok = true;
  } catch (const std::exception& e) {
    d.error = e.what();
  }
  return d;
}

std::string percent(double x) {
  char b[32];
  std::snprintf(b, sizeof b, "%.3g %%", 100.0 * x);
  return b;
}

std::vector<std::string> difference_lines(const std::vector<CardCurveDifference>& diffs) {
  std::vector<std::string> lines;
  double worst = 0.0;
  for (const auto& d : diffs) {
    if (!d.ok) {
      lines.push_back("  " + d.curve + ": not evaluable (" + d.error + ")");
      continue;
    }
    worst = std::max(worst, d.max_rel);
    lines.push_back("  " + d.curve + ": max |" + d.quantity + " card - " + d.quantity + " softhom| / max |" + d.quantity +
                    "| = " + percent(d.max_rel) + " (all P_ij: " + percent(d.max_rel_all_P) + ")");
  }
  lines.insert(lines.begin(), "Max relative stress difference card vs softhom model on the calibration load paths: " +
                                  percent(worst));
  return lines;
}

}  // namespace

// ---------------------------------------------------------------------------------------------------

YeohFit fit_yeoh_to_gent(double G, double Jm, double I1_range) {
  YeohFit f;
  f.I1_range = std::max(I1_range, 1e-6);
  f.C1 = 0.5 * G;
  // W1_Gent(x) = (G/2) Jm / (Jm − x), x = Ī1 − 3; Yeoh W1 = C1 + 2 C2 x + 3 C3 x². With C1 = G/2 the
  // relative residual (W1_Y − W1_G)/W1_G is linear in (C2, C3): ordinary least squares on a grid.
  const int n = 400;
  Eigen::MatrixXd A(n, 2);
  Eigen::VectorXd b(n);
  for (int i = 0; i < n; ++i) {
    const double x = f.I1_range * double(i + 1) / n;
    const double w1 = 0.5 * G * Jm / (Jm - x);
    A(i, 0) = 2.0 * x / w1;
    A(i, 1) = 3.0 * x * x / w1;
    b(i) = 1.0 - f.C1 / w1;
  }
  Eigen::Vector2d c = A.colPivHouseholderQr().solve(b);
  // Abaqus' Yeoh needs no sign condition, softhom's wants C3 ≥ 0 (stable at large Ī1): Gent's W1 is
  // convex in x, so the fit gives C3 > 0; keep the guard for a degenerate range.
  if (c(1) < 0.0) {
    c(1) = 0.0;
    c(0) = (A.col(0).dot(b)) / A.col(0).squaredNorm();
  }
  f.C2 = c(0);
  f.C3 = c(1);
  for (int i = 0; i <= 4 * n; ++i) {
    const double x = f.I1_range * double(i) / (4 * n);
    const double w1 = 0.5 * G * Jm / (Jm - x);
    const double wy = f.C1 + 2.0 * f.C2 * x + 3.0 * f.C3 * x * x;
    f.max_rel_W1_error = std::max(f.max_rel_W1_error, std::abs(wy / w1 - 1.0));
  }
  return f;
}

double max_isochoric_I1_minus_3(const PointRunResult& run) {
  double m = 0.0;
  for (const auto& s : run.steps) {
    const double J = s.F.determinant();
    if (!(J > 0.0)) continue;
    m = std::max(m, (s.F.transpose() * s.F).trace() / std::cbrt(J * J) - 3.0);
  }
  return m;
}

MaterialSpec febio_equivalent_spec(const MaterialSpec& spec) {
  MaterialSpec s = spec;
  s.gent.invariant = FiberInvariant::isochoric;
  return s;
}

MaterialPtr abaqus_equivalent_material(const MaterialSpec& spec, const YeohFit& yeoh) {
  require_gent(spec, "Abaqus");
  ElasticLawPtr matrix = make_yeoh({yeoh.C1, yeoh.C2, yeoh.C3, spec.gent.K});
  GentHGOParams fibers = spec.gent;
  // The HOLZAPFEL material on the superposed elements: fibers only (its C10 and 1/D are set
  // negligible in the card); here a vanishing Gent term stands for them.
  fibers.G = 1e-12 * spec.gent.G;
  fibers.Jm = 1e6;
  fibers.K = 0.0;
  fibers.invariant = FiberInvariant::isochoric;
  return make_material(std::make_shared<SumLaw>(matrix, make_gent_hgo(fibers)), spec.prony);
}

CardComparison compare_cards(const CalibrationInput& input, const std::vector<double>& values) {
  CardComparison out;
  const MaterialSpec spec = input.model.spec(values);
  const MaterialPtr model = build_material(spec);
  const MaterialPtr febio = build_material(febio_equivalent_spec(spec));
  std::vector<PointRunResult> runs;
  double range = 0.0;
  for (const CalCurve& c : input.curves) {
    PointRunResult r = run_material_point(*model, c.control, input.solver.point);
    range = std::max(range, max_isochoric_I1_minus_3(r));
    runs.push_back(std::move(r));
  }
  out.yeoh = fit_yeoh_to_gent(spec.gent.G, spec.gent.Jm, std::min(range, 0.95 * spec.gent.Jm));
  const MaterialPtr abaqus = abaqus_equivalent_material(spec, out.yeoh);
  for (std::size_t i = 0; i < input.curves.size(); ++i) {
    const CalCurve& c = input.curves[i];
    if (!runs[i].completed) {
      CardCurveDifference d;
      d.curve = c.name;
      d.error = "softhom model: " + runs[i].error;
      out.febio.push_back(d);
      out.abaqus.push_back(d);
      continue;
    }
    out.febio.push_back(compare_run(c, runs[i], *febio, input.solver.point));
    out.abaqus.push_back(compare_run(c, runs[i], *abaqus, input.solver.point));
  }
  return out;
}

// ---------------------------------------------------------------------------------------------------
// FEBio 4

std::string febio_material_block(const MaterialSpec& spec, const std::string& name,
                                 const std::vector<std::string>& comment) {
  require_gent(spec, "FEBio");
  require_febio_prony(spec);
  const GentHGOParams& g = spec.gent;
  std::ostringstream s;
  s << "<!--\n"
    << "  softhom Gent + HGO" << (spec.prony ? " + QLV" : "") << " material as a FEBio 4 <Material> block.\n"
    << "  softhom: W = -(G Jm/2) ln(1 - (I1b-3)/Jm) + K/4 (J^2 - 1 - 2 ln J)\n"
    << "              + sum_f k1/(2 k2) [exp(k2 E_f^2) - 1],  E_f = kappa I1 + (1-3 kappa) I4 - 1 ("
    << (g.invariant == FiberInvariant::full ? "full" : "isochoric") << " invariants), "
    << (g.tension_only ? "only while E_f > 0" : "tension and compression") << ".\n"
    << "  FEBio:   uncoupled solid mixture: \"Gent\" (same W_D), pressure_model \"NIKE3D\" U(J) = K/4 (J^2 - 1 - 2 ln J)\n"
    << "           (= W_V exactly), per fiber family one \"Holzapfel-Gasser-Ogden\" with c = 0, gamma = 0 (its two\n"
    << "           fibers at +-gamma both along a0, hence k1/2), kappa as softhom's: E = kappa (I1b-3) + (1-3 kappa)(I4b-1),\n"
    << "           switched off for E < 0.\n"
    << "  Differences: FEBio's HGO fiber term uses the isochoric invariants I1b, I4b and is uncoupled (it adds no\n"
    << "           hydrostatic stress)";
  if (g.invariant == FiberInvariant::full) s << "; softhom's fiber_invariant = \"full\" model differs by O(sigma/K)";
  else s << "; this model uses the isochoric invariants too: identical energy";
  if (!g.tension_only) s << ". FEBio's HGO is tension-only, softhom's model here is not: the cards differ under fiber compression";
  s << ".\n";
  if (spec.prony)
    s << "  Viscoelastic: \"uncoupled viscoelastic\" relaxes the deviatoric stress with g0 = g_inf, g_i, t_i (the same\n"
      << "           exponential update as softhom); the pressure U'(J) stays elastic as softhom's hydrostatic part.\n";
  s << "  Fiber directions a0 are in the material frame; in a structure, element mat_axis (ElementData) gives that\n"
    << "  frame (e.g. the cylindrical (hoop, axial, radial) frame of a tube) and FEBio compounds it with these axes.\n";
  for (std::string line : comment) {
    // "--" may not occur inside an XML comment.
    for (std::size_t p = line.find("--"); p != std::string::npos; p = line.find("--")) line.replace(p, 2, "- -");
    s << "  " << line << "\n";
  }
  s << "-->\n";
  s << "<Material>\n";
  s << "\t<material id=\"1\" name=\"" << name << "\" type=\"" << (spec.prony ? "uncoupled viscoelastic" : "uncoupled solid mixture") << "\">\n";
  // k and pressure_model belong to the top-level material only (FEBio ignores them below).
  s << "\t\t<k>" << num(g.K) << "</k>\n\t\t<pressure_model>NIKE3D</pressure_model>\n";
  if (spec.prony) {
    s << "\t\t<g0>" << num(spec.prony->g_inf) << "</g0>\n";
    for (std::size_t k = 0; k < spec.prony->terms.size(); ++k)
      s << "\t\t<g" << k + 1 << ">" << num(spec.prony->terms[k].g) << "</g" << k + 1 << ">\n\t\t<t" << k + 1 << ">"
        << num(spec.prony->terms[k].tau) << "</t" << k + 1 << ">\n";
    s << "\t\t<elastic type=\"uncoupled solid mixture\">\n";
  }
  const std::string in = spec.prony ? "\t\t\t" : "\t\t";
  s << in << "<solid type=\"Gent\">\n" << in << "\t<G>" << num(g.G) << "</G>\n" << in << "\t<Jm>" << num(g.Jm) << "</Jm>\n"
    << in << "</solid>\n";
  for (std::size_t f = 0; f < g.fibers.size(); ++f) {
    const FiberFamily& fam = g.fibers[f];
    const Vec3 a = fam.direction.normalized();
    s << in << "<!-- fiber family " << f + 1 << ": a0 = (" << vec_text(a) << "), k1 = " << num(fam.k1) << " -->\n";
    s << in << "<solid type=\"Holzapfel-Gasser-Ogden\">\n"
      << in << "\t<c>0</c>\n"
      << in << "\t<k1>" << num(0.5 * fam.k1) << "</k1>\n"
      << in << "\t<k2>" << num(fam.k2) << "</k2>\n"
      << in << "\t<kappa>" << num(fam.kappa) << "</kappa>\n"
      << in << "\t<gamma>0</gamma>\n"
      << in << "\t<mat_axis type=\"vector\">\n"
      << in << "\t\t<a>" << vec_text(a) << "</a>\n"
      << in << "\t\t<d>" << vec_text(perpendicular(a)) << "</d>\n"
      << in << "\t</mat_axis>\n"
      << in << "</solid>\n";
  }
  if (spec.prony) s << "\t\t</elastic>\n";
  s << "\t</material>\n</Material>\n";
  return s.str();
}

// ---------------------------------------------------------------------------------------------------
// Abaqus

std::string abaqus_material_fragment(const MaterialSpec& spec, const YeohFit& yeoh, const std::string& name,
                                     const std::vector<std::string>& comment) {
  require_gent(spec, "Abaqus");
  const GentHGOParams& g = spec.gent;
  for (const auto& f : g.fibers)
    if (f.k1 != g.fibers.front().k1 || f.k2 != g.fibers.front().k2 || f.kappa != g.fibers.front().kappa)
      throw InputError(spec.field_prefix + ".fibers", "", "the Abaqus HOLZAPFEL card needs the same k1, k2, kappa for every family");
  std::ostringstream s;
  s << "** softhom Gent + HGO" << (spec.prony ? " + QLV" : "") << " material as an Abaqus keyword fragment.\n"
    << "** softhom: G = " << num(g.G) << " MPa, Jm = " << num(g.Jm) << ", K = " << num(g.K) << " MPa";
  if (!g.fibers.empty())
    s << ", k1 = " << num(g.fibers[0].k1) << " MPa, k2 = " << num(g.fibers[0].k2) << ", kappa = " << num(g.fibers[0].kappa)
      << ", " << g.fibers.size() << " famil" << (g.fibers.size() == 1 ? "y" : "ies") << " ("
      << (g.invariant == FiberInvariant::full ? "full" : "isochoric") << " invariants)";
  s << ".\n"
    << "** Abaqus has no Gent law: " << name << "-MATRIX is a Yeoh law fitted to Gent's dW/dI1b on\n"
    << "** I1b - 3 in [0, " << num(yeoh.I1_range) << "] (the range the calibration curves reach), C10 = G/2 kept;\n"
    << "** max relative error of dW/dI1b (= of the matrix stress on any path in that range): " << percent(yeoh.max_rel_W1_error) << ".\n"
    << "** Beyond that range the Yeoh law does not lock as Gent does: do not extrapolate.\n"
    << "** Volumetric: Yeoh's (J-1)^2/D1 with D1 = 2/K against softhom's K/4 (J^2-1-2 ln J): same K, differ at O((J-1)^3).\n";
  if (!g.fibers.empty())
    s << "** " << name << "-FIBERS: *ANISOTROPIC HYPERELASTIC, HOLZAPFEL, U = C10(I1b-3) + 1/D((J^2-1)/2 - ln J)\n"
      << "**   + k1/(2k2) sum_a [exp(k2 <E_a>^2) - 1], E_a = kappa(I1b-3) + (1-3kappa)(I4b(aa)-1): the same GOH term but\n"
      << "**   of the isochoric I4b (uncoupled: no hydrostatic fiber stress), C10 and 1/D negligible (1e-9 G, 1e-9 K).\n"
      << "**   softhom's \"full\" I4 differs by O(sigma/K); the max differences on the calibration paths are below.\n"
      << "** Use: two element sets on the SAME nodes (superposed elements, e.g. C3D8H), one with " << name << "-MATRIX,\n"
      << "**   one with " << name << "-FIBERS and the orientation; the stresses add as the energies do.\n"
      << "**   Fiber directions are given in the orientation's local system (the calibration frame: 1 = load axis,\n"
      << "**   2 = in-plane transverse, 3 = normal); for a tube, use a cylindrical *ORIENTATION.\n";
  if (spec.prony)
    s << "** Viscoelastic: *VISCOELASTIC, TIME=PRONY with g_i = softhom's g_i (instantaneous moduli, MODULI=INSTANTANEOUS),\n"
      << "**   k_i = 0 (no bulk relaxation, as softhom's hydrostatic part); Abaqus relaxes the deviatoric stress.\n";
  for (const auto& line : comment) s << "** " << line << "\n";
  s << "**\n*MATERIAL, NAME=" << name << "-MATRIX\n"
    << "*HYPERELASTIC, YEOH" << (spec.prony ? ", MODULI=INSTANTANEOUS" : "") << "\n"
    << num(yeoh.C1) << ", " << num(yeoh.C2) << ", " << num(yeoh.C3) << ", " << num(2.0 / g.K) << ", 0., 0.\n";
  auto prony = [&]() {
    if (!spec.prony) return;
    s << "*VISCOELASTIC, TIME=PRONY\n";
    for (const auto& t : spec.prony->terms) s << num(t.g) << ", 0., " << num(t.tau) << "\n";
  };
  prony();
  if (!g.fibers.empty()) {
    const std::size_t n = g.fibers.size();
    s << "*MATERIAL, NAME=" << name << "-FIBERS\n"
      << "*ANISOTROPIC HYPERELASTIC, HOLZAPFEL, LOCAL DIRECTIONS=" << n << "\n"
      << num(1e-9 * 0.5 * g.G) << ", " << num(2.0 / (1e-9 * g.K)) << ", " << num(g.fibers[0].k1) << ", "
      << num(g.fibers[0].k2) << ", " << num(g.fibers[0].kappa) << "\n";
    prony();
    s << "*ORIENTATION, NAME=" << name << "-ORI, LOCAL DIRECTIONS=" << n << "\n"
      << "1., 0., 0., 0., 1., 0.\n3, 0.\n";
    for (const auto& f : g.fibers) {
      const Vec3 a = f.direction.normalized();
      s << num(a.x()) << ", " << num(a.y()) << ", " << num(a.z()) << "\n";
    }
  }
  return s.str();
}

CardComparison write_material_cards(const std::filesystem::path& dir, const CalibrationInput& input,
                                    const CalibrationResult& result) {
  CardComparison cmp;
  MaterialSpec spec;
  try {
    spec = input.model.spec(result.values);
    cmp = compare_cards(input, result.values);
  } catch (const std::exception& e) {
    cmp.warnings.push_back(std::string("no material cards: ") + e.what());
    return cmp;
  }
  std::vector<std::string> head{"Written by softhom calibrate with material.toml (" +
                                std::string(result.success ? "converged" : "NOT converged") + " fit)."};
  std::vector<std::string> fe = head, ab = head;
  for (const auto& l : difference_lines(cmp.febio)) fe.push_back(l);
  for (const auto& l : difference_lines(cmp.abaqus)) ab.push_back(l);
  try {
    io::write_file_atomic(dir / "material.feb", febio_material_block(spec, "softhom", fe));
  } catch (const InputError& e) {
    cmp.warnings.push_back(std::string("no material.feb: ") + e.what());
  }
  try {
    io::write_file_atomic(dir / "material.inp", abaqus_material_fragment(spec, cmp.yeoh, "SOFTHOM", ab));
  } catch (const InputError& e) {
    cmp.warnings.push_back(std::string("no material.inp: ") + e.what());
  }
  return cmp;
}

}  // namespace softhom::studies
