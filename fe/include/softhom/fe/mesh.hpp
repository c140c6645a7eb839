#pragma once
// Meshes for the FE core: trilinear hexahedra and/or quadratic tetrahedra (tet10.hpp, Gmsh order).
// Elements are numbered hexes first, then tets (element e ≥ hexes.size() is tet e − hexes.size()).
// Node ordering of a hex8 (reference cube [-1, 1]^3):
//   0 (-,-,-), 1 (+,-,-), 2 (+,+,-), 3 (-,+,-), 4 (-,-,+), 5 (+,-,+), 6 (+,+,+), 7 (-,+,+).
// Degenerate hexes (repeated nodes, e.g. wedges at an axis or pole) are allowed as long as the
// Jacobian is positive at the Gauss points. Boundary faces are quads whose node order gives the
// outward normal of the solid (x_ξ × x_η points out); boundary faces of tets are 6-node triangles in
// the order of kTet10Faces (vertices counter-clockwise seen from outside, then mid-edge nodes).
#include <array>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "softhom/core/input_error.hpp"
#include "softhom/materials/tensor.hpp"

namespace softhom::fe {

/// "(x, y, z)", each coordinate as format_number writes it: a point named in a message.
inline std::string point_text(const Vec3& x) {
  std::string text = "(";
  for (int i = 0; i < 3; ++i) text.append(format_number(x[i])).append(i < 2 ? ", " : ")");
  return text;
}

using Hex = std::array<int, 8>;
using Quad = std::array<int, 4>;
using Tet10 = std::array<int, 10>;
using Tri6 = std::array<int, 6>;

struct Mesh {
  std::vector<Vec3> nodes;
  std::vector<Hex> hexes;
  std::vector<Tet10> tets;                          ///< after the hexes in the element numbering
  std::vector<int> region;                          ///< per element (material region id), default 0
  std::map<std::string, std::vector<Quad>> surfaces;  ///< named boundary faces (outward normals)
  std::map<std::string, std::vector<Tri6>> tri_surfaces;  ///< named 6-node triangle faces of tets
  std::vector<std::string> region_names;            ///< optional: name of region id k (imported meshes)

  int num_nodes() const { return int(nodes.size()); }
  int num_hexes() const { return int(hexes.size()); }
  int num_elements() const { return int(hexes.size() + tets.size()); }
  int num_dofs() const { return 3 * num_nodes(); }
  bool is_tet(int e) const { return e >= int(hexes.size()); }
  /// Nodes of element e (8 for a hex, 10 for a tet).
  int element_size(int e) const { return is_tet(e) ? 10 : 8; }
  const int* element_nodes(int e) const { return is_tet(e) ? tets[e - hexes.size()].data() : hexes[e].data(); }
  /// Quad faces of surface `name` or an InputError naming it (empty when it has only triangles).
  const std::vector<Quad>& surface(const std::string& name) const;
  /// Triangle faces of surface `name` (empty when it has only quads or does not exist).
  const std::vector<Tri6>& tri_surface(const std::string& name) const;
  bool has_surface(const std::string& name) const { return surfaces.count(name) || tri_surfaces.count(name); }
};

/// Positive orientation of a tet10 ((x1 − x0) × (x2 − x0) · (x3 − x0) > 0) by swapping vertices 1, 2
/// (and the mid-edge nodes that follow them) where needed. Returns the number flipped.
int orient_tets(Mesh& mesh);

/// Local faces of a hex8 with outward normals.
constexpr std::array<std::array<int, 4>, 6> kHexFaces{{
    {0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4}, {1, 2, 6, 5}, {2, 3, 7, 6}, {0, 4, 7, 3}}};

/// Merges nodes closer than `tolerance` (relative to the bounding-box size) and renumbers the hexes.
/// Structured generators build patches independently and let this glue them (periodic seams,
/// collapsed axes and poles).
void merge_coincident_nodes(Mesh& mesh, double tolerance = 1e-9);

/// Faces that belong to exactly one hex, with outward normals.
std::vector<Quad> boundary_faces(const Mesh& mesh);
/// Faces that belong to exactly one tet (6-node triangles), with outward normals.
std::vector<Tri6> boundary_tri_faces(const Mesh& mesh);

/// Sorts the boundary faces into named surfaces: `classify(centroid, unit outward normal)` returns a
/// name or "" (face left unnamed). Existing surfaces of the same name are extended.
void name_boundary_faces(Mesh& mesh, const std::function<std::string(const Vec3&, const Vec3&)>& classify);

/// Splits every hex into 6 tets (Kuhn: the paths from local vertex 0 to vertex 6 along the three axes
/// in every order) with mid-edge nodes at midpoint(X_a, X_b) (default: the straight midpoint; a
/// generator may put them on its curved boundary). Conforming when neighbouring hexes share their
/// parametric orientation (structured blocks). Regions carry over; quad surfaces become triangle
/// surfaces of the same name; zero-volume tets (from degenerate hexes) are dropped.
Mesh hex_to_tet10(const Mesh& hex_mesh, const std::function<Vec3(const Vec3&, const Vec3&)>& midpoint = {});

/// Nodes of a surface, quads and triangles (sorted, unique).
std::vector<int> surface_nodes(const Mesh& mesh, const std::string& name);
/// Nodes satisfying a predicate on the reference position.
std::vector<int> select_nodes(const Mesh& mesh, const std::function<bool(const Vec3&)>& predicate);

/// Flips hexes whose Jacobian at the centroid is negative (mirror the ξ direction) so generators may
/// use either handedness. Returns the number flipped.
int orient_hexes(Mesh& mesh);

/// Mesh quality: minimum over elements of the Jacobian determinant at the Gauss points divided by
/// the element's mean (1 for parallelepipeds and straight-sided tets; ≤ 0 means an unusable element).
double min_scaled_jacobian(const Mesh& mesh);

}  // namespace softhom::fe
