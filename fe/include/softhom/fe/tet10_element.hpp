#pragma once
// Quadratic (10-node) tetrahedron kernels at finite strain, for meshes from outside (Gmsh).
//
// Same formulation as hex8.hpp: P2 displacement with one dilatation per element (mean-dilatation
// F-bar, F̄_g = (θ/J_g)^{1/3} F_g with θ = v_e / V_e), i.e. the P2/P0 pair, which satisfies the
// inf-sup condition (unlike Q1/P0 it has no checkerboard pressure mode), and the residual is the exact
// variation of Σ_g w_g W(F̄_g), so the tangent is the consistent Hessian. With `mixed`, the condensed
// three-field (u, θ, p) iteration of MixedVolume (hex8.hpp) replaces the F-bar volumetric terms, so
// that K/G ~ 1e5 does not wreck Newton. Integration: the 4-point degree-2 rule of tet10.hpp (exact
// stiffness for straight-sided elements and constant moduli). History: 4 Gauss points per element.
//
// Boundary faces are 6-node triangles (kTet10Faces order). Follower pressure uses a 6-point
// degree-4 rule, exact for the area vector ∫ N_a n da and the volume flux of a quadratic face.
#include <array>

#include <Eigen/Core>

#include "softhom/fe/hex8.hpp"
#include "softhom/fe/tet10.hpp"
#include "softhom/materials/material.hpp"

namespace softhom::fe {

using Tet10Coords = Eigen::Matrix<double, 10, 3>;  ///< row a: node a (coordinates or displacement)
using Vec30 = Eigen::Matrix<double, 30, 1>;
using Mat30 = Eigen::Matrix<double, 30, 30>;
using Mat63 = Eigen::Matrix<double, 6, 3>;
using Vec18 = Eigen::Matrix<double, 18, 1>;
using Mat18 = Eigen::Matrix<double, 18, 18>;

/// Reference-configuration data of one tet10 at its 4 Gauss points (computed once per element).
struct Tet10Geometry {
  std::array<Tet10Grad, 4> dN;  ///< ∂N_a/∂X_J at each Gauss point (row a)
  std::array<double, 4> w;      ///< rule weight × det(∂X/∂ξ)
  double volume = 0.0;
  bool valid = false;           ///< every det(∂X/∂ξ) > 0
};
Tet10Geometry tet10_geometry(const Tet10Coords& X);

/// Deformation gradients at the Gauss points (F̄ for fbar) and the volume ratio θ.
struct Tet10Kinematics {
  std::array<Mat3, 4> F;
  double theta = 1.0;
  bool ok = false;  ///< all J > 0
};
Tet10Kinematics tet10_kinematics(const Tet10Geometry& g, const Tet10Coords& u, Formulation f);

/// The element variables of the three-field iteration (see MixedVolume in hex8.hpp), 30 dofs.
struct Tet10MixedVolume {
  double bulk = 0.0;     ///< in: K of U
  double theta = 1.0;    ///< in: element dilatation iterate θ
  double p = 0.0;        ///< in: element pressure iterate p
  double theta_u = 1.0;  ///< out: θ_e(u)
  double shift = 0.0;    ///< out: r (returned) − r_fbar = shift · d
  double shift_u = 0.0;  ///< out: r (returned) − r_u = shift_u · d
  Vec30 d;               ///< out: ∂θ_e/∂u
};

/// Internal force r_e (30, node-major: 3a + i) and, when K is non-null, the consistent tangent
/// ∂r_e/∂u_e; arguments as hex8_internal_force (history: 4 × state_size doubles, Gauss-point major).
MaterialStatus tet10_internal_force(const Tet10Geometry& g, const Tet10Coords& u, const Material& material,
                                    const double* state_old, double* state_new, double dt, Formulation f, Vec30& r,
                                    Mat30* K, Mat3* cauchy_mean = nullptr, Tet10MixedVolume* mixed = nullptr);

/// Unit-pressure area vector of a 6-node triangle in the current configuration, a_a = ∫ N_a n da
/// (n along x_ξ × x_η, outward for kTet10Faces), its derivative ∂a/∂x (18x18, when non-null), and the
/// flux Φ = ∫ (c ⊙ x) · n da used for enclosed volumes (see quad4_pressure).
/// dflux (optional): ∂Φ/∂x_a (see quad4_pressure).
void tri6_pressure(const Mat63& x, const Vec3& mask, Vec18& a, Mat18* da, double& flux, Vec18* dflux = nullptr);

}  // namespace softhom::fe
