#pragma once
// The material interface every solver (material point, FFT RVE, FE) talks to.
//
// A material is a pure function (F, state_old, Δt) → (P, ∂P/∂F, state_new). Internal state is a plain
// array of doubles owned by the caller (one slice per voxel or quadrature point); a law with
// state_size() == 0 (every elastic law) needs no storage at all, and solvers allocate none for it.
// Calls are const, allocation-free and thread-safe, so a solver may evaluate voxels in parallel.
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "softhom/materials/compact_linearization.hpp"
#include "softhom/materials/tensor.hpp"

namespace softhom {

/// Outcome of one material call. Anything but ok means P/A are not meaningful and the caller must
/// cut back (the call never returns NaN or Inf stresses as "success").
enum class MaterialStatus {
  ok = 0,
  locking,      ///< Gent limit reached: Ī1 − 3 ≥ Jm
  inverted,     ///< J = det F ≤ 0
  not_finite,   ///< non-finite input or a non-finite intermediate (e.g. exp overflow in HGO)
  penetration,  ///< an FE iterate put a surface point through a contact obstacle (fe/contact.hpp)
};
const char* to_string(MaterialStatus s);

class Material {
 public:
  virtual ~Material() = default;

  /// Short description for logs and summary.json.
  virtual std::string describe() const = 0;

  /// Doubles of internal (history) state per material point; 0 = elastic.
  virtual int state_size() const { return 0; }
  /// Writes the state of the undeformed, unloaded material (F = I at t = 0) into `state`.
  virtual void init_state(double* state) const { (void)state; }

  /// Stress P and, when `A` is non-null, the algorithmic tangent A = ∂P/∂F (9x9, see tensor.hpp).
  /// `state_old` / `state_new` point at state_size() doubles (may be null when state_size() == 0);
  /// state_new is written only on success. `dt` is the time step since state_old (ignored by elastic
  /// laws).
  virtual MaterialStatus evaluate(const Mat3& F, const double* state_old, double* state_new, double dt,
                                  Mat3& P, Mat9* A) const = 0;

  /// Whether compact_linearization() is available: isotropic elastic laws written in (I1, J) (see
  /// compact_linearization.hpp). Anisotropic, viscoelastic and any other law: false (the default).
  virtual bool has_compact_linearization() const { return false; }
  /// The tangent at F as F plus five scalars (CompactLinearization), when has_compact_linearization();
  /// returns false otherwise. To be called at an F where evaluate() succeeded (no checks repeated).
  virtual bool compact_linearization(const Mat3& F, CompactLinearization& L) const {
    (void)F;
    (void)L;
    return false;
  }

  /// Small-strain moduli at F = I (instantaneous for viscoelastic laws). Solvers use these to choose
  /// reference media; they are not used to compute stresses.
  virtual double initial_shear_modulus() const = 0;
  virtual double initial_bulk_modulus() const = 0;
  /// K of an additive volumetric energy W_V(J) = (K/4)(J² − 1 − 2 ln J) contained in the law (so that
  /// P = P_rest(F) + W_V′(J) J F⁻ᵀ and no other term depends on it), or 0 when the law has none.
  /// Solvers use it for a mixed (pressure) Newton iteration at near incompressibility.
  virtual double volumetric_modulus() const { return 0.0; }

  /// How far F is from a limit of the law's domain, as a fraction: 1 at F = I, 0 at the limit (Gent:
  /// 1 − (Ī1 − 3)/Jm). Laws without such a limit return 1. Drivers use it to stop cleanly at locking
  /// instead of following a compressible law into the region where only the bulk modulus resists.
  virtual double limit_margin(const Mat3& F) const { (void)F; return 1.0; }

  /// Reference fiber directions (unit vectors), one per fiber family; empty for isotropic laws.
  virtual std::vector<Vec3> fiber_directions() const { return {}; }

  /// The same material with every reference direction a0 replaced by Q a0 (Q a rotation). Used to
  /// express a material in a rotated load frame.
  virtual std::unique_ptr<Material> rotated(const Mat3& Q) const = 0;
};

using MaterialPtr = std::shared_ptr<const Material>;

}  // namespace softhom
