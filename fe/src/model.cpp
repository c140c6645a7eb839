#include "softhom/fe/model.hpp"

#include <algorithm>
#include <map>
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
  // A model of contributions alone (a shell) has no solid elements; one of them must then be a domain.
  const bool other_domain = std::any_of(contributions.begin(), contributions.end(),
                                        [](const ContributionPtr& c) { return c && c->kind() == Contribution::Kind::domain; });
  if (mesh.num_elements() == 0 && !other_domain) throw InputError("mesh", "", "no elements");
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

namespace {

/// The free rigid motions of the nodes `part` (see free_rigid_motions): motions that move no node of the
/// part (a rotation about the line of collinear nodes) are not motions of it and are not reported.
std::vector<std::string> free_motions_of(const Mesh& mesh, const std::vector<int>& part, const std::vector<char>& constrained) {
  // Rigid motion m at node n: t_m for m < 3, e_{m−3} × (X_n − c) / L for m ≥ 3 (scaled by the part's
  // size L so that both kinds have entries of order one). Motion a = Σ_m a_m mode_m is held iff some
  // prescribed dof moves: ‖C a‖ > 0 with C_dm = mode_m[dof] over the prescribed dofs, so the free
  // motions are the null space of the 6 × 6 Gram matrix CᵀC within the motions that move the part
  // (the range of the Gram matrix F over all its dofs).
  Vec3 c = Vec3::Zero();
  for (int n : part) c += mesh.nodes[n];
  if (!part.empty()) c /= double(part.size());
  double L = 0.0;
  for (int n : part) L = std::max(L, (mesh.nodes[n] - c).norm());
  if (!(L > 0.0)) L = 1.0;
  Eigen::Matrix<double, 6, 6> G = Eigen::Matrix<double, 6, 6>::Zero(), F = G;
  for (int n : part) {
    const Vec3 r = (mesh.nodes[n] - c) / L;
    for (int i = 0; i < 3; ++i) {
      Eigen::Matrix<double, 6, 1> row = Eigen::Matrix<double, 6, 1>::Zero();
      row[i] = 1.0;
      for (int a = 0; a < 3; ++a) row[3 + a] = Vec3::Unit(a).cross(r)[i];  // (e_a × r)_i
      F += row * row.transpose();
      if (constrained[3 * n + i]) G += row * row.transpose();
    }
  }
  // Entries of C are O(1): a held motion has ‖C a‖² ≥ O(1) per prescribed dof it moves, a free one
  // has exactly 0 up to round-off (1e-12 leaves room for ~1e4 nodes on one line).
  const double tiny = 1e-12 * std::max(1.0, F.trace());
  static const char* names[6] = {"translation along x", "translation along y", "translation along z",
                                 "rotation about x",    "rotation about y",    "rotation about z"};
  std::vector<std::string> free;
  for (int m = 0; m < 6; ++m)
    if (G(m, m) <= tiny && F(m, m) > tiny) free.emplace_back(names[m]);
  // Free combinations: the null space of G restricted to the range of F.
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> range(F);
  Eigen::Matrix<double, 6, Eigen::Dynamic> basis(6, 0);
  for (int m = 0; m < 6; ++m)
    if (range.eigenvalues()[m] > tiny) {
      basis.conservativeResize(6, basis.cols() + 1);
      basis.col(basis.cols() - 1) = range.eigenvectors().col(m);
    }
  const Eigen::MatrixXd Gr = basis.transpose() * G * basis;
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(Gr);
  int nullity = 0;
  for (int m = 0; m < int(Gr.rows()); ++m) nullity += eig.eigenvalues()[m] <= tiny;
  if (nullity > int(free.size())) free.emplace_back("a combination of rigid motions (a rotation about an axis off the centroid)");
  return free;
}

int find_root(std::vector<int>& parent, int n) {
  while (parent[n] != n) n = parent[n] = parent[parent[n]];
  return n;
}

}  // namespace

std::vector<std::string> free_rigid_motions(const Mesh& mesh, const std::vector<char>& constrained) {
  return free_rigid_motions(mesh, constrained, Couplings{});
}

std::vector<std::string> free_rigid_motions(const Mesh& mesh, const std::vector<char>& constrained, const Couplings& couplings) {
  // Each part held on its own: the parts are the nodes connected through elements and the
  // contributions' couplings (a shell's patches, springs, ...); nodes in neither carry no stiffness and
  // belong to no part.
  const int nn = mesh.num_nodes();
  std::vector<int> parent(nn);
  std::vector<char> used(nn, 0);
  for (int n = 0; n < nn; ++n) parent[n] = n;
  auto join = [&](const int* nodes, int count) {
    for (int k = 0; k < count; ++k) {
      used[nodes[k]] = 1;
      parent[find_root(parent, nodes[k])] = find_root(parent, nodes[0]);
    }
  };
  for (int e = 0; e < mesh.num_elements(); ++e) join(mesh.element_nodes(e), mesh.element_size(e));
  for (int g = 0; g < couplings.size(); ++g)
    join(couplings.nodes.data() + couplings.offsets[g], couplings.offsets[g + 1] - couplings.offsets[g]);
  std::map<int, std::vector<int>> parts;
  for (int n = 0; n < nn; ++n)
    if (used[n]) parts[find_root(parent, n)].push_back(n);
  std::vector<std::string> free;
  for (const auto& [root, part] : parts) {
    std::vector<std::string> f = free_motions_of(mesh, part, constrained);
    if (parts.size() > 1)
      for (std::string& m : f) m += " of the part containing node " + std::to_string(part.front());
    free.insert(free.end(), f.begin(), f.end());
  }
  return free;
}

}  // namespace softhom::fe
