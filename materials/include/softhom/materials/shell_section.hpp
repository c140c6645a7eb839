#pragma once
// The material side of thin shells: any softhom law condensed to plane stress (S33 = 0), and the
// layered shell section that integrates it through the thickness (docs/model.md, "Thin shells").
//
// Everything here lives in a local orthonormal frame of the shell point: e1, e2 tangent to the
// reference mid-surface, e3 its normal. In-plane strains and stresses are in Voigt form
//   E = [E11, E22, 2 E12]  (Green–Lagrange),   S = [S11, S22, S12]  (second Piola–Kirchhoff),
// so that S·dE is the work increment and the tangent dS/dE is symmetric for a hyperelastic law.
// A law's fiber directions are read in that same local frame (helpers at the end build a layer's law
// from fiber angles).
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "softhom/materials/library.hpp"
#include "softhom/materials/material.hpp"

namespace softhom {

using Vec3v = Eigen::Vector3d;                 ///< in-plane Voigt vector [11, 22, 12]
using Mat3v = Eigen::Matrix3d;                 ///< 3x3 matrix on in-plane Voigt vectors
using Vec6v = Eigen::Matrix<double, 6, 1>;     ///< [N; M] or [ε; κ]
using Mat6v = Eigen::Matrix<double, 6, 6>;     ///< d[N; M]/d[ε; κ]
using Mat2 = Eigen::Matrix2d;
using Mat32 = Eigen::Matrix<double, 3, 2>;

/// How the through-thickness stress S33 = 0 is enforced.
enum class PlaneStressMode {
  /// The law as it is (with its bulk modulus K): the thickness stretch λ3 is solved from S33 = 0 by a
  /// safeguarded Newton iteration. Pointwise, so no locking even at K/G = 1e5.
  compressible,
  /// J = 1 exactly: λ3 = 1/sqrt(det C2); the law's volumetric energy W_V (volumetric_modulus()) is
  /// removed and replaced by the pressure that makes S33 = 0. The dissertation's shell model (§2.3).
  incompressible,
};

/// Result of one plane-stress evaluation.
struct PlaneStressPoint {
  Vec3v S = Vec3v::Zero();  ///< [S11, S22, S12]
  Mat3v D = Mat3v::Zero();  ///< condensed consistent tangent dS/dE (E in Voigt [E11, E22, 2E12])
  /// Thickness stretch. On input: the starting guess of the compressible Newton iteration when > 0
  /// and J is not given; ignored in incompressible mode.
  double lambda3 = 0.0;
  /// Volume ratio det F = λ3 sqrt(det C2). On input, when > 0: the compressible mode starts from
  /// λ3 = J / sqrt(det C2), preferred to lambda3 as a warm start (the previous step's J at this point):
  /// near incompressibility J moves by O(G/K) between steps where λ3 moves with the strain.
  double J = 0.0;
  /// Incompressible mode: the pressure p of S = S_rest(C) − p C⁻¹ (0 in compressible mode).
  double pressure = 0.0;
  /// |S33| / max(|S|, G0) at the returned λ3 (G0 the law's initial shear modulus). When ok: ≤ 1e-10,
  /// or at the round-off floor of the law's pressure (≈ 32 ε K / max(|S|, G0), larger only for K/G
  /// beyond ≈ 1e5) where Newton can no longer move λ3.
  double residual = 0.0;
  int iterations = 0;      ///< law evaluations spent on λ3 (incompressible: 1)
  bool converged = false;  ///< false when the Newton iteration for λ3 did not converge (status not_finite)
};

/// Condenses `law` to plane stress at the in-plane Green–Lagrange strain E (local frame; see the file
/// comment): F = U ⊕ λ3 with U = sqrt(I + 2E) the in-plane right stretch (laws are objective).
/// `state_old` / `state_new` as in Material::evaluate (state_new is meaningful on success only: it is
/// that of the law's evaluation at the returned λ3). Returns the law's status (locking, inverted,
/// not_finite), locking for a compressible equilibrium within 1e-3 of the law's limit (limit_margin),
/// or not_finite when λ3 did not converge; on any non-ok status out.S and out.D are zero (never NaN)
/// and out.lambda3 is the last admissible iterate or the starting guess. Thread-safe like the law.
MaterialStatus plane_stress(const Material& law, const Vec3v& E, const double* state_old, double* state_new,
                            double dt, PlaneStressMode mode, PlaneStressPoint& out);

/// Cauchy stress σ = J⁻¹ F S Fᵀ of a shell point from its in-plane S, the in-plane deformation F (3x2:
/// the images of e1 and e2, in whatever frame the caller wants σ) and λ3; J = λ3 sqrt(det FᵀF).
Mat3 shell_cauchy_stress(const Vec3v& S, const Mat32& F, double lambda3);
/// The same with a 2x2 in-plane F (σ then has zero third row and column).
Mat3 shell_cauchy_stress(const Vec3v& S, const Mat2& F, double lambda3);

/// One layer of a shell section.
struct ShellLayer {
  MaterialPtr law;
  double thickness = 0.0;  ///< reference thickness [mm]
  int points = 3;          ///< integration points through this layer
};

/// Integration rule through each layer.
enum class ThicknessRule {
  /// Gauss–Lobatto (3 points = Simpson), 2..5 points: the layer's bottom and top faces are points, so
  /// the surface and interface stresses (the largest in bending) are output directly; exact for
  /// polynomials of degree 2n − 3 (Simpson integrates the linear-elastic moments exactly).
  lobatto,
  /// Gauss–Legendre, 1..5 points: exact to degree 2n − 1, no point on the faces.
  gauss,
};

/// A through-thickness point of a section evaluation, for the element's reports.
struct SectionPoint {
  int layer = 0;
  double z = 0.0;                ///< reference distance from the mid-surface of the whole stack
  Vec3v S = Vec3v::Zero();       ///< [S11, S22, S12] at this point
  double lambda3 = 1.0;          ///< thickness stretch at this point
  double J = 0.0;                ///< volume ratio at this point (the warm start; 0 = none)
};

/// Result of one section evaluation; reuse one object so that `points` is not reallocated.
struct SectionResponse {
  Vec3v N = Vec3v::Zero();        ///< membrane forces ∫ S dz per unit reference length [N/mm]
  Vec3v M = Vec3v::Zero();        ///< moments ∫ z S dz per unit reference length [N]
  Mat6v tangent = Mat6v::Zero();  ///< d[N; M]/d[ε; κ] (when asked for)
  /// Per point, bottom to top. On input, when it already holds num_points() entries, their J are the
  /// starting guesses of the compressible thickness iteration (warm start; see PlaneStressPoint::J).
  std::vector<SectionPoint> points;
  double thickness_stretch = 1.0;  ///< current / reference thickness, ∫ λ3 dz / h
  int failed_point = -1;           ///< index of the first point whose law failed (status non-ok)
};

/// A layered Kirchhoff–Love section: E(z) = ε + z κ with z measured from the mid-surface of the whole
/// stack (layers given bottom to top), each layer integrated with its own points.
class ShellSection {
 public:
  /// Throws InputError naming "<field>[i].thickness" / "<field>[i].points" / "<field>[i].law" on bad
  /// layers (no layers, thickness ≤ 0 or not finite, points outside the rule's range, null law).
  explicit ShellSection(std::vector<ShellLayer> layers, PlaneStressMode mode = PlaneStressMode::incompressible,
                        ThicknessRule rule = ThicknessRule::lobatto, const std::string& field = "shell.layers");

  double thickness() const { return thickness_; }
  int num_points() const { return int(z_.size()); }
  const std::vector<ShellLayer>& layers() const { return layers_; }
  PlaneStressMode mode() const { return mode_; }
  /// Reference z, weight (dz) and layer of point p.
  double z(int p) const { return z_[p]; }
  double weight(int p) const { return w_[p]; }
  int layer_of(int p) const { return layer_[p]; }

  /// Σ over points of the law's state size: 0 when every layer is elastic (no storage needed).
  int state_size() const { return state_size_; }
  void init_state(double* state) const;

  /// N, M and (want_tangent) their tangent at membrane strain ε and curvature change κ (Voigt, κ12
  /// engineering: E(z) = ε + z κ). Returns ok or the first failing point's status (out.failed_point);
  /// then N, M, tangent are zero, never NaN. state_new is meaningful only on success (points before the
  /// failing one have written theirs). Const and allocation-free once out.points has its size.
  MaterialStatus evaluate(const Vec3v& eps, const Vec3v& kappa, const double* state_old, double* state_new,
                          double dt, bool want_tangent, SectionResponse& out) const;

 private:
  std::vector<ShellLayer> layers_;
  PlaneStressMode mode_;
  double thickness_ = 0.0;
  std::vector<double> z_, w_;
  std::vector<int> layer_, state_offset_;
  int state_size_ = 0;
};

// ---- fiber directions of a layer --------------------------------------------------------------
// Angles are in degrees, measured from e1 towards e2 in the tangent plane: α ↦ (cos α, sin α, 0).

/// Unit vector at `angle_deg` from e1 in the (e1, e2) plane.
Vec3 in_plane_direction(double angle_deg);
/// Rotation about e3 by `angle_deg`.
Mat3 rotation_about_normal(double angle_deg);
/// `law` with every fiber direction turned by `angle_deg` about the normal (Material::rotated).
MaterialPtr rotated_about_normal(const MaterialPtr& law, double angle_deg);
/// The law described by `spec` (Gent-HGO) with one fiber family per angle, each along
/// in_plane_direction(angle): with one family in spec.gent.fibers its k1, k2, κ serve every angle,
/// with as many families as angles each keeps its own. Validated (InputError naming
/// "<prefix>.fibers" on a mismatch or a law without fibers).
MaterialPtr layer_material(MaterialSpec spec, std::span<const double> angles_deg);

}  // namespace softhom
