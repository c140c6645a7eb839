// Isotropic laws in the isochoric first invariant (spec §3):
//   neo-Hookean  W = (μ/2)(Ī1 − 3) + W_V(J)   (or the Lamé-log form of FANS, see LameLogNeoHookeanLaw)
//   Yeoh         W = C1 (Ī1 − 3) + C2 (Ī1 − 3)² + C3 (Ī1 − 3)³ + W_V(J)
// Both reduce to W1 = dW/dĪ1, W11 = d²W/dĪ1² and go through the same InvariantAssembler as Gent.
#include <cmath>
#include <sstream>

#include "softhom/materials/laws.hpp"

namespace softhom {
namespace {

struct NeoHookeanEnergy {
  NeoHookeanParams p;
  double K() const { return p.K; }
  double G() const { return p.mu; }
  double W(double x) const { return 0.5 * p.mu * x; }
  void derivatives(double /*x*/, double& W1, double& W11) const {
    W1 = 0.5 * p.mu;
    W11 = 0.0;
  }
  std::string describe() const {
    std::ostringstream s;
    s.precision(6);
    s << "neo-Hookean (mu=" << p.mu << " MPa, K=" << p.K << " MPa)";
    return s.str();
  }
};

struct YeohEnergy {
  YeohParams p;
  double K() const { return p.K; }
  double G() const { return 2.0 * p.C1; }
  double W(double x) const { return x * (p.C1 + x * (p.C2 + x * p.C3)); }
  void derivatives(double x, double& W1, double& W11) const {
    W1 = p.C1 + x * (2.0 * p.C2 + 3.0 * p.C3 * x);
    W11 = 2.0 * p.C2 + 6.0 * p.C3 * x;
  }
  std::string describe() const {
    std::ostringstream s;
    s.precision(6);
    s << "Yeoh (C1=" << p.C1 << " C2=" << p.C2 << " C3=" << p.C3 << " MPa, K=" << p.K << " MPa)";
    return s.str();
  }
};

template <class Energy>
class IsotropicI1Law final : public ElasticLaw {
 public:
  explicit IsotropicI1Law(const Energy& e) : e_(e) {}
  std::string describe() const override { return e_.describe(); }

  MaterialStatus second_piola(const Mat3& F, const Mat3& C, double J, Mat3& S, Mat9* CC) const override {
    return compute(InvariantAssembler::Form::material, F, C, J, S, CC);
  }
  MaterialStatus first_piola(const Mat3& F, const Mat3& C, double J, Mat3& P, Mat9* A) const override {
    return compute(InvariantAssembler::Form::piola, F, C, J, P, A);
  }
  double energy(const Mat3& C, double J) const override {
    if (!(J > 0.0)) return std::nan("");
    const double x = C.trace() / std::cbrt(J * J) - 3.0;
    return e_.W(x) + volumetric_energy(e_.K(), J);
  }
  double initial_shear_modulus() const override { return e_.G(); }
  double initial_bulk_modulus() const override { return e_.K(); }
  std::unique_ptr<ElasticLaw> rotated(const Mat3& /*Q*/) const override {
    return std::make_unique<IsotropicI1Law>(e_);  // isotropic: nothing to rotate
  }
  bool has_compact_linearization() const override { return true; }
  bool compact_linearization(const Mat3& /*F*/, const Mat3& C, double J, CompactLinearization& L) const override {
    const double I1b = C.trace() / std::cbrt(J * J);
    double W1, W11;
    e_.derivatives(I1b - 3.0, W1, W11);
    L = isochoric_compact_linearization(W1, W11, I1b, J, e_.K());
    return true;
  }

 private:
  MaterialStatus compute(InvariantAssembler::Form form, const Mat3& F, const Mat3& C, double J, Mat3& stress,
                         Mat9* T) const {
    const double j23 = 1.0 / std::cbrt(J * J);
    const double I1b = j23 * C.trace();
    double W1, W11;
    e_.derivatives(I1b - 3.0, W1, W11);
    const IsochoricTerms iso = isochoric_invariant_terms(W1, W11, j23, I1b);
    const double J2 = J * J, K = e_.K();
    const double sC = iso.sC + 0.5 * K * (J2 - 1.0);
    const double cCC = iso.cCC + K * J2;
    const double cS = iso.cS - K * (J2 - 1.0);
    if (!std::isfinite(sC + cCC + cS + iso.sX + iso.cXX + iso.cXC)) return MaterialStatus::not_finite;
    const Mat3 Ci = C.inverse();
    InvariantAssembler assembler(form, F, Ci, T);
    assembler.finish(iso.sX, sC, iso.cXX, iso.cXC, cCC, cS, stress);
    if (!stress.allFinite()) return MaterialStatus::not_finite;
    return MaterialStatus::ok;
  }

  Energy e_;
};

/// Neo-Hookean in the Lamé/log form W = (μ/2)(I1 − 3 − 2 ln J) + (λ/2)(ln J)², λ = K − 2μ/3
/// (NeoHookeanForm::lame_log). In the invariant assembler's terms:
///   S  = μ I + (λ ln J − μ) C⁻¹,
///   CC = λ C⁻¹⊗C⁻¹ + 2(μ − λ ln J) C⁻¹⊙C⁻¹   (2 ∂(ln J)/∂C = C⁻¹, ∂C⁻¹/∂C = −C⁻¹⊙C⁻¹).
/// Its volumetric part is not W_V(J), but W − W_V(J) has a J-stiffness of O(μ) + O(K (J − 1)³), so
/// the law still reports K as volumetric_modulus(): the mixed-pressure iteration only needs the
/// dominant K term to be W_V (it carries W_V′ linearized and converges to the same full stress).
class LameLogNeoHookeanLaw final : public ElasticLaw {
 public:
  explicit LameLogNeoHookeanLaw(const NeoHookeanParams& p) : p_(p), lambda_(p.K - 2.0 / 3.0 * p.mu) {}
  std::string describe() const override {
    std::ostringstream s;
    s.precision(6);
    s << "neo-Hookean, Lame-log form (mu=" << p_.mu << " MPa, K=" << p_.K << " MPa)";
    return s.str();
  }
  MaterialStatus second_piola(const Mat3& F, const Mat3& C, double J, Mat3& S, Mat9* CC) const override {
    return compute(InvariantAssembler::Form::material, F, C, J, S, CC);
  }
  MaterialStatus first_piola(const Mat3& F, const Mat3& C, double J, Mat3& P, Mat9* A) const override {
    return compute(InvariantAssembler::Form::piola, F, C, J, P, A);
  }
  double energy(const Mat3& C, double J) const override {
    if (!(J > 0.0)) return std::nan("");
    const double lnJ = std::log(J);
    return 0.5 * p_.mu * (C.trace() - 3.0 - 2.0 * lnJ) + 0.5 * lambda_ * lnJ * lnJ;
  }
  double initial_shear_modulus() const override { return p_.mu; }
  double initial_bulk_modulus() const override { return p_.K; }
  std::unique_ptr<ElasticLaw> rotated(const Mat3& /*Q*/) const override {
    return std::make_unique<LameLogNeoHookeanLaw>(p_);  // isotropic
  }
  /// W_1 = μ/2, W_J = (λ ln J − μ)/J, W_JJ = (μ + λ(1 − ln J))/J², no mixed or I1I1 terms.
  bool has_compact_linearization() const override { return true; }
  bool compact_linearization(const Mat3& /*F*/, const Mat3& /*C*/, double J, CompactLinearization& L) const override {
    const double lnJ = std::log(J);
    L = compact_from_derivatives(0.5 * p_.mu, (lambda_ * lnJ - p_.mu) / J, 0.0, 0.0, (p_.mu + lambda_ * (1.0 - lnJ)) / (J * J), J);
    return true;
  }

 private:
  MaterialStatus compute(InvariantAssembler::Form form, const Mat3& F, const Mat3& C, double J, Mat3& stress,
                         Mat9* T) const {
    const double lnJ = std::log(J);
    const double sC = lambda_ * lnJ - p_.mu;
    if (!std::isfinite(sC)) return MaterialStatus::not_finite;
    const Mat3 Ci = C.inverse();
    InvariantAssembler assembler(form, F, Ci, T);
    assembler.finish(p_.mu, sC, 0.0, 0.0, lambda_, -2.0 * sC, stress);
    if (!stress.allFinite()) return MaterialStatus::not_finite;
    return MaterialStatus::ok;
  }

  NeoHookeanParams p_;
  double lambda_;
};

}  // namespace

ElasticLawPtr make_neo_hookean(const NeoHookeanParams& p) {
  if (p.form == NeoHookeanForm::lame_log) return std::make_shared<LameLogNeoHookeanLaw>(p);
  return std::make_shared<IsotropicI1Law<NeoHookeanEnergy>>(NeoHookeanEnergy{p});
}
ElasticLawPtr make_yeoh(const YeohParams& p) { return std::make_shared<IsotropicI1Law<YeohEnergy>>(YeohEnergy{p}); }

}  // namespace softhom
