#pragma once
// Hexahedral meshes for the FE core. Node ordering of a hex8 (reference cube [-1, 1]^3):
//   0 (-,-,-), 1 (+,-,-), 2 (+,+,-), 3 (-,+,-), 4 (-,-,+), 5 (+,-,+), 6 (+,+,+), 7 (-,+,+).
// Degenerate hexes (repeated nodes, e.g. wedges at an axis or pole) are allowed as long as the
// Jacobian is positive at the Gauss points. Boundary faces are quads whose node order gives the
// outward normal of the solid (x_ξ × x_η points out).
#include <array>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "softhom/materials/tensor.hpp"

namespace softhom::fe {

using Hex = std::array<int, 8>;
using Quad = std::array<int, 4>;

struct Mesh {
  std::vector<Vec3> nodes;
  std::vector<Hex> hexes;
  std::vector<int> region;                          ///< per element (material region id), default 0
  std::map<std::string, std::vector<Quad>> surfaces;  ///< named boundary faces (outward normals)

  int num_nodes() const { return int(nodes.size()); }
  int num_elements() const { return int(hexes.size()); }
  int num_dofs() const { return 3 * num_nodes(); }
  /// Surface `name` or an InputError naming it.
  const std::vector<Quad>& surface(const std::string& name) const;
};

/// Local faces of a hex8 with outward normals.
constexpr std::array<std::array<int, 4>, 6> kHexFaces{{
    {0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4}, {1, 2, 6, 5}, {2, 3, 7, 6}, {0, 4, 7, 3}}};

/// Merges nodes closer than `tolerance` (relative to the bounding-box size) and renumbers the hexes.
/// Structured generators build patches independently and let this glue them (periodic seams,
/// collapsed axes and poles).
void merge_coincident_nodes(Mesh& mesh, double tolerance = 1e-9);

/// Faces that belong to exactly one hex, with outward normals.
std::vector<Quad> boundary_faces(const Mesh& mesh);

/// Sorts the boundary faces into named surfaces: `classify(centroid, unit outward normal)` returns a
/// name or "" (face left unnamed). Existing surfaces of the same name are extended.
void name_boundary_faces(Mesh& mesh, const std::function<std::string(const Vec3&, const Vec3&)>& classify);

/// Nodes of a surface (sorted, unique).
std::vector<int> surface_nodes(const Mesh& mesh, const std::string& name);
/// Nodes satisfying a predicate on the reference position.
std::vector<int> select_nodes(const Mesh& mesh, const std::function<bool(const Vec3&)>& predicate);

/// Flips hexes whose Jacobian at the centroid is negative (mirror the ξ direction) so generators may
/// use either handedness. Returns the number flipped.
int orient_hexes(Mesh& mesh);

/// Mesh quality: minimum over elements of the Jacobian determinant at the 8 Gauss points divided by
/// the element's mean (1 for parallelepipeds; ≤ 0 means an unusable element).
double min_scaled_jacobian(const Mesh& mesh);

}  // namespace softhom::fe
