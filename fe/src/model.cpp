#include "softhom/fe/model.hpp"

#include <algorithm>
#include <string>

#include <Eigen/Dense>

#include "softhom/fe/tet10_element.hpp"
#include "softhom/materials/errors.hpp"

namespace softhom::fe {

namespace {

void check_node(const Mesh& mesh, int n, const char* field) {
  if (n < 0 || n >= mesh.num_nodes()) throw InputError(field, std::to_string(n), "node id out of range");
}

void check_dofs(const Mesh& mesh, const std::vector<int>& dofs, const char* field) {
  for (int d : dofs)
    if (d < 0 || d >= mesh.num_dofs()) throw InputError(field, std::to_string(d), "dof out of range");
}

template <class Faces>
void check_faces(const Mesh& mesh, const Faces& faces, const char* field) {
  for (const auto& q : faces)
    for (int n : q) check_node(mesh, n, field);
}

}  // namespace

void DirichletGroup::validate(const Mesh& mesh) const {
  if (!scale.empty() && scale.size() != dofs.size())
    throw InputError("dirichlet.scale", std::to_string(scale.size()), "must match the number of dofs");
  check_dofs(mesh, dofs, "dirichlet.dofs");
}

void PressureLoad::validate(const Mesh& mesh) const {
  check_faces(mesh, faces, "pressure.faces");
  check_faces(mesh, tris, "pressure.tris");
}

void NodalLoad::validate(const Mesh& mesh) const {
  if (scale.size() != dofs.size())
    throw InputError("nodal_loads.scale", std::to_string(scale.size()), "must match the number of dofs");
  check_dofs(mesh, dofs, "nodal_loads.dofs");
}

void CavityControl::validate(const Mesh& mesh) const {
  check_faces(mesh, faces, "cavity.faces");
  check_faces(mesh, tris, "cavity.tris");
  if (faces.empty() && tris.empty()) throw InputError("cavity.faces", "", "a cavity needs faces");
  if (!(mask.sum() > 0)) throw InputError("cavity.mask", "", "mask must have a positive entry");
}

std::vector<const Contribution*> FeModel::assembly_order() const {
  std::vector<const Contribution*> order;
  auto internal = [](const Contribution& c) { return c.kind() == Contribution::Kind::domain || c.kind() == Contribution::Kind::interface; };
  for (const ContributionPtr& c : contributions)
    if (internal(*c)) order.push_back(c.get());
  for (const auto& g : dirichlet) order.push_back(&g);
  for (const auto& p : pressures) order.push_back(&p);
  for (const auto& l : nodal_loads) order.push_back(&l);
  if (cavity) order.push_back(&*cavity);
  for (const ContributionPtr& c : contributions)
    if (!internal(*c)) order.push_back(c.get());
  return order;
}

void FeModel::validate() const {
  if (mesh.num_elements() == 0) throw InputError("mesh", "", "no elements");
  if (int(element_material.size()) != mesh.num_elements())
    throw InputError("materials", std::to_string(element_material.size()),
                     "need one material per element (" + std::to_string(mesh.num_elements()) + ")");
  for (const auto& m : element_material)
    if (!m) throw InputError("materials", "null", "every element needs a material");
  check_faces(mesh, mesh.hexes, "mesh.hexes");
  check_faces(mesh, mesh.tets, "mesh.tets");
  for (const ContributionPtr& c : contributions)
    if (!c) throw InputError("contributions", "null", "every contribution must be an object");
  for (const Contribution* c : assembly_order()) c->validate(mesh);
}

double cavity_volume(const std::vector<Vec3>& x, const std::vector<Quad>& faces, const Vec3& mask,
                     const std::vector<Tri6>& tris) {
  double flux = 0.0;
  Vec12 a;
  for (const Quad& q : faces) {
    Mat43 xe;
    for (int k = 0; k < 4; ++k) xe.row(k) = x[q[k]].transpose();
    double f = 0.0;
    quad4_pressure(xe, mask, a, nullptr, f);
    flux += f;
  }
  Vec18 a6;
  for (const Tri6& t : tris) {
    Mat63 xe;
    for (int k = 0; k < 6; ++k) xe.row(k) = x[t[k]].transpose();
    double f = 0.0;
    tri6_pressure(xe, mask, a6, nullptr, f);
    flux += f;
  }
  return -flux / mask.sum();
}

}  // namespace softhom::fe

namespace softhom::fe {

std::vector<std::string> free_rigid_motions(const Mesh& mesh, const std::vector<char>& constrained) {
  // Rigid motion m at node n: t_m for m < 3, e_{m−3} × (X_n − c) / L for m ≥ 3 (scaled by the body size
  // L so that both kinds have entries of order one). Motion a = Σ_m a_m mode_m is held iff some
  // prescribed dof moves: ‖C a‖ > 0 with C_dm = mode_m[dof] over the prescribed dofs, so the free
  // motions are the null space of the 6 × 6 Gram matrix CᵀC.
  const int nn = mesh.num_nodes();
  Vec3 c = Vec3::Zero();
  for (const Vec3& x : mesh.nodes) c += x;
  if (nn > 0) c /= double(nn);
  double L = 0.0;
  for (const Vec3& x : mesh.nodes) L = std::max(L, (x - c).norm());
  if (!(L > 0.0)) L = 1.0;
  Eigen::Matrix<double, 6, 6> G = Eigen::Matrix<double, 6, 6>::Zero();
  for (int n = 0; n < nn; ++n) {
    const Vec3 r = (mesh.nodes[n] - c) / L;
    for (int i = 0; i < 3; ++i) {
      if (!constrained[3 * n + i]) continue;
      Eigen::Matrix<double, 6, 1> row = Eigen::Matrix<double, 6, 1>::Zero();
      row[i] = 1.0;
      for (int a = 0; a < 3; ++a) row[3 + a] = Vec3::Unit(a).cross(r)[i];  // (e_a × r)_i
      G += row * row.transpose();
    }
  }
  // Entries of C are O(1): a held motion has ‖C a‖² ≥ O(1) per prescribed dof it moves, a free one
  // has exactly 0 up to round-off (1e-12 leaves room for ~1e4 nodes on one line).
  const double tiny = 1e-12 * std::max(1.0, G.trace());
  static const char* names[6] = {"translation along x", "translation along y", "translation along z",
                                 "rotation about x",    "rotation about y",    "rotation about z"};
  std::vector<std::string> free;
  for (int m = 0; m < 6; ++m)
    if (G(m, m) <= tiny) free.emplace_back(names[m]);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eig(G);
  int nullity = 0;
  for (int m = 0; m < 6; ++m) nullity += eig.eigenvalues()[m] <= tiny;
  if (nullity > int(free.size())) free.emplace_back("a combination of rigid motions (a rotation about an axis off the centroid)");
  return free;
}

}  // namespace softhom::fe
