#include "softhom/fe/model.hpp"

#include "softhom/fe/tet10_element.hpp"
#include "softhom/materials/errors.hpp"

namespace softhom::fe {

void FeModel::validate() const {
  const int nn = mesh.num_nodes();
  if (mesh.num_elements() == 0) throw InputError("mesh", "", "no elements");
  if (int(element_material.size()) != mesh.num_elements())
    throw InputError("materials", std::to_string(element_material.size()),
                     "need one material per element (" + std::to_string(mesh.num_elements()) + ")");
  for (const auto& m : element_material)
    if (!m) throw InputError("materials", "null", "every element needs a material");
  for (const Hex& h : mesh.hexes)
    for (int n : h)
      if (n < 0 || n >= nn) throw InputError("mesh.hexes", std::to_string(n), "node id out of range");
  for (const Tet10& t : mesh.tets)
    for (int n : t)
      if (n < 0 || n >= nn) throw InputError("mesh.tets", std::to_string(n), "node id out of range");
  for (const auto& g : dirichlet) {
    if (!g.scale.empty() && g.scale.size() != g.dofs.size())
      throw InputError("dirichlet.scale", std::to_string(g.scale.size()), "must match the number of dofs");
    for (int d : g.dofs)
      if (d < 0 || d >= 3 * nn) throw InputError("dirichlet.dofs", std::to_string(d), "dof out of range");
  }
  for (const auto& l : nodal_loads) {
    if (l.scale.size() != l.dofs.size())
      throw InputError("nodal_loads.scale", std::to_string(l.scale.size()), "must match the number of dofs");
    for (int d : l.dofs)
      if (d < 0 || d >= 3 * nn) throw InputError("nodal_loads.dofs", std::to_string(d), "dof out of range");
  }
  auto check_faces = [&](const auto& faces, const char* what) {
    for (const auto& q : faces)
      for (int n : q)
        if (n < 0 || n >= nn) throw InputError(what, std::to_string(n), "node id out of range");
  };
  for (const auto& p : pressures) {
    check_faces(p.faces, "pressure.faces");
    check_faces(p.tris, "pressure.tris");
  }
  if (cavity) {
    check_faces(cavity->faces, "cavity.faces");
    check_faces(cavity->tris, "cavity.tris");
    if (cavity->faces.empty() && cavity->tris.empty()) throw InputError("cavity.faces", "", "a cavity needs faces");
    if (!(cavity->mask.sum() > 0)) throw InputError("cavity.mask", "", "mask must have a positive entry");
  }
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
