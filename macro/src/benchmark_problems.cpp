// The shared test and benchmark problems (see benchmark_problems.hpp).
#include "softhom/macro/benchmark_problems.hpp"

#include <algorithm>
#include <cmath>

#include "softhom/macro/geometry.hpp"
#include "softhom/materials/laws.hpp"

namespace softhom::macro {

fe::FeModel make_cook_membrane_problem(int n, double G, double bulk_over_shear, double shear_force, bool tet10) {
  fe::FeModel m;
  m.mesh = tet10 ? fe::hex_to_tet10(make_cook_membrane(n)) : make_cook_membrane(n);
  m.element_material.assign(m.mesh.num_elements(), make_material(make_neo_hookean({G, bulk_over_shear * G})));
  fe::DirichletGroup clamp, plane;
  for (int node = 0; node < m.mesh.num_nodes(); ++node) {
    if (m.mesh.nodes[node][0] < 1e-9)
      for (int c = 0; c < 2; ++c) clamp.dofs.push_back(3 * node + c);
    plane.dofs.push_back(3 * node + 2);  // plane strain
  }
  m.dirichlet = {clamp, plane};
  // Consistent nodal forces of the uniform shear traction on the tip face (height 16, thickness 1).
  const double traction = shear_force / 16.0;
  fe::NodalLoad load;
  const auto quads = m.mesh.surfaces.find("tip");  // (none once split into tets)
  if (quads != m.mesh.surfaces.end())
    for (const fe::Quad& f : quads->second) {
      // Flat bilinear quads: a quarter of the face's force on each vertex.
      const double area = (m.mesh.nodes[f[2]] - m.mesh.nodes[f[0]]).cross(m.mesh.nodes[f[3]] - m.mesh.nodes[f[1]]).norm() / 2;
      for (int node : f) {
        load.dofs.push_back(3 * node + 1);
        load.scale.push_back(traction * area / 4.0);
      }
    }
  for (const fe::Tri6& f : m.mesh.tri_surface("tip")) {
    // Flat 6-node triangles: the vertices get nothing, each mid-edge node a third of the face's force.
    const double area = (m.mesh.nodes[f[1]] - m.mesh.nodes[f[0]]).cross(m.mesh.nodes[f[2]] - m.mesh.nodes[f[0]]).norm() / 2;
    for (int k = 3; k < 6; ++k) {
      load.dofs.push_back(3 * f[k] + 1);
      load.scale.push_back(traction * area / 3.0);
    }
  }
  load.value = PiecewiseLinear{{0.0, 1.0}, {0.0, 1.0}};
  m.nodal_loads = {load};
  return m;
}

int cook_tip_node(const fe::Mesh& mesh) {
  for (int node = 0; node < mesh.num_nodes(); ++node)
    if ((mesh.nodes[node] - Vec3(48, 60, 0)).norm() < 1e-9) return node;
  return -1;
}

int cook_tip_dof(int n) { return 3 * (n + (n + 1) * n) + 1; }

GentHGOParams helix_tube_law(double bulk_over_shear) {
  GentHGOParams p;
  p.G = 0.017;
  p.Jm = 14.0;
  p.K = bulk_over_shear * p.G;
  const double a = 45.0 * M_PI / 180.0;
  p.fibers = {{Vec3(std::sin(a), std::cos(a), 0.0), 0.8, 18.0}, {Vec3(-std::sin(a), std::cos(a), 0.0), 0.8, 18.0}};
  return p;
}

StructureSpec make_helix_tube_spec(double dofs, double bulk_over_shear) {
  StructureSpec spec;
  spec.kind = StructureKind::tube;
  TubeSpec t;
  t.inner_radius = 5.0;
  t.outer_radius = 7.5;
  t.length = 50.0;
  t.sweep_deg = 360.0;
  t.cap_thickness = 2.5;
  // Edge h of near-cubic cells: 3 dofs per node of the wall volume 2.5 · 2π · 6.25 · 50.
  const double h = std::cbrt(3.0 * 2.5 * 2 * M_PI * 6.25 * 50.0 / dofs);
  t.radial_cells = std::max(1, int(std::lround(2.5 / h)));
  t.circumferential_cells = std::max(8, int(std::lround(2 * M_PI * 6.25 / h / 4)) * 4);
  t.axial_cells = std::max(1, int(std::lround(50.0 / h)));
  t.cap_axial_cells = std::max(1, int(std::lround(2.5 / h)));
  t.cap_core_cells = std::max(1, int(std::lround(5.0 / h)));
  spec.tube = t;
  spec.material = make_material(make_gent_hgo(helix_tube_law(bulk_over_shear)));
  spec.fiber_frame = FiberFrame::cylindrical;
  spec.control = LoadControl::pressure;
  spec.load = {{0.0, 180.0}, {0.0, 0.004}};
  return spec;
}

}  // namespace softhom::macro
