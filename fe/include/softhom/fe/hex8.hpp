#pragma once
// Trilinear hexahedron kernels at finite strain.
//
// Locking-free formulation: a variational mean-dilatation F-bar. With θ = v_e / V_e the element's
// volume ratio (the volume average of J), every Gauss point uses F̄ = (θ/J)^{1/3} F, so the volumetric
// response sees one dilatation per element (the Q1/P0 constraint count, Nagtegaal et al. 1974, Simo
// et al. 1985). The residual is the exact variation of Π_e = Σ_g w_g W(F̄_g), r = Σ_g w_g M_gᵀ P(F̄_g)
// with M_g = ∂vec(F̄_g)/∂u_e, so for a hyperelastic law the tangent is the (symmetric) Hessian and
// CHOLMOD applies. It needs only (F → P, ∂P/∂F) from the Material, so any law works (unlike a
// three-field Q1/P0 with an isochoric/volumetric split of W).
#include <array>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "softhom/materials/material.hpp"
#include "softhom/materials/volumetric.hpp"

namespace softhom::fe {

using Mat83 = Eigen::Matrix<double, 8, 3>;
using Vec24 = Eigen::Matrix<double, 24, 1>;
using Mat24 = Eigen::Matrix<double, 24, 24>;
using Mat43 = Eigen::Matrix<double, 4, 3>;
using Vec12 = Eigen::Matrix<double, 12, 1>;
using Mat12 = Eigen::Matrix<double, 12, 12>;

enum class Formulation {
  standard,  ///< plain displacement Q1 (locks when nearly incompressible; kept for comparison)
  fbar,      ///< mean-dilatation F-bar (default)
};

/// Reference-configuration data of one hex8 at its 2×2×2 Gauss points (computed once per element).
struct Hex8Geometry {
  std::array<Mat83, 8> dN;  ///< ∂N_a/∂X_J at each Gauss point (row a)
  std::array<double, 8> w;  ///< Gauss weight × det(∂X/∂ξ)
  double volume = 0.0;
  bool valid = false;       ///< every det(∂X/∂ξ) > 0
};

Hex8Geometry hex8_geometry(const Mat83& X);

/// Shape functions at the reference point ξ.
Eigen::Matrix<double, 8, 1> hex8_shape(const Vec3& xi);
/// ∂N_a/∂ξ_J at the reference point ξ (row a).
Mat83 hex8_shape_derivatives(const Vec3& xi);

/// Deformation gradients at the Gauss points (F̄ for fbar) and the volume ratio θ.
struct Hex8Kinematics {
  std::array<Mat3, 8> F;
  double theta = 1.0;
  bool ok = false;  ///< all J > 0
};
Hex8Kinematics hex8_kinematics(const Hex8Geometry& g, const Mat83& u, Formulation f);

/// Element variables of the three-field (u, θ, p) Newton iteration of a law with an additive
/// volumetric energy U(J) = (K/4)(J² − 1 − 2 ln J) (Material::volumetric_modulus()). The F-bar
/// energy is Σ_g w_g W_rest(F̄_g) + V_e U(θ_e(u)) exactly (det F̄_g = θ_e), so replacing V_e U(θ_e) by
/// V_e U(θ) + p V_e (θ_e(u) − θ) with element unknowns θ, p (Simo–Taylor–Pister Q1/P0) has the same
/// solution. Condensing θ and p gives the residual r_rest + V_e p̃ d, p̃ = U′(θ) + U″(θ)(θ_e − θ),
/// and the tangent K_rest + V_e p H + V_e U″(θ) d dᵀ (d = ∂θ_e/∂u, H = ∂²θ_e/∂u²). What it buys:
/// the geometric stiffness uses the iterate p, not U′(θ_e(u)) — after a large displacement-based
/// step θ_e(u) − 1 carries an O(ε²) error that K/G ~ 1e5 turns into a spurious pressure far above the
/// shear stresses, which wrecks the pure F-bar tangent (non-positive, Newton overshoots).
struct MixedVolume {
  double bulk = 0.0;     ///< in: K of U
  double theta = 1.0;    ///< in: element dilatation iterate θ
  double p = 0.0;        ///< in: element pressure iterate p
  double theta_u = 1.0;  ///< out: θ_e(u) = v_e / V_e
  double shift = 0.0;    ///< out: r (returned) − r_fbar = shift · d
  double shift_u = 0.0;  ///< out: r (returned) − r_u = shift_u · d, r_u = r_rest + V p d (u-row of the 3-field residual)
  Vec24 d;               ///< out: ∂θ_e/∂u
};

/// Internal force r_e (24, node-major: 3a + i) and, when K is non-null, the consistent tangent
/// ∂r_e/∂u_e. With `mixed` (F-bar only) r and K are those of the condensed three-field iteration. History: `state_old`/`state_new` hold 8 × state_size doubles (Gauss-point major) or
/// are null when the material is elastic. A non-ok status leaves r/K unspecified.
MaterialStatus hex8_internal_force(const Hex8Geometry& g, const Mat83& u, const Material& material,
                                   const double* state_old, double* state_new, double dt, Formulation f,
                                   Vec24& r, Mat24* K, Mat3* cauchy_mean = nullptr, MixedVolume* mixed = nullptr);

/// Unit-pressure area vector of a bilinear quad in the current configuration, a_a = ∫ N_a n da
/// (n along x_ξ × x_η), its derivative ∂a/∂x (12x12, when non-null), and the flux
/// Φ = ∫ (c ⊙ x) · n da used for enclosed volumes (exact with 2×2 Gauss for bilinear faces).
/// dflux (optional): ∂Φ/∂x_a, the exact gradient of the flux (the enclosed-volume derivative; it equals
/// the sum of a over a closed surface, but not on an open one whose closing plane moves).
void quad4_pressure(const Mat43& x, const Vec3& mask, Vec12& a, Mat12* da, double& flux, Vec12* dflux = nullptr);

}  // namespace softhom::fe
