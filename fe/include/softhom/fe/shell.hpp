#pragma once
// Thin shells as a contribution of the macro model: a rotation-free Kirchhoff–Love triangle whose only
// unknowns are the nodal displacements.
//
// Formulation (after the Basic Shell Triangle of Oñate & Zárate 2000 and its large-strain form by Flores
// & Oñate 2001): each 3-node triangle is one integration point of the layered section
// (softhom/materials/shell_section.hpp) in a local orthonormal frame (e1, e2 tangent to the reference
// triangle, e3 its normal).
//  - Membrane: the constant Green–Lagrange strain of the triangle, ε_αβ = ½ (a_α·a_β − δ_αβ), a_α = ∂x/∂X_α.
//  - Bending: the curvature of the patch made of the triangle and its three edge neighbours. The six
//    patch nodes (the triangle's three and the three across its edges, each neighbour unfolded about
//    the shared edge into the triangle's plane) define one quadratic surface in the triangle's
//    reference coordinates X_α; its constant second derivatives give b_αβ = x,_αβ·t, t the triangle's
//    unit normal. Because t ⊥ the triangle's edges, b_αβ = Σ_i Q_αβ,i t·(x_oi − x_ai): the heights of
//    the three opposite nodes o_i above the triangle's plane (a_i a node of edge i), with Q from the
//    inverse of the 6-point quadratic interpolation (the idea of the enhanced BST, Flores & Oñate 2005):
//    exact for a quadratic surface on any mesh. The curvature change κ = −(b − B) (B: the same in the
//    reference) makes E(z) = ε + z κ; curved reference surfaces (spheres, cylinders) start at κ = 0.
//  - Boundary edges have no neighbour. A `clamped` one (clamped or symmetry) has a point at the mirror
//    image of the opposite vertex across the edge, at height 2 δ t·T: the surface leaves the edge along
//    its reference conormal T (δ the vertex's distance from the edge), as a mirrored neighbour would.
//    A `free` one (free or simply supported) replaces the missing point's equation of the fit by
//    ∂²q/∂ν² = 0: no curvature across the edge (BST's free edge, where the moment M_νν vanishes), exact
//    for surfaces curved along the edge only. Displacement conditions of either are Dirichlet
//    constraints of the model, not of the element.
// The residual is A₀ Bᵀ [N; M] and the tangent A₀ (Bᵀ D B + N·∂²ε + M·∂²κ), B = ∂[ε; κ]/∂x, with the
// second derivatives of the strains exact (forward second-order differentiation of the kinematics).
//
// Surface topology: shell_topology finds each edge's neighbour, refuses non-manifold edges (three or
// more triangles) and, with orient, turns triangles so that shared edges run opposite ways (a
// non-orientable surface is refused naming an element); check_closed refuses a surface with a boundary
// edge where a closed one is needed (a cavity).
#include <array>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "softhom/fe/contribution.hpp"
#include "softhom/fe/mesh.hpp"
#include "softhom/materials/loading.hpp"
#include "softhom/materials/shell_section.hpp"

namespace softhom::fe {

using Tri3 = std::array<int, 3>;

/// Rotation condition of a boundary edge (its displacements are Dirichlet constraints).
enum class ShellEdge : signed char {
  free,     ///< free or simply supported: the conormal rotates freely
  clamped,  ///< clamped or symmetry plane: the conormal keeps its reference direction
};

/// Edge neighbours of a triangle surface. Edge k of triangle (n0, n1, n2) is the one opposite vertex k:
/// (n1, n2), (n2, n0), (n0, n1).
struct ShellTopology {
  std::vector<std::array<int, 3>> neighbour;  ///< triangle across edge k, −1 on the boundary
  std::vector<std::array<int, 3>> opposite;   ///< that triangle's vertex off the shared edge (node id), −1
  int boundary_edges = 0;
  int flipped = 0;  ///< triangles turned by orient
};

/// Topology of `tris` (node ids < num_nodes). Throws InputError naming `field` and an element for a
/// degenerate triangle, an edge shared by more than two triangles, or (orient = false) two triangles
/// whose shared edge runs the same way. With orient, flips triangles in place so that each connected
/// part follows its first triangle; a non-orientable part is refused.
ShellTopology shell_topology(std::vector<Tri3>& tris, int num_nodes, bool orient, const std::string& field);

/// Throws InputError naming `field` and the first triangle with a boundary edge.
void check_closed(const ShellTopology& topology, const std::string& field);

/// The reference data of one triangle and its patch: slots 0..2 the triangle's nodes, 3 + i the node
/// across edge i (−1 absent).
struct ShellPatch {
  std::array<int, 6> nodes{-1, -1, -1, -1, -1, -1};
  Mat3 frame = Mat3::Identity();  ///< columns e1, e2, e3 (reference normal)
  double area = 0.0;
  double dN[3][2] = {};           ///< ∂N_c/∂X_α of the triangle's nodes
  /// b_k = Σ_i Q[k][i] h_i (Voigt k: 11, 22, 12) with h_i the height of the node across edge i.
  double Q[3][3] = {};
  std::array<int, 3> base{0, 0, 0};          ///< slot of a node of edge i (h_i = t·(x_{3+i} − x_base))
  std::array<signed char, 3> kind{0, 0, 0};  ///< edge i: 0 free (h = 0), 1 neighbour, 2 clamped
  /// Clamped edge i: 2 δ_i T_i (h_i = t·(2 δ T)).
  Vec3 clamp[3] = {Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
  double B[3] = {};                          ///< reference curvature b, Voigt [11, 22, 12]
};

/// The fiber frame of a shell: e1 the projection of `axis` onto the tangent plane (global), or the
/// circumferential direction about a cylinder axis (cylindrical).
struct ShellFrameRule {
  enum class Kind { global, cylindrical } kind = Kind::global;
  Vec3 axis{1.0, 0.0, 0.0};    ///< global: projected axis; cylindrical: the cylinder's axis
  Vec3 origin{0.0, 0.0, 0.0};  ///< cylindrical: a point of the axis
};

/// Local frame of a triangle with reference normal n at centroid c. Sets `fallback` when the rule's
/// direction is within 1e-3 (sine) of the normal there: then the next global axis (y, then z) is projected.
Mat3 shell_frame(const ShellFrameRule& rule, const Vec3& n, const Vec3& c, bool& fallback);

/// Membrane strain and curvature change [ε; κ] (Voigt, engineering shear) of a patch at positions x
/// (slots as ShellPatch::nodes; absent slots ignored), with their first and second derivatives with
/// respect to the 18 patch coordinates when `B` / `H` are given (H: 6 matrices of 18 × 18).
void shell_strains(const ShellPatch& p, const std::array<Vec3, 6>& x, Vec6v& strains,
                   Eigen::Matrix<double, 6, 18>* B = nullptr, std::array<Eigen::Matrix<double, 18, 18>, 6>* H = nullptr);

/// The same strains and B in closed form (shell_kinematics.cpp).
void shell_kinematics(const ShellPatch& p, const std::array<Vec3, 6>& x, Vec6v& strains, Eigen::Matrix<double, 6, 18>& B);
/// The stress-weighted sum of the strains' second derivatives G = Σ_k NM_k ∂²[ε; κ]_k/∂x² (the geometric
/// part of the tangent) for NM = [N; M], in closed form: one Hessian of t·W instead of the six carried
/// by the forward jets of shell_strains (which the tests keep as its reference).
void shell_geometric_stiffness(const ShellPatch& p, const std::array<Vec3, 6>& x, const Vec6v& NM,
                               Eigen::Matrix<double, 18, 18>& G);

/// What a shell is made of: the triangles, their edge conditions, section and frame.
struct ShellSpec {
  std::vector<Tri3> triangles;
  /// Boundary edges by their two nodes (either order) and condition; unlisted boundary edges are free.
  std::vector<std::pair<std::array<int, 2>, ShellEdge>> edges;
  std::shared_ptr<const ShellSection> section;
  ShellFrameRule frame;
  bool orient = true;  ///< orient the triangles consistently (false: refuse inconsistent ones)
  /// Named sets of triangles (a vessel's sac, its parent artery), each with its own probes.
  std::map<std::string, std::vector<int>> groups;
};

/// The shell domain: residual and consistent tangent of every triangle's patch.
class ShellDomain final : public Contribution {
 public:
  /// Builds topology, frames and patches from the mesh's reference nodes. Throws InputError (naming
  /// "shell" keys and elements) for bad triangles, a non-manifold or inconsistently oriented surface,
  /// a frame that cannot be formed, or a singular patch.
  ShellDomain(const Mesh& mesh, ShellSpec spec);
  Kind kind() const override { return Kind::domain; }
  std::string name() const override { return "shell"; }
  void validate(const Mesh& mesh) const override;
  void declare_couplings(Couplings& couplings) const override;
  MaterialStatus assemble(const Mesh& mesh, const Iterate& it, AssemblySink& sink) const override;
  /// A clamped edge holds the rotation about it (which no prescribed displacement of its nodes does).
  bool holds_rigid_motion() const override { return has_clamped_; }
  int state_size() const override { return int(patches_.size()) * section_->state_size(); }
  void init_state(double* state) const override;
  /// Probes "shell max principal stress [MPa]", "shell max principal element [-]" and "shell max principal
  /// stretch [-]", and for every group G "shell G max principal stress [MPa]" and "shell G max principal
  /// stretch [-]"; the field "shell":
  /// the triangles with per-cell thickness stretch, Cauchy stress per layer at bottom, middle and top
  /// (σ11, σ22, σ12 in the local frame carried by the mid-surface's rotation), in-plane principal
  /// stresses and stretches, the current fiber direction, and the points' displacement.
  void report(const Mesh& mesh, const Iterate& it, ContributionReport& out) const override;

  const std::vector<Tri3>& triangles() const { return spec_.triangles; }
  const ShellTopology& topology() const { return topology_; }
  const std::vector<ShellPatch>& patches() const { return patches_; }
  const ShellSection& section() const { return *section_; }
  /// Triangles whose fiber frame fell back to another axis (warned once by the caller).
  int frame_fallbacks() const { return frame_fallbacks_; }

  /// Per-triangle results at a state (the section evaluated from state with dt = 0).
  struct Results {
    std::vector<double> thickness_stretch;  ///< 1 per triangle
    std::vector<double> cauchy;             ///< per triangle, layer, position (bottom, middle, top): σ11, σ22, σ12
    std::vector<double> principal_stress;   ///< 2 per triangle: in-plane principal σ of the mid-surface
    std::vector<double> principal_stretch;  ///< 3 per triangle: in-plane λ1 ≥ λ2, thickness λ3
    std::vector<double> fiber;              ///< 3 per triangle: current direction of the first fiber of the first layer with fibers (0 if none)
    std::vector<double> max_stress;         ///< 1 per triangle: largest in-plane principal σ over its section points
    double max_principal = 0.0;             ///< over triangles and section points
    int max_element = -1;
  };
  Results results(const Mesh& mesh, const std::vector<double>& u, const double* state) const;

 private:
  ShellSpec spec_;
  std::shared_ptr<const ShellSection> section_;
  ShellTopology topology_;
  std::vector<ShellPatch> patches_;
  int frame_fallbacks_ = 0;
  bool has_clamped_ = false;
};

/// A follower end moment on a shell edge, for an element without rotational dofs: the edge's rotation
/// about a fixed axis is taken as that of the chords from each edge node to its partner one row inward
/// (θ_k the angle of x_edge − x_inner about the axis), and the load is work-conjugate to it: potential
/// −Σ_k M_k(t) θ_k, M_k = share_k · moment(t). The forces ±M_k ∂θ_k/∂x stay a pure couple on every
/// chord whatever its direction, and the tangent −Σ M_k ∂²θ_k/∂x² is symmetric (the moment about a fixed
/// axis is conservative). Within the rotation-free triangle the chord of the last row is the edge's
/// conormal up to the curvature of that row (an O(h) difference of the end rotation).
class ShellEdgeMoment final : public Contribution {
 public:
  struct Pair {
    int edge = -1, inner = -1;
    double share = 0.0;  ///< this pair's part of the total moment (the shares sum to 1)
  };
  /// Throws InputError naming `field` for an axis of zero length or a pair without two distinct nodes.
  ShellEdgeMoment(std::vector<Pair> pairs, const Vec3& axis, PiecewiseLinear moment, const std::string& field);
  Kind kind() const override { return Kind::load; }
  std::string name() const override { return "shell_edge_moment"; }
  void validate(const Mesh& mesh) const override;
  void declare_couplings(Couplings& couplings) const override;
  void load_levels(double t, std::vector<double>& levels) const override { levels.push_back(moment_(t)); }
  MaterialStatus assemble(const Mesh& mesh, const Iterate& it, AssemblySink& sink) const override;
  /// Probes "shell edge moment [N mm]" (the total moment) and "shell edge rotation [rad]" (rotation()).
  void report(const Mesh& mesh, const Iterate& it, ContributionReport& out) const override;
  /// The chords' rotation about the axis from their reference directions: the angle of the
  /// share-weighted mean of their rotations as unit vectors, in (−π, π].
  double rotation(const Mesh& mesh, const std::vector<double>& u) const;
  const std::vector<Pair>& pairs() const { return pairs_; }

 private:
  std::vector<Pair> pairs_;
  Vec3 axis_, p_, q_;  ///< unit axis and an orthonormal basis (p, q = axis × p) of the plane normal to it
  PiecewiseLinear moment_;
};

/// The pairs of a uniform moment per unit length along the boundary edge made of `segments` (node
/// pairs of boundary edges of `tris`): each edge node with the node of its triangles off the edge whose
/// direction is closest to the inward conormal, its share the half-length of its segments over the
/// edge's length (a constant moment per unit length, lumped as a uniform line load is). Throws
/// InputError naming `field` when a segment is no triangle's edge.
std::vector<ShellEdgeMoment::Pair> shell_edge_moment_pairs(const Mesh& mesh, const std::vector<Tri3>& tris,
                                                           const std::vector<std::array<int, 2>>& segments,
                                                           const std::string& field);

/// The triangles as degenerate quads (a, c, b, b) whose normal points against the triangle's (a, b, c):
/// into the cavity of an outward-oriented closed shell, the solid-face convention of PressureLoad and
/// CavityControl (a bilinear quad with two coincident nodes integrates a flat triangle's area vector and
/// its linear fluxes exactly).
std::vector<Quad> shell_load_faces(const std::vector<Tri3>& tris);

}  // namespace softhom::fe
