#pragma once
// Cook's membrane as a complete test problem (mesh, law, supports, load): the standard benchmark of
// nearly incompressible bending with shear, used by the macro tests and the PETSc benchmark.
#include "softhom/fe/model.hpp"

namespace softhom::macro {

/// make_cook_membrane(n) in plane strain (z fixed at every node), clamped at x = 0 (x and y), neo-Hooke
/// with shear modulus G and bulk modulus bulk_over_shear · G, and a total shear force `shear_force`
/// (along y) on the tip face x = 48 as consistent nodal forces of a uniform traction, ramped by the
/// load factor 0 → 1 over t ∈ [0, 1]. The formulation is the model's default.
fe::FeModel make_cook_membrane_problem(int n, double G, double bulk_over_shear, double shear_force);

/// The y dof of the tip corner (48, 60, 0), where Cook's deflection is read.
int cook_tip_dof(int n);

}  // namespace softhom::macro
