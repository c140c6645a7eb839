#pragma once
// Hyperelastic laws written in their natural measure, S(C), with one tested conversion to (P, ∂P/∂F).
#include <memory>

#include "softhom/materials/material.hpp"

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
  virtual std::unique_ptr<ElasticLaw> rotated(const Mat3& Q) const = 0;
};

using ElasticLawPtr = std::shared_ptr<const ElasticLaw>;

/// Common pre-checks of every material call: finite entries and J > 0.
MaterialStatus check_deformation(const Mat3& F, double& J);

/// Adapts an ElasticLaw to the Material interface (no internal state).
class HyperelasticMaterial final : public Material {
 public:
  explicit HyperelasticMaterial(ElasticLawPtr law) : law_(std::move(law)) {}
  std::string describe() const override { return law_->describe(); }
  MaterialStatus evaluate(const Mat3& F, const double* state_old, double* state_new, double dt, Mat3& P,
                          Mat9* A) const override;
  double initial_shear_modulus() const override { return law_->initial_shear_modulus(); }
  double initial_bulk_modulus() const override { return law_->initial_bulk_modulus(); }
  std::vector<Vec3> fiber_directions() const override { return law_->fiber_directions(); }
  std::unique_ptr<Material> rotated(const Mat3& Q) const override {
    return std::make_unique<HyperelasticMaterial>(ElasticLawPtr(law_->rotated(Q)));
  }
  const ElasticLaw& law() const { return *law_; }

 private:
  ElasticLawPtr law_;
};

}  // namespace softhom
