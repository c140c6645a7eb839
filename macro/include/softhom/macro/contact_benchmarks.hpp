#pragma once
// The contact problems the tests and bench/contact_hertz.cpp share.
#include <memory>
#include <vector>

#include "softhom/fe/contact.hpp"
#include "softhom/fe/model.hpp"
#include "softhom/fe/surface_contact.hpp"

namespace softhom::macro {

/// Hertz indentation (Hertz 1882; Johnson 1985, §4.2): a rigid sphere of radius R = 1 pressed into a flat
/// neo-Hookean solid (G = 1, ν = 0.3 at small strain) by `depth` · t over t ∈ [0, 1], frictionless. The
/// solid is the quarter x, y ≥ 0 of a block [0, L]² × [−L, 0] with L = 20 a (a = √(R depth) the final
/// contact radius) on symmetry planes x = 0, y = 0 and a frictionless bottom; `fine` cells span 1.25 a
/// uniformly along x, y and z, `coarse` cells grow geometrically from there to L.
struct HertzProblem {
  fe::FeModel model;
  std::shared_ptr<const fe::ObstacleContact> contact;
  double radius = 1.0;
  double depth = 0.0;
  double effective_modulus = 0.0;  ///< E* = E / (1 − ν²) (the sphere rigid)
  /// Hertz's whole-sphere force at indentation d: (4/3) E* √R d^{3/2}.
  double force(double d) const;
  /// Hertz's contact radius at force F: (3 F R / (4 E*))^{1/3}.
  double contact_radius(double force) const;
};
HertzProblem make_hertz_problem(int fine, int coarse, double depth = 0.01);

/// Hertz contact of two elastic spheres (Hertz 1882; Johnson 1985, §4.2): radii R1 = 1 (the upper body,
/// neo-Hookean G1 = 1) and R2 = 2 (the lower, G2 = 2), both ν = 0.3 at small strain, pressed together by
/// `approach` · t over t ∈ [0, 1], frictionless, through the contact between deformable surfaces
/// (fe/surface_contact.hpp: the upper's points against the lower's faces). Each body is the quarter
/// x, y ≥ 0 of a graded block of side L = 10 a (a = √(R* approach) the final contact radius; `fine`
/// cells span 1.25 a, `coarse` cells grow to L) whose facing surface is mapped onto its sphere (the
/// depth mapping fading linearly to the flat far face), touching at the origin at t = 0; symmetry planes
/// x = 0, y = 0, the lower body's far face held in z, the upper's moved down by the approach. Hertz's law
/// has F = (4/3) E* √R* δ^{3/2} and a = (3 F R* / (4 E*))^{1/3} with 1/R* = 1/R1 + 1/R2 and
/// 1/E* = (1 − ν1²)/E1 + (1 − ν2²)/E2.
struct HertzSpheresProblem {
  fe::FeModel model;
  std::shared_ptr<const fe::SurfaceContact> contact;
  double radius1 = 1.0, radius2 = 2.0;
  double approach = 0.0;
  double effective_radius = 0.0;   ///< R*
  double effective_modulus = 0.0;  ///< E*
  double fine_size = 0.0;          ///< the fine cells' size h
  /// Hertz's whole-sphere force at approach δ and contact radius at force F.
  double force(double delta) const;
  double contact_radius(double force) const;
};
HertzSpheresProblem make_hertz_spheres_problem(int fine, int coarse, double approach = 0.006);

/// Ironing after Puso & Laursen (2004, CMAME 193, the ironing example): a die pressed 1.0 into a soft
/// neo-Hookean block (E = 1, ν = 0.3) over t ∈ [0, 1] and slid 10 along it over t ∈ [1, 2], Coulomb
/// friction μ = 0.3. Here the die is rigid (a cylinder of radius 3 across the block's width, axis along
/// y) and the block [0, 15] × [0, 3] × [0, 4] longer than the published 9 so that the die, starting
/// 2.5 from its left end, slides the whole 10 on it; bottom fixed, u_y = 0 on both sides (the die spans
/// the width: plane strain); `cells` hex8 per unit length; the default normal penalty, a tenth of it
/// tangentially.
struct IroningProblem {
  fe::FeModel model;
  std::shared_ptr<const fe::ObstacleContact> contact;
  double depth = 1.0, slide = 10.0, friction = 0.3;
};
IroningProblem make_ironing_problem(int cells, double friction = 0.3);

/// The Hertz coefficient of indentation data beyond a far-field compliance: the least-squares fit
/// d = α F^{2/3} + C F (C F the displacement of the finite block's far field, linear in the total force
/// where a ≪ L) returns α; Hertz's is (3 / (4 E* √R))^{2/3}.
double hertz_coefficient(const std::vector<double>& force, const std::vector<double>& indentation,
                         double* compliance = nullptr);

}  // namespace softhom::macro
