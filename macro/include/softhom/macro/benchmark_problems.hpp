#pragma once
// The complete problems (mesh, law, supports, load) the macro tests and benchmarks share: Cook's
// membrane, the standard benchmark of nearly incompressible bending with shear, and the capped
// fiber-reinforced helix tube under follower pressure.
#include "softhom/fe/model.hpp"
#include "softhom/macro/structures.hpp"
#include "softhom/materials/laws.hpp"

namespace softhom::macro {

/// make_cook_membrane(n) in plane strain (z fixed at every node), clamped at x = 0 (x and y), neo-Hooke
/// with shear modulus G and bulk modulus bulk_over_shear · G, and a total shear force `shear_force`
/// (along y) on the tip face x = 48 as consistent nodal forces of a uniform traction, ramped by the
/// load factor 0 → 1 over t ∈ [0, 1]. The formulation is the model's default. With `tet10` every hex is
/// split into six 10-node tets (fe::hex_to_tet10; the P2/P0 pair of the device scenes).
fe::FeModel make_cook_membrane_problem(int n, double G, double bulk_over_shear, double shear_force, bool tet10 = false);

/// The y dof of the tip corner (48, 60, 0) of the hex mesh, where Cook's deflection is read.
int cook_tip_dof(int n);
/// The node at the tip corner (48, 60, 0) of either mesh, or −1.
int cook_tip_node(const fe::Mesh& mesh);

/// The helix tube's law: Gent–HGO (Ecoflex, G = 0.017, Jm = 14, K = bulk_over_shear · G, two fiber
/// families at ±45° to the axis, k1 0.8, k2 18, in the cylindrical frame).
GentHGOParams helix_tube_law(double bulk_over_shear);

/// The capped ±45° tube: R_i 5, R_o 7.5, L 50, caps 2.5 thick (their cores' innermost ring of degenerate
/// hexes), near-cubic cells sized for about `dofs` free dofs; helix_tube_law(bulk_over_shear); follower
/// pressure ramped to 0.004 over t ∈ [0, 180].
StructureSpec make_helix_tube_spec(double dofs, double bulk_over_shear);

}  // namespace softhom::macro
