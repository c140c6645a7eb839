#pragma once
// Fibers tied to the solid: 2-node and 3-node (quadratic) truss/cable elements at finite strain whose
// nodes carry no unknowns of their own. Each fiber node takes its host's interpolation at its reference
// position, x_i = Σ_a N_a(ξ_i) x_a — the host being the solid element that contains it (located once by
// the inverse isoparametric map) or a face of a named surface (the fiber lies on the surface). The
// fiber's energy L0 ∫ ψ(λ) A ds is added as a contribution that declares the host nodes of each fiber
// element as its couplings and scatters Nᵀ f and Nᵀ K N onto them.
//
// Why nodes tied (not integration points of the host field): the stretch comes from the fiber's own
// chord (or quadratic curve), so a cable that goes slack, a stiff fiber across a coarse host and a fiber
// tied to a surface are the same truss; the fiber's force is constant along a 2-node element (no
// quadrature across host faces, so no kinks in the integrand to segment at), and an affine host motion
// is reproduced exactly wherever the fiber's nodes fall (the tests shift the host mesh under the fiber).
// Accuracy in a non-affine host field comes with fiber elements no longer than the host's (the
// generators' default).
#include <array>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "softhom/fe/contribution.hpp"
#include "softhom/fe/mesh.hpp"
#include "softhom/materials/material.hpp"

namespace softhom::fe {

// --- The fiber's 1D law -----------------------------------------------------------------------------

enum class FiberLawKind {
  linear,       ///< N = E A (λ − 1): linear in the Biot (engineering) strain λ − 1 (nominal stress E (λ − 1))
  neo_hookean,  ///< N = (E/3) A (λ − λ⁻²): an incompressible neo-Hookean rod in uniaxial tension (G = E/3)
};

struct FiberLaw {
  FiberLawKind kind = FiberLawKind::linear;
  double modulus = 10.0;  ///< E [MPa] (the small-strain Young's modulus of either law)
  double area = 0.0;      ///< reference cross-section A [mm²]
  bool cable = false;     ///< tension only: no force for λ < 1
};

/// Axial force N [N] and dN/dλ at stretch λ (> 0).
struct FiberForce {
  double force = 0.0, stiffness = 0.0;
};
FiberForce fiber_force(const FiberLaw& law, double stretch);

/// The nominal stress along unit direction T of `material` in uniaxial stress at stretch λ along T
/// (the two lateral stretches solved for zero lateral normal stress, lateral shear not allowed: exact
/// for isotropic laws and for fibers of the law along T), and its derivative dP/dλ (the Schur
/// complement of the lateral block). Elastic response from the initial state (history laws: the
/// instantaneous one). Non-ok status when the law refuses a state on the way.
MaterialStatus uniaxial_nominal_stress(const Material& material, const Vec3& T, double stretch, FiberForce& out);
/// The same from the history `state_old` over a step dt, writing the new history into `state_new`
/// (both material.state_size() values): a viscoelastic host's relaxed uniaxial stress and its
/// algorithmic stiffness.
MaterialStatus uniaxial_nominal_stress(const Material& material, const Vec3& T, double stretch, FiberForce& out,
                                       const double* state_old, double* state_new, double dt);

// --- Where fiber nodes sit in the mesh ----------------------------------------------------------------

/// A point's host: up to 10 nodes and their shape-function values at the point.
struct HostPoint {
  int element = -1;  ///< solid element, or face index within the tie surface
  int count = 0;
  std::array<int, 10> nodes{};
  std::array<double, 10> weights{};
  /// Σ weights_a X_a (the point as the host sees it).
  Vec3 position(const std::vector<Vec3>& x) const;
};

/// Finds the host of a reference point: bounding boxes of the candidates (solid elements, or the faces
/// of one surface) binned in a uniform grid (cells about the mean box size), the candidates of the
/// point's bin tested by the inverse isoparametric map (Newton on ξ; on faces the closest point).
/// Building is O(candidates), each query O(candidates in one bin): no loop over all pairs.
class HostLocator {
 public:
  /// Solid elements: the host contains X within a relative 1e-8 of its reference cell.
  explicit HostLocator(const Mesh& mesh);
  /// Faces (quads and 6-node triangles): the host is the face whose closest point to X is nearest,
  /// within `relative_gap` × the face's size (a faceted surface lies inside the curve it samples).
  HostLocator(const Mesh& mesh, const std::vector<Quad>& quads, const std::vector<Tri6>& tris,
              double relative_gap = 0.1);
  std::optional<HostPoint> locate(const Vec3& X) const;

 private:
  void bin(const std::vector<std::array<Vec3, 2>>& boxes);
  std::optional<HostPoint> locate_in_element(int e, const Vec3& X) const;
  std::optional<HostPoint> locate_on_face(int f, const Vec3& X, double& distance) const;
  const Mesh& mesh_;
  bool faces_ = false;
  std::vector<Quad> quads_;
  std::vector<Tri6> tris_;
  double relative_gap_ = 0.1;
  Vec3 lo_{0, 0, 0}, cell_{1, 1, 1};
  std::array<int, 3> dims_{1, 1, 1};
  std::vector<int> offsets_, items_;  ///< bin b: items_[offsets_[b] .. offsets_[b + 1])
  std::vector<double> sizes_;         ///< each item's box diagonal
};

/// The inverse isoparametric map of one element: ξ with Σ N_a(ξ) X_a = X (Newton from the centre),
/// and whether it lies in the reference element within `slack` (in reference coordinates).
bool element_inverse_map(const Mesh& mesh, int element, const Vec3& X, double slack, Vec3& xi);

// --- The fibers -------------------------------------------------------------------------------------

enum class FiberTie {
  embedded,  ///< nodes in the solid elements that contain them
  surface,   ///< nodes on the faces of a named surface (its nodes only)
};

/// Fiber polylines in the reference configuration, cut into elements of `order` (1: 2-node, 2: 3-node
/// with its middle node at the mid-point of the element's arc on the polyline).
struct FiberLines {
  std::vector<std::vector<Vec3>> lines;  ///< each fiber's points, in order (≥ 2)
};

struct FiberOptions {
  FiberLaw law;
  int order = 1;                    ///< 1: 2-node elements, 2: 3-node elements
  FiberTie tie = FiberTie::embedded;
  std::string surface;              ///< the tie = surface face set (a named surface of the mesh)
  bool volume_correction = false;   ///< subtract the host's uniaxial stress along the fiber over A (a
                                    ///< viscoelastic host's relaxed one: its history kept per fiber point)
  std::string field = "fibers";     ///< the scene key the messages name
};

/// The per-element state of the fibers at an iterate (element order of TiedFibers).
struct FiberElementState {
  double stretch = 1.0;  ///< mean over the element's Gauss points
  double force = 0.0;    ///< axial force of the fiber [N] (corrected when volume_correction)
  double angle_deg = 0.0;///< current angle of the element's chord from the z axis [deg]
};

/// Fiber elements tied to a mesh (a contribution of kind interface: internal forces).
class TiedFibers final : public Contribution {
 public:
  /// Locates every fiber node; InputError naming options.field when a node has no host (outside every
  /// element, or off the tie surface), when the tie surface does not exist, or when the area is not
  /// positive. `element_material`: the host's materials (for the volume correction; may be empty without).
  TiedFibers(const Mesh& mesh, const FiberLines& lines, FiberOptions options,
             const std::vector<MaterialPtr>& element_material = {});

  Kind kind() const override { return Kind::interface; }
  std::string name() const override { return "fibers"; }
  void validate(const Mesh& mesh) const override;
  void declare_couplings(Couplings& couplings) const override;
  /// The history of the volume correction in a host with one (QLV): the host law's state per Gauss point.
  int state_size() const override { return state_size_; }
  void init_state(double* state) const override;
  MaterialStatus assemble(const Mesh& mesh, const Iterate& it, AssemblySink& sink) const override;
  /// Probes <stem>_max_stretch, <stem>_max_force [N], <stem>_mean_abs_angle [deg]; the field <stem>
  /// (line2/line3 cells) with per-element stretch, force [N], current angle [deg] and the nodes'
  /// displacement [mm]. The stem is "fibers" for the first [[fibers]] table, "fibers_k" for table k.
  void report(const Mesh& mesh, const Iterate& it, ContributionReport& out) const override;

  int num_elements() const { return int(elements_.size()); }
  int nodes_per_element() const { return options_.order + 1; }
  /// Reference positions of the fiber nodes (the host's interpolation at them) and each element's
  /// nodes (VTK/XDMF line order: the two ends, then the middle).
  const std::vector<Vec3>& reference_points() const { return reference_; }
  const std::vector<int>& connectivity() const { return connectivity_; }
  /// The fiber (polyline index) of each element.
  const std::vector<int>& fiber_of_element() const { return fiber_; }
  std::vector<FiberElementState> states(const Mesh& mesh, const Iterate& it) const;
  /// Current positions of the fiber nodes.
  std::vector<Vec3> current_points(const Mesh& mesh, const Iterate& it) const;
  const FiberOptions& options() const { return options_; }

 private:
  struct Element {
    std::vector<int> nodes;            ///< unique host nodes the element couples
    std::vector<double> weights;       ///< nodes.size() × (order + 1), column i: fiber node i's weights
    const Material* host = nullptr;    ///< the host material for the volume correction
    long state = -1;                   ///< offset of its points' host history (-1: none)
  };
  int state_size_ = 0;
  FiberOptions options_;
  std::vector<Vec3> reference_;
  std::vector<HostPoint> hosts_;
  std::vector<int> connectivity_, fiber_;
  std::vector<Element> elements_;
  std::vector<MaterialPtr> materials_;  ///< keeps the host materials alive
};

}  // namespace softhom::fe
