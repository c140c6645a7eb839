#pragma once
// Quadratic (10-node) tetrahedron: shape functions, derivatives and quadrature. Shared by the macro
// FE core (imported tetrahedral meshes) and the 3D periodic FE RVE engine, so that both use one node
// ordering and one set of rules.
//
// Node ordering (Gmsh "tetrahedron 10", element type 11): vertices 0–3, then the mid-edge nodes of
// the edges kTet10Edges in this order: 4 (0,1), 5 (1,2), 6 (2,0), 7 (3,0), 8 (3,2), 9 (3,1).
// VTK/XDMF "Tetrahedron_10" orders the last two edges (1,3), (2,3): use kTet10ToVtk when writing.
// Reference tetrahedron: ξ = (ξ1, ξ2, ξ3) ≥ 0, ξ1 + ξ2 + ξ3 ≤ 1, barycentric L0 = 1 − Σξ, L_k = ξ_k.
#include <array>

#include <Eigen/Core>

namespace softhom::fe {

using Tet10Vec = Eigen::Matrix<double, 10, 1>;
using Tet10Grad = Eigen::Matrix<double, 10, 3>;  ///< row a: ∂N_a/∂(ξ or X)

/// Vertex pairs of the mid-edge nodes 4..9.
constexpr std::array<std::array<int, 2>, 6> kTet10Edges{{{0, 1}, {1, 2}, {2, 0}, {3, 0}, {3, 2}, {3, 1}}};
/// Writing a VTK/XDMF Tetrahedron_10: vtk_nodes[kTet10ToVtk[a]] = nodes[a] (a swap, its own inverse).
constexpr std::array<int, 10> kTet10ToVtk{0, 1, 2, 3, 4, 5, 6, 7, 9, 8};
/// Faces of the linear tetrahedron (vertex indices) with outward normals for a positively oriented
/// element ((x1 − x0) × (x2 − x0) · (x3 − x0) > 0), and the mid-edge nodes of each face in the order
/// (edge v0v1, v1v2, v2v0): 6-node triangle faces for follower pressure.
constexpr std::array<std::array<int, 3>, 4> kTetFaces{{{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {0, 3, 2}}};
constexpr std::array<std::array<int, 6>, 4> kTet10Faces{
    {{0, 2, 1, 6, 5, 4}, {0, 1, 3, 4, 9, 7}, {1, 2, 3, 5, 8, 9}, {0, 3, 2, 7, 8, 6}}};

/// Barycentric coordinates of a reference point.
inline std::array<double, 4> tet_barycentric(const Eigen::Vector3d& xi) {
  return {1.0 - xi[0] - xi[1] - xi[2], xi[0], xi[1], xi[2]};
}

/// N_a(ξ): vertices L_a(2L_a − 1), mid-edge nodes 4 L_i L_j.
inline Tet10Vec tet10_shape(const Eigen::Vector3d& xi) {
  const auto L = tet_barycentric(xi);
  Tet10Vec N;
  for (int a = 0; a < 4; ++a) N[a] = L[a] * (2.0 * L[a] - 1.0);
  for (int e = 0; e < 6; ++e) N[4 + e] = 4.0 * L[kTet10Edges[e][0]] * L[kTet10Edges[e][1]];
  return N;
}

/// ∂N_a/∂ξ_J (10x3).
inline Tet10Grad tet10_shape_derivatives(const Eigen::Vector3d& xi) {
  const auto L = tet_barycentric(xi);
  // ∂L_k/∂ξ_J: L0 → (−1, −1, −1), L_k → e_k.
  auto dL = [](int k, int J) { return k == 0 ? -1.0 : (k - 1 == J ? 1.0 : 0.0); };
  Tet10Grad d;
  for (int J = 0; J < 3; ++J) {
    for (int a = 0; a < 4; ++a) d(a, J) = (4.0 * L[a] - 1.0) * dL(a, J);
    for (int e = 0; e < 6; ++e) {
      const int i = kTet10Edges[e][0], j = kTet10Edges[e][1];
      d(4 + e, J) = 4.0 * (dL(i, J) * L[j] + L[i] * dL(j, J));
    }
  }
  return d;
}

/// Quadrature on the reference tetrahedron (weights sum to its volume 1/6).
struct TetRulePoint {
  Eigen::Vector3d xi;
  double w;
};

/// 4-point rule, exact for degree 2: the standard rule of quadratic tetrahedra (mass-lumping-free
/// stiffness of a P2 element with affine geometry is integrated exactly for constant moduli).
inline std::array<TetRulePoint, 4> tet_rule_degree2() {
  const double a = 0.5854101966249685, b = 0.1381966011250105, w = 1.0 / 24.0;
  return {{{Eigen::Vector3d(b, b, b), w}, {Eigen::Vector3d(a, b, b), w},
           {Eigen::Vector3d(b, a, b), w}, {Eigen::Vector3d(b, b, a), w}}};
}

}  // namespace softhom::fe
