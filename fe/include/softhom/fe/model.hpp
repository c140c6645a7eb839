#pragma once
// A structure-scale FE problem: the mesh with its solids (materials per element) and the contributions
// acting on it (contribution.hpp): prescribed displacements, follower pressures, nodal forces, an
// optional cavity-volume control, and any other contribution added from outside. The Newton driver is
// in solver.hpp.
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "softhom/fe/contribution.hpp"
#include "softhom/fe/hex8.hpp"
#include "softhom/fe/mesh.hpp"
#include "softhom/materials/loading.hpp"
#include "softhom/materials/material.hpp"

namespace softhom::fe {

/// u_dof(t) = scale_k · value(t) for every dof k of the group (dof = 3 · node + component).
struct DirichletGroup final : Contribution {
  std::vector<int> dofs;
  std::vector<double> scale;  ///< same size as dofs (1 when empty)
  PiecewiseLinear value = PiecewiseLinear::constant(0.0);

  DirichletGroup() = default;
  DirichletGroup(std::vector<int> dofs, std::vector<double> scale, PiecewiseLinear value)
      : dofs(std::move(dofs)), scale(std::move(scale)), value(std::move(value)) {}
  Kind kind() const override { return Kind::constraint; }
  std::string name() const override { return "dirichlet"; }
  void validate(const Mesh& mesh) const override;
  void prescribe(double t, const std::function<void(int, double)>& set) const override;
};

/// Follower pressure p(t) on quads and 6-node triangles (outward normals of the solid): the load
/// −p n da acts on the solid, with its (unsymmetric) load stiffness.
struct PressureLoad final : Contribution {
  std::vector<Quad> faces;
  PiecewiseLinear pressure;
  std::vector<Tri6> tris;

  PressureLoad() = default;
  PressureLoad(std::vector<Quad> faces, PiecewiseLinear pressure, std::vector<Tri6> tris = {})
      : faces(std::move(faces)), pressure(std::move(pressure)), tris(std::move(tris)) {}
  Kind kind() const override { return Kind::load; }
  std::string name() const override { return "pressure"; }
  void validate(const Mesh& mesh) const override;
  void declare_couplings(Couplings& couplings) const override;
  void load_levels(double t, std::vector<double>& levels) const override { levels.push_back(pressure(t)); }
  MaterialStatus assemble(const Mesh& mesh, const Iterate& it, AssemblySink& sink) const override;
};

/// Dead (configuration-independent) nodal forces f_dof(t) = scale_k · value(t), e.g. the consistent
/// nodal forces of a uniform traction on a face of the reference configuration.
struct NodalLoad final : Contribution {
  std::vector<int> dofs;
  std::vector<double> scale;  ///< same size as dofs
  PiecewiseLinear value = PiecewiseLinear::constant(0.0);

  NodalLoad() = default;
  NodalLoad(std::vector<int> dofs, std::vector<double> scale, PiecewiseLinear value)
      : dofs(std::move(dofs)), scale(std::move(scale)), value(std::move(value)) {}
  Kind kind() const override { return Kind::load; }
  std::string name() const override { return "nodal_loads"; }
  void validate(const Mesh& mesh) const override;
  void load_levels(double t, std::vector<double>& levels) const override { levels.push_back(value(t)); }
  MaterialStatus assemble(const Mesh& mesh, const Iterate& it, AssemblySink& sink) const override;
};

/// Cavity-volume control: the pressure on `faces` is an unknown (the bordered unknown of the Newton
/// system), determined by the constraint that the enclosed volume equals volume_ratio(t) · V0. Passes
/// pressure maxima (limit points).
/// The cavity is closed by the faces and by planes on which (mask ⊙ x) · n = 0 (symmetry planes
/// through the origin normal to masked axes, or planes normal to unmasked axes), so that
/// V = −(1/Σ mask) ∫ (mask ⊙ x) · n da over the faces.
struct CavityControl final : Contribution {
  std::vector<Quad> faces;
  Vec3 mask{1.0, 1.0, 1.0};
  PiecewiseLinear volume_ratio;
  std::vector<Tri6> tris;  ///< 6-node triangle faces (tet meshes), in addition to `faces`

  CavityControl() = default;
  CavityControl(std::vector<Quad> faces, Vec3 mask, PiecewiseLinear volume_ratio, std::vector<Tri6> tris = {})
      : faces(std::move(faces)), mask(mask), volume_ratio(std::move(volume_ratio)), tris(std::move(tris)) {}
  Kind kind() const override { return Kind::constraint; }
  std::string name() const override { return "cavity"; }
  /// Its pressure acts on the solid as a load.
  bool external_force() const override { return true; }
  void validate(const Mesh& mesh) const override;
  void declare_couplings(Couplings& couplings) const override;
  /// p a (p the bordered unknown), its load stiffness p ∂a/∂x, the border a = ∂R/∂p, g = ∂V/∂u, and V.
  MaterialStatus assemble(const Mesh& mesh, const Iterate& it, AssemblySink& sink) const override;
};

/// The mesh's solids (hex8 and tet10, one material each, in `formulation`: the element domain the
/// driver evaluates first) and the contributions acting on it: typed lists of the built-in ones and
/// `contributions` for any other (interfaces, ties, further element domains).
struct FeModel {
  Mesh mesh;
  std::vector<MaterialPtr> element_material;  ///< one per element (shared pointers may repeat)
  Formulation formulation = Formulation::fbar;
  std::vector<DirichletGroup> dirichlet;
  std::vector<PressureLoad> pressures;
  std::vector<NodalLoad> nodal_loads;
  std::optional<CavityControl> cavity;  ///< at most one bordered unknown
  std::vector<ContributionPtr> contributions;

  /// Adds a contribution of any kind (e.g. std::make_shared<MySpring>(...)).
  void add(ContributionPtr c) { contributions.push_back(std::move(c)); }
  /// Every contribution beyond the solids, in the order the driver assembles them: domains and
  /// interfaces (internal forces) first, then constraints and loads.
  std::vector<const Contribution*> assembly_order() const;

  /// Throws InputError on inconsistent sizes, bad node ids or invalid elements.
  void validate() const;
};

/// Enclosed volume of a cavity bounded by `faces` in configuration x (see CavityControl).
double cavity_volume(const std::vector<Vec3>& x, const std::vector<Quad>& faces, const Vec3& mask,
                     const std::vector<Tri6>& tris = {});

}  // namespace softhom::fe

namespace softhom::fe {

/// The rigid-body motions of the mesh (translations along x, y, z; rotations about the axes through
/// the node centroid) that the prescribed dofs (`constrained[dof]` ≠ 0) leave free, as phrases:
/// "translation along x", "rotation about z", and "a combination of rigid motions" for a free
/// combination that is none of the six. Empty when every rigid motion is held. The stiffness of a
/// body with a free rigid motion is singular: Simulation refuses it before the first factorization.
/// Each part (nodes connected through elements and `couplings`) is checked on its own, and the phrases
/// of a model with several parts name one node of the part.
std::vector<std::string> free_rigid_motions(const Mesh& mesh, const std::vector<char>& constrained,
                                            const Couplings& couplings);
std::vector<std::string> free_rigid_motions(const Mesh& mesh, const std::vector<char>& constrained);

}  // namespace softhom::fe
