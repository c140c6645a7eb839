#pragma once
// A structure-scale FE problem: mesh, materials per element, prescribed displacements, follower
// pressures and an optional cavity-volume control. Pure data; the Newton driver is in solver.hpp.
#include <optional>
#include <string>
#include <vector>

#include "softhom/fe/hex8.hpp"
#include "softhom/fe/mesh.hpp"
#include "softhom/materials/loading.hpp"
#include "softhom/materials/material.hpp"

namespace softhom::fe {

/// u_dof(t) = scale_k · value(t) for every dof k of the group (dof = 3 · node + component).
struct DirichletGroup {
  std::vector<int> dofs;
  std::vector<double> scale;  ///< same size as dofs (1 when empty)
  PiecewiseLinear value = PiecewiseLinear::constant(0.0);
};

/// Follower pressure p(t) on quads and 6-node triangles (outward normals of the solid): the load
/// −p n da acts on the solid.
struct PressureLoad {
  std::vector<Quad> faces;
  PiecewiseLinear pressure;
  std::vector<Tri6> tris;
};

/// Dead (configuration-independent) nodal forces f_dof(t) = scale_k · value(t), e.g. the consistent
/// nodal forces of a uniform traction on a face of the reference configuration.
struct NodalLoad {
  std::vector<int> dofs;
  std::vector<double> scale;  ///< same size as dofs
  PiecewiseLinear value = PiecewiseLinear::constant(0.0);
};

/// Cavity-volume control: the pressure on `faces` is an unknown, determined by the constraint that
/// the enclosed volume equals volume_ratio(t) · V0. Passes pressure maxima (limit points).
/// The cavity is closed by the faces and by planes on which (mask ⊙ x) · n = 0 (symmetry planes
/// through the origin normal to masked axes, or planes normal to unmasked axes), so that
/// V = −(1/Σ mask) ∫ (mask ⊙ x) · n da over the faces.
struct CavityControl {
  std::vector<Quad> faces;
  Vec3 mask{1.0, 1.0, 1.0};
  PiecewiseLinear volume_ratio;
  std::vector<Tri6> tris;  ///< 6-node triangle faces (tet meshes), in addition to `faces`
};

struct FeModel {
  Mesh mesh;
  std::vector<MaterialPtr> element_material;  ///< one per element (shared pointers may repeat)
  Formulation formulation = Formulation::fbar;
  std::vector<DirichletGroup> dirichlet;
  std::vector<PressureLoad> pressures;
  std::vector<NodalLoad> nodal_loads;
  std::optional<CavityControl> cavity;

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
std::vector<std::string> free_rigid_motions(const Mesh& mesh, const std::vector<char>& constrained);

}  // namespace softhom::fe
