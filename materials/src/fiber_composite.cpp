// Transversely isotropic law of a unidirectional fiber composite: the Gent + HGO law (gent_hgo.cpp)
// plus, for every fiber family a0, a fiber–matrix (longitudinal) shear term and a transverse shear term:
//   W = W_Gent+HGO + Σ_f [ (GL/2)(I5 − I4²) + GT (τ − 1) + (Ef/2)(√I4 − 1)² ],   τ = (I1 I4 − I5) / (2 J √I4)
// with the full invariants I1 = tr C, I4 = a0·C a0, I5 = a0·C² a0, J = det F.
//
// The fiber term (Ef/2)(λf − 1)², λf = √I4, is a linear elastic fiber in its stretch (rule of mixtures:
// Ef = φ E_fiber), in tension and compression as glass is; HGO's k1/(2k2)[exp(k2 (I4 − 1)²) − 1] (a
// collagen fiber, tension only) stiffens at least as (I4 − 1)², i.e. as λf⁴, which the stiff glass fibers
// of the composite do not (their own neo-Hookean stress grows as λf − λf⁻²). Both small-strain fiber
// moduli are equal for Ef = 4 k1.
//
// Why these two measures. A transversely isotropic W depends on I1 … I5 (Spencer, Deformations of
// Fibre-reinforced Materials, 1972; Merodio & Ogden, Int. J. Non-Linear Mech. 40 (2005) 213); Gent + HGO
// uses I1, I4 and J only, so it has one shear modulus G in every plane, while a matrix reinforced by
// stiff fibers has a longitudinal and a transverse shear modulus of its own (composite-cylinder estimate
// for rigid fibers: G_L = G_m (1 + φ)/(1 − φ), Hashin & Rosen, J. Appl. Mech. 31 (1964) 223). The two
// terms follow the orthogonal strain invariants of Criscione, Douglas & Hunter (J. Mech. Phys. Solids 49
// (2001) 871), whose along-fiber shear is β4² = I5/I4² − 1 and transverse shear cosh β3 = τ:
//  - I5 − I4² = |C a0|² − (a0·C a0)² ≥ 0, the squared shear of the fiber against the matrix: zero iff a0
//    is a principal direction of C, so nothing in a stretch along or across the fibers. In simple shear
//    along the fibers, F = I + γ a0⊗n, it is γ² for every γ: the longitudinal shear modulus is G + GL.
//  - τ ≥ 1 compares the trace of C on the plane across the deformed fiber with twice the root of its
//    determinant (J²/I4): 1 iff that plane deforms by a dilation, 1 + γ²/2 in a simple shear γ within it,
//    1 in simple shear along the fibers. The transverse shear modulus is G + GT and, through
//    incompressibility, tension across the fibers stiffens with it.
// Both vanish with their first derivatives at C = I (stress-free reference). Guo, Peng & Moran (J.
// Biomech. 39 (2006) 1849) separate the composite's response the same way (fiber stretch against the
// matrix's shear across and along the fibers) in their composite-based model. GL = GT = Ef = 0 is the
// Gent + HGO law exactly.
//
// Each term is W_x(I1, I4, I5, J) with gradient g and Hessian H in those four variables:
//   S  = 2 Σ_a g_a X_a,  CC = 4 Σ_ab H_ab X_a⊗X_b + 4 g_5 ∂²I5 + 4 g_J ∂²J
//   X_1 = I, X_4 = M = a0⊗a0, X_5 = N = a0⊗b + b⊗a0 (b = C a0), X_J = (J/2) C⁻¹
//   ∂²I5_ijkl = ½[a_i(δ_jk a_l + δ_jl a_k) + a_j(δ_ik a_l + δ_il a_k)],  ∂²J = (J/4) C⁻¹⊗C⁻¹ − (J/2) C⁻¹⊙C⁻¹
#include <array>
#include <cmath>
#include <sstream>

#include "softhom/materials/errors.hpp"
#include "softhom/materials/laws.hpp"

namespace softhom {
namespace {

enum Invariant { kI1 = 0, kI4 = 1, kI5 = 2, kJ = 3 };

/// Gradient and Hessian of a term in (I1, I4, I5, J).
struct InvariantDerivatives {
  Eigen::Vector4d g = Eigen::Vector4d::Zero();
  Eigen::Matrix4d H = Eigen::Matrix4d::Zero();
};

/// τ = (I1 I4 − I5) / (2 J √I4) and its derivatives (the transverse shear measure, above).
inline double transverse_shear(double I1, double I4, double I5, double J) {
  return (I1 * I4 - I5) / (2.0 * J * std::sqrt(I4));
}

inline double added_terms_energy(const FiberCompositeParams& p, double I1, double I4, double I5, double J) {
  const double s = std::sqrt(I4) - 1.0;
  return 0.5 * p.GL * (I5 - I4 * I4) + p.GT * (transverse_shear(I1, I4, I5, J) - 1.0) + 0.5 * p.Ef * s * s;
}

/// (GL/2)(I5 − I4²) + GT (τ − 1) + (Ef/2)(√I4 − 1)²: derivatives in (I1, I4, I5, J).
InvariantDerivatives added_term_derivatives(const FiberCompositeParams& p, double I1, double I4, double I5, double J) {
  const double GL = p.GL, GT = p.GT, s = std::sqrt(I4);
  InvariantDerivatives d;
  d.g(kI4) = -GL * I4 + 0.5 * p.Ef * (1.0 - 1.0 / s);
  d.g(kI5) = 0.5 * GL;
  d.H(kI4, kI4) = -GL + 0.25 * p.Ef / (s * s * s);
  if (GT == 0.0) return d;
  const double D = 2.0 * J * std::sqrt(I4), tau = (I1 * I4 - I5) / D;
  Eigen::Vector4d t;  // ∂τ
  t << I4 / D, I1 / D - tau / (2.0 * I4), -1.0 / D, -tau / J;
  Eigen::Matrix4d T = Eigen::Matrix4d::Zero();  // ∂²τ (τ_11 = τ_55 = τ_15 = 0)
  T(kI1, kI4) = 0.5 / D;
  T(kI1, kJ) = -I4 / (D * J);
  T(kI4, kI5) = 0.5 / (D * I4);
  T(kI5, kJ) = 1.0 / (D * J);
  T(kI4, kI4) = -I1 / (2.0 * D * I4) - t(kI4) / (2.0 * I4) + tau / (2.0 * I4 * I4);
  T(kI4, kJ) = -I1 / (D * J) + tau / (2.0 * I4 * J);
  T(kJ, kJ) = 2.0 * tau / (J * J);
  for (int a = 0; a < 4; ++a)
    for (int b = 0; b < a; ++b) T(a, b) = T(b, a);
  d.g += GT * t;
  d.H += GT * T;
  return d;
}

/// S += 2 Σ g_a X_a and CC += 4 ∂²W/∂C∂C of one family's terms (material form).
void add_invariant_terms(const InvariantDerivatives& d, const Vec3& a0, const Mat3& C, const Mat3& Ci, double J,
                         Mat3& S, Mat9* CC) {
  const Vec3 b = C * a0;
  const std::array<Mat3, 4> X{Mat3::Identity(), Mat3(a0 * a0.transpose()),
                              Mat3(a0 * b.transpose() + b * a0.transpose()), Mat3(0.5 * J * Ci)};
  for (int a = 0; a < 4; ++a) S += 2.0 * d.g(a) * X[a];
  if (!CC) return;
  for (int a = 0; a < 4; ++a)
    for (int c = 0; c < 4; ++c)
      if (d.H(a, c) != 0.0) add_dyad(*CC, 4.0 * d.H(a, c), X[a], X[c]);
  add_dyad(*CC, d.g(kJ) * J, Ci, Ci);              // 4 g_J (J/4) C⁻¹⊗C⁻¹
  add_sym_product(*CC, -2.0 * d.g(kJ) * J, Ci);    // 4 g_J (−J/2) C⁻¹⊙C⁻¹
  const double w = 2.0 * d.g(kI5);                 // 4 g_5 · ½
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k)
        for (int l = 0; l < 3; ++l) {
          const double dik = i == k, dil = i == l, djk = j == k, djl = j == l;
          (*CC)(voigt9(i, j), voigt9(k, l)) +=
              w * (a0(i) * (djk * a0(l) + djl * a0(k)) + a0(j) * (dik * a0(l) + dil * a0(k)));
        }
}

class FiberCompositeLaw final : public ElasticLaw {
 public:
  explicit FiberCompositeLaw(const FiberCompositeParams& p) : p_(p), base_(make_gent_hgo(p.base)) {
    for (const Vec3& a0 : base_->fiber_directions()) directions_.push_back(a0);
  }

  std::string describe() const override {
    std::ostringstream s;
    s.precision(6);
    s << "fiber composite (" << base_->describe() << "; GL=" << p_.GL << " MPa, GT=" << p_.GT << " MPa, Ef=" << p_.Ef
      << " MPa)";
    return s.str();
  }

  MaterialStatus second_piola(const Mat3& F, const Mat3& C, double J, Mat3& S, Mat9* CC) const override {
    const MaterialStatus st = base_->second_piola(F, C, J, S, CC);
    if (st != MaterialStatus::ok) return st;
    const Mat3 Ci = C.inverse();
    for (const Vec3& a0 : directions_) {
      const Vec3 b = C * a0;
      const double I4 = a0.dot(b);
      if (!(I4 > 0.0)) return MaterialStatus::not_finite;
      add_invariant_terms(added_term_derivatives(p_, C.trace(), I4, b.squaredNorm(), J), a0, C, Ci, J, S, CC);
    }
    if (!S.allFinite() || (CC && !CC->allFinite())) return MaterialStatus::not_finite;
    return MaterialStatus::ok;
  }

  double energy(const Mat3& C, double J) const override {
    double W = base_->energy(C, J);
    for (const Vec3& a0 : directions_) {
      const Vec3 b = C * a0;
      W += added_terms_energy(p_, C.trace(), a0.dot(b), b.squaredNorm(), J);
    }
    return W;
  }

  double initial_shear_modulus() const override { return p_.base.G; }
  double initial_bulk_modulus() const override { return p_.base.K; }
  std::vector<Vec3> fiber_directions() const override { return directions_; }
  double limit_margin(const Mat3& F) const override { return base_->limit_margin(F); }
  std::unique_ptr<ElasticLaw> rotated(const Mat3& Q) const override {
    FiberCompositeParams q = p_;
    for (auto& f : q.base.fibers) f.direction = Q * f.direction;
    return std::make_unique<FiberCompositeLaw>(q);
  }

 private:
  FiberCompositeParams p_;
  ElasticLawPtr base_;
  std::vector<Vec3> directions_;  // unit a0 of every family (as the Gent + HGO part normalised them)
};

}  // namespace

ElasticLawPtr make_fiber_composite(const FiberCompositeParams& p) {
  return std::make_shared<FiberCompositeLaw>(p);
}

}  // namespace softhom
