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
};

struct SectionMeshQuality {
  double min_angle_deg = 0.0, max_angle_deg = 0.0;
  double min_radius_ratio = 0.0, mean_radius_ratio = 0.0;  ///< 2 r_in / r_circ (1 = equilateral)
  double min_edge = 0.0, max_edge = 0.0;
  int refinement_passes = 0;     ///< mesher passes until the boundary vertices paired up
  int mirrored_points = 0;       ///< Steiner points mirrored onto opposite edges
  double max_pairing_error = 0.0;  ///< largest coordinate mismatch of paired boundary nodes
  double fiber_area_error = 0.0;   ///< |mesh fiber area − exact| / exact (0 without fibers)
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

/// Quadratic-triangle shape functions at (ξ, η) (area coordinates L = (1 − ξ − η, ξ, η)).
std::array<double, 6> tri6_shape(double xi, double eta);
/// Their derivatives ∂N/∂ξ (column 0) and ∂N/∂η (column 1).
Eigen::Matrix<double, 6, 2> tri6_shape_derivatives(double xi, double eta);

/// Recomputes the periodic masters by coordinate matching and returns the largest mismatch; throws
/// std::runtime_error if a node on y1 = L1 or y2 = L2 has no partner (used by tests to verify).
double verify_periodic_pairing(const SectionMesh& mesh);

}  // namespace softhom::rve
