#pragma once
// Hyperelastic laws written in their natural measure, S(C), with one tested conversion to (P, ∂P/∂F).
#include <cmath>
#include <memory>

#include "softhom/materials/material.hpp"
#include "softhom/materials/volumetric.hpp"

namespace softhom {

/// A hyperelastic law in material form: S = 2 ∂W/∂C and CC = 2 ∂S/∂C = 4 ∂²W/∂C∂C (minor-symmetric).
/// Implementations must not allocate and must return a non-ok status instead of non-finite numbers.
class ElasticLaw {
 public:
  virtual ~ElasticLaw() = default;
  virtual std::string describe() const = 0;
  /// `F` is passed alongside C = FᵀF for laws that want J = det F directly (J ≤ 0 is rejected before).
  virtual MaterialStatus second_piola(const Mat3& F, const Mat3& C, double J, Mat3& S, Mat9* CC) const = 0;
  /// Strain energy per reference volume (used by tests and energy checks), or NaN when undefined.
  virtual double energy(const Mat3& C, double J) const = 0;
  virtual double initial_shear_modulus() const = 0;
  virtual double initial_bulk_modulus() const = 0;
  virtual std::vector<Vec3> fiber_directions() const { return {}; }
  /// See Material::limit_margin.
  virtual double limit_margin(const Mat3& F) const { (void)F; return 1.0; }
  virtual std::unique_ptr<ElasticLaw> rotated(const Mat3& Q) const = 0;

  /// P = F S and, when `A` is non-null, A = ∂P/∂F (same preconditions as second_piola). The default
  /// converts second_piola() with piola_tangent_from_material(); a law may override it with a fused
  /// kernel that never forms the 9x9 CC (the tests check that both routes agree).
  virtual MaterialStatus first_piola(const Mat3& F, const Mat3& C, double J, Mat3& P, Mat9* A) const;

  /// See Material::compact_linearization (`C` = FᵀF, `J` = det F > 0).
  virtual bool has_compact_linearization() const { return false; }
  virtual bool compact_linearization(const Mat3& F, const Mat3& C, double J, CompactLinearization& L) const {
    (void)F;
    (void)C;
    (void)J;
    (void)L;
    return false;
  }
};

using ElasticLawPtr = std::shared_ptr<const ElasticLaw>;

/// Common pre-checks of every material call: finite entries and J > 0.
MaterialStatus check_deformation(const Mat3& F, double& J);

/// Coefficients contributed by an isochoric invariant Ī = J^(-2/3) (X:C), with X = I (Ī1) or X = M_f
/// (Ī4), to a law with dW/dĪ = W1 and d²W/dĪ² = W11 (Y = ∂Ī/∂C = J^(-2/3)(X − (X:C)/3 C⁻¹)):
///   S  += sX X + sC C⁻¹                                              (= 2 W1 Y)
///   CC += cXX X⊗X + cXC (X⊗C⁻¹ + C⁻¹⊗X) + cCC C⁻¹⊗C⁻¹ + cS C⁻¹⊙C⁻¹  (= 4 W11 Y⊗Y + 4 W1 ∂Y/∂C)
struct IsochoricTerms {
  double sX, sC, cXX, cXC, cCC, cS;
};
inline IsochoricTerms isochoric_invariant_terms(double W1, double W11, double j23, double Ibar) {
  const double q = W11 * Ibar + W1;
  return {2.0 * W1 * j23, -2.0 / 3.0 * W1 * Ibar, 4.0 * W11 * j23 * j23, -4.0 / 3.0 * j23 * q,
          4.0 / 9.0 * Ibar * q, 4.0 / 3.0 * W1 * Ibar};
}

/// Building block of the laws written in invariants of C (Gent + HGO, neo-Hookean, Yeoh):
///   S  = sI I + sC C⁻¹ + Σ_f sM_f M_f                                        (M_f = a0_f ⊗ a0_f)
///   CC = cII I⊗I + cIC (I⊗C⁻¹ + C⁻¹⊗I) + cCC C⁻¹⊗C⁻¹ + cS C⁻¹⊙C⁻¹
///        + Σ_f [cMM_f M_f⊗M_f + cMC_f (M_f⊗C⁻¹ + C⁻¹⊗M_f)]
/// written either in material form (S, CC) or directly in Piola form (P = F S, A = ∂P/∂F) through the
/// push-forwards F·I = F, F·C⁻¹ = F⁻ᵀ, F·M_f = (F a0_f) ⊗ a0_f and
/// F(C⁻¹⊙C⁻¹)Fᵀ → ½(δ_ik C⁻¹_JL + F⁻ᵀ_iL F⁻ᵀ_kJ): no 9x9 CC and no 9x9x3 push-forward.
/// Fibers are added one at a time, so any number of families needs no storage; nothing allocates.
class InvariantAssembler {
 public:
  enum class Form { material, piola };
  /// `T` receives CC (material) or A (piola) and may be null for a stress-only call. `F` and `C_inv`
  /// must outlive the assembler.
  InvariantAssembler(Form form, const Mat3& F, const Mat3& C_inv, Mat9* T);
  /// One fiber family: `a0` reference direction, `a` = F a0, `M` = a0 ⊗ a0.
  void add_fiber(const Vec3& a0, const Vec3& a, const Mat3& M, double sM, double cMM, double cMC);
  /// A general symmetric structure tensor H in place of M (e.g. the dispersed-fiber tensor
  /// κ I + (1 − 3κ) M of Gasser–Ogden–Holzapfel): S += sH H, CC += cHH H⊗H + cHC (H⊗C⁻¹ + C⁻¹⊗H).
  /// `FH` = F H (its Piola push-forward, used in Piola form only).
  void add_structure(const Mat3& H, const Mat3& FH, double sH, double cHH, double cHC);
  /// Adds the isotropic terms and writes S (material form) or P (piola form) into `stress`.
  void finish(double sI, double sC, double cII, double cIC, double cCC, double cS, Mat3& stress);

 private:
  Form form_;
  const Mat3& F_;
  const Mat3& Ci_;
  Mat9* T_;
  Mat3 S_fibers_ = Mat3::Zero();  // Σ sM_f M_f
  Vec9 z_ = Vec9::Zero();         // Σ cMC_f vec(M_f) (material) or vec(F M_f) (piola)
  bool T_written_ = false;        // *T_ holds a partial sum (else it is assigned, not accumulated)
};

/// Adapts an ElasticLaw to the Material interface (no internal state).
class HyperelasticMaterial final : public Material {
 public:
  explicit HyperelasticMaterial(ElasticLawPtr law) : law_(std::move(law)) {}
  std::string describe() const override { return law_->describe(); }
  MaterialStatus evaluate(const Mat3& F, const double* state_old, double* state_new, double dt, Mat3& P,
                          Mat9* A) const override;
  double initial_shear_modulus() const override { return law_->initial_shear_modulus(); }
  double initial_bulk_modulus() const override { return law_->initial_bulk_modulus(); }
  // Every law of laws.hpp adds W_V(J) with K = its initial bulk modulus.
  double volumetric_modulus() const override { return law_->initial_bulk_modulus(); }
  std::vector<Vec3> fiber_directions() const override { return law_->fiber_directions(); }
  double limit_margin(const Mat3& F) const override { return law_->limit_margin(F); }
  bool has_compact_linearization() const override { return law_->has_compact_linearization(); }
  bool compact_linearization(const Mat3& F, CompactLinearization& L) const override {
    return law_->compact_linearization(F, F.transpose() * F, F.determinant(), L);
  }
  std::unique_ptr<Material> rotated(const Mat3& Q) const override {
    return std::make_unique<HyperelasticMaterial>(ElasticLawPtr(law_->rotated(Q)));
  }
  const ElasticLaw& law() const { return *law_; }

 private:
  ElasticLawPtr law_;
};

}  // namespace softhom
