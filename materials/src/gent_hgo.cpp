// Compressible Gent matrix + HGO fiber families (spec §2):
//   W = −(G Jm/2) ln(1 − (Ī1 − 3)/Jm) + (K/4)(J² − 1 − 2 ln J) + Σ_f k1/(2 k2) [exp(k2 (I*_f − 1)²) − 1]
// with I*_f the full I4 = a0·C a0 or the isochoric Ī4 = J^(-2/3) I4 (FiberInvariant).
//
// Derivatives used (W1 = dW_D/dĪ1, ψ' = dW_f/dI*, see InvariantAssembler for the tensor bases):
//   W1 = G Jm / (2 (Jm − Ī1 + 3)),   W11 = 2 W1² / (G Jm)
//   ψ' = k1 E exp(k2 E²),            ψ'' = k1 exp(k2 E²)(1 + 2 k2 E²),   E = I* − 1
//   full invariant:      S_f = 2ψ' M,  CC_f = 4ψ'' M⊗M
//   isochoric invariant: S_f = 2ψ' ∂Ī4/∂C = 2ψ' J^(-2/3)(M − (I4/3) C⁻¹), i.e. the fiber stress passes
//                        through the deviatoric projector (spec erratum to eq. 2.9); CC_f from
//                        isochoric_invariant_terms() exactly as for Ī1.
// Fiber dispersion (Gasser, Ogden & Holzapfel 2006): with κ > 0 the family's invariant is H : C,
// H = κ I + (1 − 3κ) M, i.e. κ I1 + (1 − 3κ) I4 (isochoric: of Ī1 and Ī4); every formula above holds
// with M replaced by H. κ = 0 is the aligned HGO family, κ = 1/3 an isotropic distribution.
#include <cmath>
#include <sstream>

#include "softhom/materials/errors.hpp"
#include "softhom/materials/laws.hpp"

namespace softhom {
namespace {

// exp(x) overflows for x > ~709.78; stop earlier so that ψ'' = k1 e^x (1 + 2x) stays finite too.
constexpr double kMaxExponent = 700.0;

// Closer to the locking limit than this (relative to Jm) the stress is dominated by the rounding error
// of Ī1 (≈ 1e-16 Ī1), so the call reports locking instead of returning a meaningless number.
constexpr double kLockingMargin = 1e-12;

struct Fiber {
  Vec3 a0;
  Mat3 M;  // a0 ⊗ a0, precomputed
  double k1, k2;
  double kappa;   // GOH dispersion: structure tensor H = κ I + (1 − 3κ) M
  double H_trace;  // tr H = 3κ + (1 − 3κ)|a0|², 1 up to rounding (the invariant's value at C = I)
};

// The family's invariant before the isochoric scaling: H : C = κ tr C + (1 − 3κ) |F a0|².
inline double structure_invariant(const Fiber& f, const Mat3& C, double a_sq) {
  return f.kappa == 0.0 ? a_sq : f.kappa * C.trace() + (1.0 - 3.0 * f.kappa) * a_sq;
}

class GentHGOLaw final : public ElasticLaw {
 public:
  explicit GentHGOLaw(const GentHGOParams& p) : p_(p) {
    fibers_.reserve(p.fibers.size());
    for (std::size_t i = 0; i < p.fibers.size(); ++i) {
      const double n = p.fibers[i].direction.norm();
      if (!(n > 0.0) || !std::isfinite(n))
        throw InputError("fibers[" + std::to_string(i) + "].direction", "",
                         "fiber direction must be a finite non-zero vector");
      const Vec3 a0 = p.fibers[i].direction / n;
      p_.fibers[i].direction = a0;
      const double kappa = p.fibers[i].kappa;
      if (!(kappa >= 0.0 && kappa <= 1.0 / 3.0))
        throw InputError("fibers[" + std::to_string(i) + "].kappa", format_number(kappa),
                         "fiber dispersion must lie in [0, 1/3]");
      fibers_.push_back({a0, a0 * a0.transpose(), p.fibers[i].k1, p.fibers[i].k2, kappa,
                         3.0 * kappa + (1.0 - 3.0 * kappa) * a0.squaredNorm()});
    }
  }

  std::string describe() const override {
    std::ostringstream s;
    s.precision(6);
    s << (fibers_.empty() ? "Gent" : "Gent+HGO") << " (G=" << p_.G << " MPa, Jm=" << p_.Jm << ", K=" << p_.K
      << " MPa";
    if (!fibers_.empty()) {
      s << "; " << fibers_.size() << " fiber famil" << (fibers_.size() == 1 ? "y" : "ies") << ", "
        << (p_.invariant == FiberInvariant::full ? "full" : "isochoric") << " invariant, "
        << (p_.tension_only ? "tension only" : "tension and compression");
      for (const auto& f : fibers_) {
        s << "; k1=" << f.k1 << " MPa k2=" << f.k2;
        if (f.kappa > 0.0) s << " kappa=" << f.kappa;
        s << " a0=(" << f.a0.x() << ", " << f.a0.y() << ", " << f.a0.z() << ")";
      }
    }
    s << ")";
    return s.str();
  }

  MaterialStatus second_piola(const Mat3& F, const Mat3& C, double J, Mat3& S, Mat9* CC) const override {
    return compute(InvariantAssembler::Form::material, F, C, J, S, CC);
  }
  MaterialStatus first_piola(const Mat3& F, const Mat3& C, double J, Mat3& P, Mat9* A) const override {
    return compute(InvariantAssembler::Form::piola, F, C, J, P, A);
  }

  double limit_margin(const Mat3& F) const override {
    const double J = F.determinant();
    if (!(J > 0.0)) return 0.0;
    const double I1b = (F.transpose() * F).trace() / std::cbrt(J * J);
    return 1.0 - (I1b - 3.0) / p_.Jm;
  }

  double energy(const Mat3& C, double J) const override {
    if (!(J > 0.0)) return std::nan("");
    const double j23 = 1.0 / std::cbrt(J * J);
    const double x = j23 * C.trace() - 3.0;
    if (!(x < p_.Jm)) return std::nan("");
    double W = -0.5 * p_.G * p_.Jm * std::log1p(-x / p_.Jm) + volumetric_energy(p_.K, J);
    for (const auto& f : fibers_) {
      double I = structure_invariant(f, C, f.a0.dot(C * f.a0));
      if (p_.invariant == FiberInvariant::isochoric) I *= j23;
      const double E = I - f.H_trace;  // as in compute()
      if (p_.tension_only && !(E > 0.0)) continue;
      // k1/(2k2)(exp(k2 E²) − 1) → k1 E²/2 as k2 → 0; expm1 keeps it accurate for small k2 E².
      W += f.k2 > 0.0 ? 0.5 * f.k1 / f.k2 * std::expm1(f.k2 * E * E) : 0.5 * f.k1 * E * E;
    }
    return W;
  }

  double initial_shear_modulus() const override { return p_.G; }
  double initial_bulk_modulus() const override { return p_.K; }
  std::vector<Vec3> fiber_directions() const override {
    std::vector<Vec3> d;
    for (const auto& f : fibers_) d.push_back(f.a0);
    return d;
  }
  /// Gent without fiber families is isotropic in (Ī1, J): W1 and W11 as in compute().
  bool has_compact_linearization() const override { return fibers_.empty(); }
  bool compact_linearization(const Mat3& /*F*/, const Mat3& C, double J, CompactLinearization& L) const override {
    if (!fibers_.empty()) return false;
    const double I1b = C.trace() / std::cbrt(J * J);
    const double W1 = 0.5 * p_.G * p_.Jm / (p_.Jm - (I1b - 3.0));
    const double W11 = 2.0 * W1 * W1 / (p_.G * p_.Jm);
    L = isochoric_compact_linearization(W1, W11, I1b, J, p_.K);
    return true;
  }
  std::unique_ptr<ElasticLaw> rotated(const Mat3& Q) const override {
    GentHGOParams q = p_;
    for (auto& f : q.fibers) f.direction = Q * f.direction;
    return std::make_unique<GentHGOLaw>(q);
  }

 private:
  MaterialStatus compute(InvariantAssembler::Form form, const Mat3& F, const Mat3& C, double J, Mat3& stress,
                         Mat9* T) const {
    const double j23 = 1.0 / std::cbrt(J * J);  // J^(-2/3)
    const double I1b = j23 * C.trace();
    const double gap = p_.Jm - (I1b - 3.0);  // Jm − (Ī1 − 3) > 0 away from locking
    if (!std::isfinite(gap)) return MaterialStatus::not_finite;
    if (!(gap > kLockingMargin * p_.Jm)) return MaterialStatus::locking;
    const Mat3 Ci = C.inverse();

    const double W1 = 0.5 * p_.G * p_.Jm / gap;
    const double W11 = 2.0 * W1 * W1 / (p_.G * p_.Jm);
    const IsochoricTerms iso = isochoric_invariant_terms(W1, W11, j23, I1b);
    double sC = iso.sC, cCC = iso.cCC, cS = iso.cS;
    // Volumetric part: S_V = (K/2)(J² − 1) C⁻¹, CC_V = K J² C⁻¹⊗C⁻¹ − K (J² − 1) C⁻¹⊙C⁻¹.
    const double J2 = J * J;
    sC += 0.5 * p_.K * (J2 - 1.0);
    cCC += p_.K * J2;
    cS -= p_.K * (J2 - 1.0);

    InvariantAssembler assembler(form, F, Ci, T);
    double check = 0.0;  // sum of the fiber coefficients: non-finite iff one of them is
    for (const auto& f : fibers_) {
      const Vec3 a = F * f.a0;
      const double I4 = structure_invariant(f, C, a.squaredNorm());
      const double Is = p_.invariant == FiberInvariant::full ? I4 : j23 * I4;
      // E = I* − 1 with "1" taken as tr H (= 1 up to rounding): exactly 0 at F = I, so the tension-only
      // switch gives the same reference tangent whatever the rounding of the normalised a0.
      const double E = Is - f.H_trace;
      if (p_.tension_only && !(E > 0.0)) continue;  // fibers carry no compression
      const double x = f.k2 * E * E;
      if (!(x <= kMaxExponent)) return MaterialStatus::not_finite;
      const double ex = std::exp(x);
      const double psi1 = f.k1 * E * ex;
      const double psi2 = f.k1 * ex * (1.0 + 2.0 * x);
      check += psi2;  // |ψ'| ≤ ψ'' for k2 ≥ 0 up to the factor E: overflow shows here first
      // The structure tensor enters only through (sX, cXX, cXC); aligned fibers take the cheaper
      // a ⊗ a0 push-forward.
      auto add = [&](double sX, double cXX, double cXC) {
        if (f.kappa == 0.0) {
          assembler.add_fiber(f.a0, a, f.M, sX, cXX, cXC);
        } else {
          const double w = 1.0 - 3.0 * f.kappa;
          Mat3 H = w * f.M;
          H.diagonal().array() += f.kappa;
          const Mat3 FH = f.kappa * F + w * a * f.a0.transpose();
          assembler.add_structure(H, FH, sX, cXX, cXC);
        }
      };
      if (p_.invariant == FiberInvariant::full) {
        add(2.0 * psi1, 4.0 * psi2, 0.0);
      } else {
        const IsochoricTerms t = isochoric_invariant_terms(psi1, psi2, j23, Is);
        add(t.sX, t.cXX, t.cXC);
        sC += t.sC;
        cCC += t.cCC;
        cS += t.cS;
      }
    }
    check += sC + cCC + cS + iso.cXX + iso.cXC;
    if (!std::isfinite(check)) return MaterialStatus::not_finite;
    assembler.finish(iso.sX, sC, iso.cXX, iso.cXC, cCC, cS, stress);
    if (!stress.allFinite()) return MaterialStatus::not_finite;
    return MaterialStatus::ok;
  }

  GentHGOParams p_;
  std::vector<Fiber> fibers_;
};

}  // namespace

ElasticLawPtr make_gent_hgo(const GentHGOParams& p) { return std::make_shared<GentHGOLaw>(p); }

}  // namespace softhom
