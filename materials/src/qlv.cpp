// Quasi-linear viscoelasticity around any ElasticLaw (spec §4), and make_material().
//
// Split of the elastic stress: S_H^e = (1/3)(S^e:C) C⁻¹ (hydrostatic, stays elastic) and
// S_D^e = S^e − S_H^e = J F⁻¹ dev(σ^e) F⁻ᵀ (relaxes with D(t) = g∞ + Σ g_k exp(−t/τ_k)).
// Exponential integrator, exact for a constant rate of S_D^e over the step:
//   h_k ← exp(−Δt/τ_k) h_k + g_k φ_k (S_D^e,n+1 − S_D^e,n),   φ_k = (τ_k/Δt)(1 − exp(−Δt/τ_k)) → 1 at Δt = 0
//   S = S_H^e + g∞ S_D^e + Σ_k h_k
// Algorithmic tangent (CC = 2 ∂S/∂C):
//   CC = CC_H + f (CC^e − CC_H),   f = g∞ + Σ g_k φ_k
//   CC_H = 2 ∂S_H^e/∂C = (1/3) C⁻¹⊗(C:CC^e) + (2/3) C⁻¹⊗S^e − (2/3)(S^e:C) C⁻¹⊙C⁻¹
// (from ∂(S^e:C)/∂C = ½ C:CC^e + S^e and ∂C⁻¹/∂C = −C⁻¹⊙C⁻¹). CC is minor- but not major-symmetric.
// It is pushed forward term by term to A = ∂P/∂F (see evaluate), starting from the law's (P^e, A^e).
//
// State per point (6 (1 + N) doubles, symmetric tensors in the order 11, 22, 33, 23, 13, 12):
//   [S_D^e at the last converged step | h_1 | … | h_N].
#include <cmath>
#include <sstream>

#include "softhom/materials/laws.hpp"

namespace softhom {
namespace {

inline void load_sym(const double* s, Mat3& A) {
  A(0, 0) = s[0];
  A(1, 1) = s[1];
  A(2, 2) = s[2];
  A(1, 2) = A(2, 1) = s[3];
  A(0, 2) = A(2, 0) = s[4];
  A(0, 1) = A(1, 0) = s[5];
}
inline void store_sym(const Mat3& A, double* s) {
  // A is symmetric up to rounding; average the off-diagonal pairs so the stored history is symmetric.
  s[0] = A(0, 0);
  s[1] = A(1, 1);
  s[2] = A(2, 2);
  s[3] = 0.5 * (A(1, 2) + A(2, 1));
  s[4] = 0.5 * (A(0, 2) + A(2, 0));
  s[5] = 0.5 * (A(0, 1) + A(1, 0));
}

// φ(x) = (1 − e^(−x))/x with x = Δt/τ; expm1 keeps it accurate for small x, and φ(0) = 1 exactly.
inline double phi(double x) { return x > 0.0 ? -std::expm1(-x) / x : 1.0; }

class QLVMaterial final : public Material {
 public:
  QLVMaterial(ElasticLawPtr law, PronySeries prony) : law_(std::move(law)), prony_(std::move(prony)) {}

  std::string describe() const override {
    std::ostringstream s;
    s.precision(6);
    s << law_->describe() << " with QLV (g_inf=" << prony_.g_inf;
    for (const auto& t : prony_.terms) s << "; g=" << t.g << " tau=" << t.tau << " s";
    s << ")";
    return s.str();
  }
  int state_size() const override { return 6 * (1 + int(prony_.terms.size())); }
  void init_state(double* state) const override {
    for (int i = 0; i < state_size(); ++i) state[i] = 0.0;
  }

  MaterialStatus evaluate(const Mat3& F, const double* state_old, double* state_new, double dt, Mat3& P,
                          Mat9* A) const override {
    double J = 0.0;
    MaterialStatus st = check_deformation(F, J);
    if (st != MaterialStatus::ok) return st;
    // A negative or non-finite step is not a time step: refuse it like a non-finite input.
    if (!(dt >= 0.0) || !std::isfinite(dt)) return MaterialStatus::not_finite;
    const Mat3 C = F.transpose() * F;
    // Elastic response in Piola form (the law's fused kernel where it has one); S^e = F⁻¹ P^e.
    Mat3 Pe;
    Mat9 Ae;
    st = law_->first_piola(F, C, J, Pe, A ? &Ae : nullptr);
    if (st != MaterialStatus::ok) return st;
    const Mat3 Finv = F.inverse();
    Mat3 Se = Finv * Pe;
    Se = 0.5 * (Se + Se.transpose());  // symmetric up to rounding
    const Mat3 Ci = Finv * Finv.transpose();

    const double p = ddot(Se, C);
    const Mat3 SH = (p / 3.0) * Ci;
    const Mat3 SD = Se - SH;
    Mat3 SD_old, h;
    load_sym(state_old, SD_old);
    const Mat3 dSD = SD - SD_old;

    Mat3 S = SH + prony_.g_inf * SD;
    double f = prony_.g_inf;
    const int N = int(prony_.terms.size());
    for (int k = 0; k < N; ++k) {
      const auto& t = prony_.terms[k];
      const double x = dt / t.tau;
      const double gphi = t.g * phi(x);
      load_sym(state_old + 6 * (k + 1), h);
      S += std::exp(-x) * h + gphi * dSD;
      f += gphi;
    }
    if (!S.allFinite()) return MaterialStatus::not_finite;
    P.noalias() = F * S;

    if (A) {
      // A = δ_ik S_JL + push(CC),  push(X)_iJkL = F_iM X_MJNL F_kN,  CC = f CC^e + (1 − f) CC_H, with
      //   push(CC^e)       = A^e − δ_ik S^e_JL
      //   push(C⁻¹ ⊗ X)    = F⁻ᵀ ⊗ (F X)
      //   push(C⁻¹ ⊙ C⁻¹)  = ½ (δ_ik C⁻¹_JL + F⁻ᵀ_iL F⁻ᵀ_kJ)
      //   F (C:CC^e)       = (A^eᵀ : F) − P^e        (contract A^e = δ S^e + push(CC^e) with F)
      // so no material 9x9 tensor is formed.
      const double w = 1.0 - f;
      const Mat3 Fit = Finv.transpose();
      const Vec9 t = flatten(Fit), pe = flatten(Pe);
      const Vec9 r = Ae.transpose() * flatten(F) - pe;  // vec(F (C:CC^e))
      Mat9& T = *A;
      T = f * Ae;
      T.noalias() += t * (w / 3.0 * (r + 2.0 * pe)).transpose();
      const double q = w * p / 3.0;
      for (int k = 0; k < 3; ++k)
        for (int L = 0; L < 3; ++L)
          for (int i = 0; i < 3; ++i)
            for (int J2 = 0; J2 < 3; ++J2) T(voigt9(i, J2), voigt9(k, L)) -= q * Fit(i, L) * Fit(k, J2);
      const Mat3 G = S - f * Se - q * Ci;
      for (int i = 0; i < 3; ++i) T.block<3, 3>(3 * i, 3 * i) += G;
      if (!T.allFinite()) return MaterialStatus::not_finite;
    }

    // Success: write the new state (after every read of state_old, so the two may alias).
    if (state_new) {
      for (int k = 0; k < N; ++k) {
        const auto& t = prony_.terms[k];
        const double x = dt / t.tau;
        load_sym(state_old + 6 * (k + 1), h);
        store_sym(std::exp(-x) * h + t.g * phi(x) * dSD, state_new + 6 * (k + 1));
      }
      store_sym(SD, state_new);
    }
    return MaterialStatus::ok;
  }

  double initial_shear_modulus() const override { return law_->initial_shear_modulus(); }
  double initial_bulk_modulus() const override { return law_->initial_bulk_modulus(); }
  // W_V contributes only to S_H^e, which stays elastic: the volumetric term passes through unrelaxed.
  double volumetric_modulus() const override { return law_->initial_bulk_modulus(); }
  std::vector<Vec3> fiber_directions() const override { return law_->fiber_directions(); }
  double limit_margin(const Mat3& F) const override { return law_->limit_margin(F); }
  std::unique_ptr<Material> rotated(const Mat3& Q) const override {
    return std::make_unique<QLVMaterial>(ElasticLawPtr(law_->rotated(Q)), prony_);
  }

 private:
  ElasticLawPtr law_;
  PronySeries prony_;
};

}  // namespace

MaterialPtr make_material(ElasticLawPtr law, const std::optional<PronySeries>& prony) {
  // No Prony terms and g∞ = 1 is the elastic law itself: use the adapter, which stores no history.
  if (!prony || (prony->terms.empty() && prony->g_inf == 1.0))
    return std::make_shared<HyperelasticMaterial>(std::move(law));
  return std::make_shared<QLVMaterial>(std::move(law), *prony);
}

}  // namespace softhom
