#pragma once
// Batch evaluation of one constitutive law at many material points, for codes that embed softhom's
// laws (an FE² macro solver's quadrature points, a Python script): the law is declared exactly as in a
// scene file (a material table: preset and/or law, parameters, [fibers], [viscoelastic]), and every
// call evaluates n points in parallel (OpenMP over points) without allocating per point.
//
// Conventions (as Material, material.hpp / tensor.hpp):
//  - F, P: 3×3, row-major flattened (component 3 i + j), in the frame the material was declared in
//    (fiber directions a0 of the table are in that frame). Units: P in MPa (the parameters' unit).
//  - A = ∂P/∂F: 9×9 per point, row-major, A[9 a + b] = ∂P_a/∂F_b with a = 3 i + j, b = 3 k + l; the
//    algorithmic (consistent) tangent of the time-discrete update for laws with history (QLV).
//  - State: state_size() doubles per point, owned by the caller, point k at [k · state_size(), ...).
//    Elastic laws have state_size() = 0 and need no arrays. `state_old` is the committed state of the
//    start of the step, `state_new` the trial state at its end: evaluating never modifies state_old, so
//    an FE² Newton iteration re-evaluates from the same committed state until the caller commits (copies
//    or swaps state_new into state_old).
// Thread-safety: a MaterialBatch is immutable after construction; evaluate() may be called from
// several threads at once on distinct output arrays (it opens its own OpenMP parallel region; call it
// from inside a parallel region to run it on that thread only).
#include <cstddef>
#include <string>
#include <vector>

#include <toml++/toml.h>

#include "softhom/materials/material.hpp"

namespace softhom {

/// Outcome of a batch call: how many points failed (status other than ok: Gent locking, inverted F,
/// non-finite), the first of them and its status. P and A of a failed point are zero; its state_new is a
/// copy of its state_old (so a caller that commits anyway keeps a valid state), and the caller should
/// cut back its step as for a failed single-point call.
struct BatchStatus {
  std::size_t failed_points = 0;
  long first_failed_point = -1;  ///< index of the first failed point, −1 when all succeeded
  MaterialStatus first_status = MaterialStatus::ok;
  bool ok() const { return failed_points == 0; }
};

class MaterialBatch {
 public:
  /// Wraps an existing law (shared, immutable). Throws std::invalid_argument on a null pointer.
  explicit MaterialBatch(MaterialPtr material);

  /// From TOML text in scene syntax. `table` is the TOML path of the material table inside the text
  /// ("material", "phases.matrix"); empty: the whole text is the material table. Every error is an
  /// InputError naming the field as a scene file would ("material.G = -1: ...", TOML syntax errors
  /// with line and column).
  static MaterialBatch from_toml(const std::string& toml_text, const std::string& table = "material");
  /// From a parsed material table; `path` names it in error messages.
  static MaterialBatch from_table(const toml::table& material_table, const std::string& path = "material");

  const Material& material() const { return *material_; }
  MaterialPtr material_ptr() const { return material_; }
  std::string describe() const { return material_->describe(); }
  /// Doubles of history per point (0 for elastic laws).
  int state_size() const { return state_size_; }
  /// Small-strain moduli at F = I [MPa] (instantaneous for QLV).
  double initial_shear_modulus() const { return material_->initial_shear_modulus(); }
  double initial_bulk_modulus() const { return material_->initial_bulk_modulus(); }

  /// The state of n undeformed, unloaded points (n · state_size() doubles).
  std::vector<double> initial_state(std::size_t n) const;

  /// Evaluates n points: F (9 n), state_old (n · state_size(), may be null when it is 0), dt [s] since
  /// state_old → P (9 n), A (81 n; null: no tangents), state_new (n · state_size(); may alias
  /// nothing else, may be null when state_size() is 0). No allocation; OpenMP over points.
  BatchStatus evaluate(std::size_t n, const double* F, const double* state_old, double dt, double* P, double* A,
                       double* state_new) const;

  /// The same on vectors: n = F.size() / 9; outputs are resized (only when their size changes).
  /// `A` null: no tangents. Throws InputError("F"/"state_old") when a size does not fit.
  BatchStatus evaluate(const std::vector<double>& F, const std::vector<double>& state_old, double dt,
                       std::vector<double>& P, std::vector<double>* A, std::vector<double>& state_new) const;

 private:
  MaterialPtr material_;
  int state_size_ = 0;
};

}  // namespace softhom
