#pragma once
// Structured hexahedral generators for the structures of dissertation §3.3, §3.6 and §4.3, and the
// fiber fields that go with them. Lengths in mm. Every generator names its boundary surfaces
// (outward normals of the solid) so that scenes can refer to them.
#include <vector>

#include "softhom/fe/mesh.hpp"

namespace softhom::macro {

/// Box [0, Lx] × [0, Ly] × [0, Lz]. Surfaces: xmin, xmax, ymin, ymax, zmin, zmax.
struct PlateSpec {
  Vec3 size{10.0, 10.0, 0.5};
  std::array<int, 3> cells{10, 10, 1};
};
fe::Mesh make_plate(const PlateSpec& spec);

/// Thick-walled tube along z, R_i ≤ r ≤ R_o, 0 ≤ z ≤ length, angular sector [0, sweep_deg]
/// (90: quarter with symmetry planes, 360: full). Optional closed end cap of thickness
/// `cap_thickness` at z = length (solid disk, degenerate wedges at the axis).
/// Surfaces: inner, outer, zmin, zmax (outer end, including the cap's), cap_inner (cap face toward
/// the cavity), ysym (θ = 0 plane, sector < 360), xsym (θ = 90° plane, quarter only).
/// Regions: 0, or 1 for elements whose centroid has y < 0 when `split_y` (two-material actuator).
struct TubeSpec {
  double inner_radius = 5.0, outer_radius = 7.5, length = 1.0;
  int radial_cells = 4, circumferential_cells = 16, axial_cells = 1;
  double sweep_deg = 90.0;
  double cap_thickness = 0.0;
  int cap_axial_cells = 1, cap_core_cells = 2;
  bool split_y = false;
};
fe::Mesh make_tube(const TubeSpec& spec);

/// One eighth of a thick sphere R_i ≤ |x| ≤ R_i + thickness in the positive octant, as three
/// cubed-sphere patches (no degenerate elements). Surfaces: inner, outer, x0, y0, z0 (symmetry planes).
struct SphereSpec {
  double inner_radius = 1.0, thickness = 0.05;
  int radial_cells = 2, patch_cells = 8;  ///< cells along each edge of a patch (3 patches)
};
fe::Mesh make_sphere_octant(const SphereSpec& spec);

/// Cook's membrane: the tapered panel with corners (0, 0), (48, 44), (48, 60), (0, 44), one element
/// thick (0 ≤ z ≤ 1), n × n × 1 hex8. Node (i, j, k) of the n × n grid
/// (i along x, j from bottom to top edge, k = 0, 1) has the id i + (n + 1)(j + (n + 1) k), so the tip
/// corner (48, 60, 0) is node n + (n + 1) n. Surfaces: clamped (x = 0), tip (x = 48).
fe::Mesh make_cook_membrane(int n);

/// Element centroids (reference).
std::vector<Vec3> element_centroids(const fe::Mesh& mesh);

/// Local cylindrical frame at x about the z axis: columns (e_θ, e_z, e_r) — hoop, axial, radial (a
/// rotation). A fiber at helix angle α from the tube axis is (sin α, cos α, 0) in this frame, the
/// spec §7 convention with the axis as e2.
Mat3 cylindrical_frame(const Vec3& x);
/// Local spherical frame at x: columns (e_θ-like tangent 1, tangent 2, e_r) with e_r = x/|x|.
Mat3 spherical_frame(const Vec3& x);

}  // namespace softhom::macro
