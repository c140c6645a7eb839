#pragma once
// The thin-walled kinematic model of a fiber-reinforced elastomeric enclosure (Bishop-Moser, Krishnan
// & Kota 2012–2015: the fibers' inextensibility leaves the tube a one- or two-parameter family of
// homogeneous deformations; Connolly, Walsh & Bertoldi, PNAS 2017: the matrix energy along that family
// against the pressure's work fixes where it sits). The tube's wall (inner radius R_i, outer R_o,
// length L) deforms homogeneously: hoop stretch λ_θ and axial stretch λ_z of its mid-surface, and a
// twist τ (θ = Θ + τ Z); the matrix is an incompressible neo-Hookean solid of shear modulus G whose
// energy is that of the mid-surface over the wall's volume; the fibers at the mid radius are
// inextensible, (λ_θ sin α + κ cos α)² + (λ_z cos α)² = 1 with κ = λ_θ R τ the shear, for each family
// (±α: κ = 0). The cavity is the inner radius after the wall's incompressible deformation. Stationary
// Π = V_wall W − p V_cavity along the constraint gives the state at pressure p.
//
// What it leaves out (where a thick wall parts from it): the stretch varies through the wall (λ_θ ∝ 1/r
// at the inner surface grows fastest), the fibers sit at one radius, and the ends (clamp, cap) hold
// the tube near them; so compare with a finite-element tube's middle, away from the ends.

namespace softhom::macro {

struct ThinTubeState {
  double hoop_stretch = 1.0, axial_stretch = 1.0;
  double twist_per_length = 0.0;  ///< τ [rad/mm]
  double fiber_angle_deg = 0.0;   ///< current angle of the (+α) fibers from the axis
};

struct ThinTube {
  double inner_radius = 5.0, outer_radius = 5.5;
  double shear_modulus = 0.1;  ///< G [MPa]
  double angle_deg = 45.0;     ///< α from the axis, in (0, 90)
  bool double_helix = true;
};

/// The state at pressure p [MPa] (Newton on the stationarity, from the undeformed state continued in p).
ThinTubeState thin_tube_state(const ThinTube& tube, double pressure);

}  // namespace softhom::macro
