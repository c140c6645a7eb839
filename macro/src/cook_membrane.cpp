// Cook's membrane test problem (see cook_membrane.hpp).
#include "softhom/macro/cook_membrane.hpp"

#include "softhom/macro/geometry.hpp"
#include "softhom/materials/laws.hpp"

namespace softhom::macro {

fe::FeModel make_cook_membrane_problem(int n, double G, double bulk_over_shear, double shear_force) {
  fe::FeModel m;
  m.mesh = make_cook_membrane(n);
  auto id = [&](int i, int j, int k) { return i + (n + 1) * (j + (n + 1) * k); };
  m.element_material.assign(m.mesh.num_elements(), make_material(make_neo_hookean({G, bulk_over_shear * G})));
  fe::DirichletGroup clamp, plane;
  for (int node = 0; node < m.mesh.num_nodes(); ++node) {
    if (m.mesh.nodes[node][0] < 1e-9)
      for (int c = 0; c < 2; ++c) clamp.dofs.push_back(3 * node + c);
    plane.dofs.push_back(3 * node + 2);  // plane strain
  }
  m.dirichlet = {clamp, plane};
  // The tip face (height 16, thickness 1) in n × 1 quads: each carries shear_force / n, a quarter per node.
  fe::NodalLoad load;
  for (int j = 0; j < n; ++j)
    for (int k = 0; k <= 1; ++k)
      for (int jj : {j, j + 1}) {
        load.dofs.push_back(3 * id(n, jj, k) + 1);
        load.scale.push_back(shear_force / (4.0 * n));
      }
  load.value = PiecewiseLinear{{0.0, 1.0}, {0.0, 1.0}};
  m.nodal_loads = {load};
  return m;
}

int cook_tip_dof(int n) { return 3 * (n + (n + 1) * n) + 1; }

}  // namespace softhom::macro
