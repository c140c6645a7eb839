#pragma once
// Geometrically nonlinear shell benchmarks of Sze, Liu & Lo (2004), "Popular benchmark problems for
// geometric nonlinear analysis of shells", Finite Elements in Analysis and Design 40:1551–1569, built
// for the rotation-free triangle (fe/shell.hpp), shared by the tests and bench_shell_nonlinear.
// Their laws are linear elastic (small strain, large rotation); here a compressible neo-Hookean law with
// the same small-strain moduli, plane stress by S33 = 0 (it departs from St Venant–Kirchhoff at second
// order in the strain: below 1e-3 of the response at these problems' strains of at most 3 %).
#include <array>
#include <memory>

#include "softhom/macro/structures.hpp"

namespace softhom::macro {

/// The node of `mesh` nearest to p (a benchmark's load or probe point).
int nearest_node(const fe::Mesh& mesh, const Vec3& p);

/// build_structure of a shell without pressure (spec.shell as given; the load is point forces and
/// moments the caller adds).
Structure build_unpressurized_shell(StructureSpec spec);

/// A one-layer section of a compressible neo-Hookean law with the small-strain moduli of (E, ν).
std::shared_ptr<const ShellSection> small_strain_shell_section(double E, double nu, double thickness);

/// The hemisphere with an 18° hole under alternating radial point forces (Sze et al. 2004): R = 10,
/// t = 0.04, E = 6.825e7, ν = 0.3, forces of P = 400 outward along x at A = (R, 0, 0) and inward along y
/// at B = (0, R, 0), dead, ramped over t ∈ [0, 1]. The quarter x, y ≥ 0 (cells² grid), symmetry edges
/// x0 and y0 (each carries half of its point's force), equator and hole free, u_z = 0 at A against the
/// rigid translation along z.
struct PinchedHemisphere {
  Structure structure;
  int node_a = -1, node_b = -1;
};
PinchedHemisphere make_pinched_hemisphere(int cells, double force = 400.0);
/// Sze et al. (2004), the hemisphere's table of radial deflections, at P = 400: the outward
/// displacement of A and the inward displacement of B.
inline constexpr double kHemisphereUaAt400 = 4.067, kHemisphereUbAt400 = 8.178;

/// The open-ended cylinder pulled out by two opposite radial forces at mid-length (Sze et al. 2004):
/// R = 4.953, L = 10.35, t = 0.094, E = 10.5e6, ν = 0.3125, P_max = 40 000, dead, ramped over
/// t ∈ [0, 1]. The eighth 0 ≤ θ ≤ 90°, 0 ≤ z ≤ L/2 with z = 0 the mid-length plane (cells_around ×
/// cells_axial, one diagonal): symmetry edges theta0 (y = 0), theta1 (x = 0) and z0, the end z1 free; P/4
/// outward along y at A = (0, R, 0). Probes: A's outward w_A, and the inward −u_x at B = (R, 0, 0) and at
/// C = (R, 0, L/2) on the free end.
struct PulloutCylinder {
  Structure structure;
  int node_a = -1, node_b = -1, node_c = -1;
};
PulloutCylinder make_pullout_cylinder(int cells_around, int cells_axial, double force = 40000.0);
/// Sze et al. (2004), the pull-out's table at P = 40 000: w_A, −u_B, −u_C.
inline constexpr double kPulloutWaAt40k = 2.768, kPulloutUbAt40k = 4.551, kPulloutUcAt40k = 3.269;

/// The cantilever strip rolled up by an end moment (Sze et al. 2004): L = 12, W = 1, t = 0.1,
/// E = 1.2e6, ν = 0, clamped at x = 0, moment about −y at x = L ramped to `fraction` · M_max over
/// t ∈ [0, 1], M_max = 2π E I / L = 50π/3 (the strip closes into a circle), as fe::ShellEdgeMoment on the
/// edge xmax. Grid of cells × cells_across, one diagonal.
struct RolledCantilever {
  Structure structure;
  int tip_node = -1;  ///< the tip node at y = 0
  std::shared_ptr<const fe::ShellEdgeMoment> moment;
  double length = 12.0, bending_stiffness = 100.0, max_moment = 0.0;
  /// Euler's closed form of the tip (u, w) at moment M: the strip bends into an arc of curvature
  /// M / (E I), θ = M L / (E I): u = L (sin θ / θ − 1), w = L (1 − cos θ) / θ.
  std::array<double, 2> tip(double M) const;
};
/// hold_lateral: u_y = 0 at every node (the exact solution's, ν = 0). The mesh's one diagonal direction
/// couples the patch curvature's large-rotation error into twist, so that the free strip drifts sideways
/// as it rolls (|u_y| ≈ the width at M ≈ 0.85 M_max on 24 × 4 cells) and its helical path has a limit
/// point short of M_max; held, it rolls into the full circle (BENCHMARKS.md "Thin shells").
RolledCantilever make_rolled_cantilever(int cells, int cells_across, double fraction, bool hold_lateral = false);

/// A thin tube (mid radius R, wall H, length L) held at the axial stretch λz = 1 (both ends at u_z = 0),
/// inflated by a follower pressure ramped to `pressure` over t ∈ [0, 1], as a quarter: either the
/// shell (cylinder, `cells` × 2, symmetry edges, cylindrical frame: e1 hoop, e2 axial) under the
/// pressure on its mid-surface, or the tet10 solid (`cells` × 1 radial × `axial_cells`, the law's frame
/// (hoop, axial, radial) per element) under the pressure on its inner wall. The law's fibers are given
/// in that frame in both. radius_nodes: the shell's nodes, or the solid's on the reference mid-surface;
/// end_dofs: the z dofs at z = L (their reaction is the axial force of the quarter).
struct ThinWallTube {
  Structure structure;
  std::vector<int> radius_nodes, end_dofs;
  /// Mean current distance of radius_nodes from the axis.
  double radius(const fe::Simulation& sim) const;
};
/// The thin tubes' wall law: Gent–HGO with G = 1, K = 1000, Jm = 1e4 (practically neo-Hookean), and
/// with `fibers` two families at ±40° from the hoop direction (k1 = 2, k2 = 1, isochoric invariant),
/// given in the frame (hoop, axial, radial).
MaterialPtr thin_wall_tube_law(bool fibers);
/// Cauchy stress of a law in the frame (hoop, axial, radial) at the hoop stretch λ, λz = 1, λr = 1/λ
/// (J = 1): the state of an incompressible tube's wall at a fixed axial stretch.
Mat3 tube_wall_cauchy(const Material& law, double hoop_stretch);
struct ThinWallTubeSize {
  double radius = 10.0, wall = 0.2, length = 1.0;
};
ThinWallTube make_thin_wall_tube_shell(const MaterialPtr& law, const ThinWallTubeSize& size, int cells, double pressure);
ThinWallTube make_thin_wall_tube_solid(const MaterialPtr& law, const ThinWallTubeSize& size, int cells, int axial_cells, double pressure);

}  // namespace softhom::macro
