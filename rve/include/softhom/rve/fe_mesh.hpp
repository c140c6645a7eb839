#pragma once
// Periodic conforming triangle meshes of a fiber cross-section (the cell of geometry.hpp), for the FE
// RVE engine.
//
// The section [0, L1] × [0, L2] is meshed with CGAL's constrained Delaunay mesher: every fiber
// boundary (and its periodic images that cross the cell) is a chain of constraint segments, the
// cell boundary is split into segments with identical parameters on opposite edges, and after each
// refinement pass any Steiner point the mesher put on one edge is mirrored onto the opposite edge
// (then the pass is repeated) until the boundary vertices pair up exactly. Element size grows from
// `interface_size` at the fiber boundaries to `mesh_size` away from them.
//
// Elements are 6-node triangles (vertices 0, 1, 2 counter-clockwise, then the mid-side nodes of the
// edges 0–1, 1–2, 2–0). Mid-side nodes of edges on a circular fiber boundary are moved onto the exact
// circle (isoparametric geometry), so the fiber area converges at O(h⁴) instead of O(h²).
#include <array>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "softhom/rve/geometry.hpp"

namespace softhom::rve {

struct SectionMeshOptions {
  double mesh_size = 0.0;        ///< element size away from interfaces; 0: L1 / 16
  double interface_size = 0.0;   ///< element size at fiber boundaries; 0: mesh_size / 3
  double grading = 0.3;          ///< size growth per unit distance from the nearest interface
  double min_angle_deg = 20.7;   ///< CGAL termination is guaranteed up to 20.7°
  bool curved_interfaces = true; ///< mid-side nodes on the exact circle
  /// Rectangular fibers: graded refinement toward the corners, h(r) = interface_size (r / R)^β with
  /// r the distance to the nearest corner, R = half the shorter side, β = corner_exponent (the
  /// classical grading for a stress singularity ~ r^(λ−1) with P2 elements: β = 1 − μ, μ < λ/2;
  /// λ ≈ 0.6 at a 90° glass corner in a soft matrix → β = 0.7), floored at R (interface_size/R)^(1/(1−β)).
  /// Corners shared with a periodic image (layers touching across the cell) are not refined.
  bool corner_refinement = true;
  double corner_exponent = 0.7;
  /// Cap of the corner grading: the smallest corner size is at least corner_min_size_ratio ·
  /// interface_size. The uncapped floor R (h_i/R)^(1/(1−β)) falls as h_i^3.3 (3e-5 mm = 1.5e-4 L at
  /// L/16), far below what the singular corner field needs for the homogenized stress; the element
  /// count is set by the power grading itself (∝ (R/h_i)², about 7× the unrefined mesh at any level).
  double corner_min_size_ratio = 0.05;
};

struct SectionMeshQuality {
  double min_angle_deg = 0.0, max_angle_deg = 0.0;
  double min_radius_ratio = 0.0, mean_radius_ratio = 0.0;  ///< 2 r_in / r_circ (1 = equilateral)
  double min_edge = 0.0, max_edge = 0.0;
  int refinement_passes = 0;     ///< mesher passes until the boundary vertices paired up
  int mirrored_points = 0;       ///< Steiner points mirrored onto opposite edges
  double max_pairing_error = 0.0;  ///< largest coordinate mismatch of paired boundary nodes
  double fiber_area_error = 0.0;   ///< |mesh fiber area − exact| / exact (0 without fibers)
  int refined_corners = 0;         ///< fiber corners with graded corner refinement
  double min_corner_size = 0.0;    ///< smallest target size at a corner (0: none)
};

struct SectionMesh {
  double L1 = 1.0, L2 = 1.0;
  std::vector<Eigen::Vector2d> nodes;        ///< vertices and mid-side nodes
  std::vector<std::array<int, 6>> elements;  ///< T6 connectivity
  std::vector<int> phase;                    ///< per element: 0 matrix, 1 fiber
  /// Periodic master of every node (itself for interior nodes and the nodes of the edges y1 = 0,
  /// y2 = 0; the image node for y1 = L1, y2 = L2, with the four corners all mapped to (0, 0)).
  std::vector<int> master;
  int vertices = 0;                          ///< corner nodes (the rest are mid-side nodes)
  /// false for a plate cell (make_plate): only the edges y1 = 0, L1 are paired; the edges y2 = 0, L2
  /// are the plate's free faces (their nodes are their own masters, except the corners (L1, y2) →
  /// (0, y2)).
  bool periodic_y2 = true;
  SectionMeshQuality quality;

  int num_nodes() const { return int(nodes.size()); }
  int num_elements() const { return int(elements.size()); }
  int num_masters() const;
  double area(int phase_id) const;           ///< exact (curved) area of the phase in the mesh
};

/// Meshes the section. Throws InputError (field "solver.mesh_size" / "solver.interface_size") on
/// non-positive sizes or a mesh that would be absurdly large, and std::runtime_error when the
/// boundary vertices cannot be paired.
SectionMesh mesh_section(const Section& section, const SectionMeshOptions& options = {});

/// Makes the section mesh a plate cell: one layer of fibers, periodic along y1 only, its faces
/// y2 = 0 and y2 = L2 free (the FE solver then leaves ũ unpaired across them). The mesh itself is
/// unchanged (the mesher's mirrored points on the y2 edges are harmless).
void make_plate(SectionMesh& mesh);

/// Refuses (InputError on "microstructure.cell") a plate section whose fibers cut a free face y2 = 0
/// or y2 = L2 (a hexagonal or random arrangement): the plate is one layer of whole fibers.
void check_plate_section(const Section& section);

/// Quadratic-triangle shape functions at (ξ, η) (area coordinates L = (1 − ξ − η, ξ, η)).
std::array<double, 6> tri6_shape(double xi, double eta);
/// Their derivatives ∂N/∂ξ (column 0) and ∂N/∂η (column 1).
Eigen::Matrix<double, 6, 2> tri6_shape_derivatives(double xi, double eta);

/// Recomputes the periodic masters by coordinate matching and returns the largest mismatch; throws
/// std::runtime_error if a node on y1 = L1 or (periodic_y2) y2 = L2 has no partner (used by tests to
/// verify).
double verify_periodic_pairing(const SectionMesh& mesh);

// ---------------------------------------------------------------------------------------------
// 3D variant: periodic conforming tetrahedral meshes of the cell (fibers along y3).
//
// The cell [0, L1] × [0, L2] × [0, L3] is meshed with CGAL's Periodic_3_mesh_3 (a Delaunay mesh of
// the flat torus, refined against a labeling function matrix / fiber, with the sizing field of the
// section mesher). CGAL meshes a cube: other cell shapes (hexagonal arrangements, L3 ≠ L1) are meshed
// in the unit cube and mapped affinely, which stretches the elements by the aspect ratio of the cell
// (reported in the quality). Every tetrahedron of the torus mesh becomes one 10-node element
// (fe/tet10.hpp node order) with unwrapped vertex positions: a vertex used by elements on both sides
// of a cell face appears as several nodes (its periodic copies), all mapped to one master. So the
// pairing of opposite faces is exact by construction; verify_periodic_cell_mesh checks it.
// Vertices on the fiber surfaces are projected onto the exact cylinder and so are the mid-edge nodes
// of the surface triangles (isoparametric geometry). Rectangular fibers: the corner edges are not
// protected features in this version (CGAL rounds them at the scale of the interface size).

struct CellMeshOptions {
  double mesh_size = 0.0;        ///< element size away from interfaces; 0: L1 / 6
  double interface_size = 0.0;   ///< element size at fiber surfaces; 0: mesh_size / 2
  double grading = 0.3;          ///< size growth per unit distance from the nearest interface
  double length = 0.0;           ///< L3 (along the fibers); 0: L1
  double facet_angle_deg = 25.0;
  double radius_edge_ratio = 2.0;
  bool curved_interfaces = true;
  unsigned seed = 1;             ///< CGAL's random generator (reproducible meshes)
  /// A mesh that still folds an element after the repairs of mesh_cell is remade with the next seeds,
  /// at most this many times (the fold depends on where CGAL puts its interface vertices).
  int seed_retries = 3;
  /// Vertex smoothing of CGAL's refined mesh before its sliver perturber and exuder:
  /// ODT (optimal Delaunay triangulation) and/or Lloyd relaxation, at most `smoothing_iterations`
  /// sweeps each (no time limit: the mesh depends only on the inputs and the seed).
  bool odt = false;
  bool lloyd = false;
  int smoothing_iterations = 20;
  bool perturb = true;           ///< CGAL's sliver perturber
  bool exude = true;             ///< CGAL's sliver exuder
};

struct CellMeshQuality {
  double min_dihedral_deg = 0.0, max_dihedral_deg = 0.0;
  double min_radius_ratio = 0.0, mean_radius_ratio = 0.0;  ///< 3 r_in / r_circ (1 = regular)
  double min_edge = 0.0, max_edge = 0.0;
  double max_pairing_error = 0.0;  ///< largest |x_node − x_master − k L| over all periodic copies
  double fiber_volume_error = 0.0; ///< |mesh fiber volume − exact| / exact
  double aspect_stretch = 1.0;     ///< max(L) / min(L) of the affine map from CGAL's cube
  int periodic_copies = 0;         ///< nodes that are copies of another node
  int unlabeled_cells = 0;         ///< cells CGAL left outside its complex (phase from the centroid)
  int relabeled_cells = 0;         ///< matrix cells with all vertices on a fiber surface, made fiber
  int interface_facets_not_in_complex = 0;  ///< phase-boundary facets that are not CGAL surface facets
  double max_interface_offset = 0.0;  ///< largest |distance to the fiber surface| / radius of an
                                      ///< interface vertex after projection (circles; 0 = exact)
  double mesh_seconds = 0.0;       ///< wall time of CGAL's mesher (refinement + optimizers)
  unsigned seed_used = 0;          ///< the seed of the mesh returned (options.seed + retries)
};

struct CellMesh {
  double L1 = 1.0, L2 = 1.0, L3 = 1.0;
  std::vector<Eigen::Vector3d> nodes;         ///< unwrapped positions (periodic copies included)
  std::vector<std::array<int, 10>> elements;  ///< Tet10 connectivity (Gmsh order), positively oriented
  std::vector<int> phase;                     ///< per element: 0 matrix, 1 fiber
  std::vector<int> master;                    ///< periodic master of every node
  int vertices = 0;                           ///< distinct vertices of the torus mesh
  CellMeshQuality quality;

  int num_nodes() const { return int(nodes.size()); }
  int num_elements() const { return int(elements.size()); }
  int num_masters() const;
  double volume(int phase_id) const;          ///< exact (curved) volume of the phase
};

/// Meshes the 3D cell of the section. Throws InputError (fields "solver.mesh_size",
/// "solver.interface_size", "solver.length") on bad sizes and std::runtime_error if CGAL fails.
CellMesh mesh_cell(const Section& section, const CellMeshOptions& options = {});

/// Checks the periodic structure independently of the mesher: every node lies at its master's
/// position plus a lattice vector (returns the largest mismatch), and every triangular face of the
/// torus mesh (vertices identified by master) is shared by exactly two elements with opposite
/// orientation (no gaps, no overlaps, no unmatched face on the cell boundary). Throws
/// std::runtime_error on a violation.
double verify_periodic_cell_mesh(const CellMesh& mesh);

}  // namespace softhom::rve
