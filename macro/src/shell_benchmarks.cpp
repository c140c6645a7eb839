// The shell benchmarks the tests and benches share (shell_benchmarks.hpp): Sze, Liu & Lo (2004) and the thin tube.
#include "softhom/macro/shell_benchmarks.hpp"

#include <cmath>

#include "softhom/materials/laws.hpp"

namespace softhom::macro {

int nearest_node(const fe::Mesh& mesh, const Vec3& p) {
  int best = 0;
  for (int n = 1; n < mesh.num_nodes(); ++n)
    if ((mesh.nodes[n] - p).norm() < (mesh.nodes[best] - p).norm()) best = n;
  return best;
}

Structure build_unpressurized_shell(StructureSpec spec) {
  spec.kind = StructureKind::shell;
  spec.control = LoadControl::pressure;
  spec.load = PiecewiseLinear{{0.0, 1.0}, {0.0, 0.0}};
  return build_structure(spec);
}

std::shared_ptr<const ShellSection> small_strain_shell_section(double E, double nu, double thickness) {
  NeoHookeanParams p;
  p.mu = E / (2 * (1 + nu));
  p.K = E / (3 * (1 - 2 * nu));
  return std::make_shared<ShellSection>(std::vector<ShellLayer>{{make_material(make_neo_hookean(p)), thickness, 3}},
                                        PlaneStressMode::compressible);
}

PinchedHemisphere make_pinched_hemisphere(int cells, double force) {
  const double R = 10.0;
  StructureSpec spec;
  spec.shell.shape = ShellShape::hemisphere;
  spec.shell.radius = R;
  spec.shell.hole_deg = 18.0;
  spec.shell.cells = cells;
  spec.shell.section = small_strain_shell_section(6.825e7, 0.3, 0.04);
  PinchedHemisphere h;
  h.structure = build_unpressurized_shell(spec);
  fe::FeModel& m = h.structure.model;
  h.node_a = nearest_node(m.mesh, Vec3(R, 0, 0));
  h.node_b = nearest_node(m.mesh, Vec3(0, R, 0));
  const PiecewiseLinear ramp{{0.0, 1.0}, {0.0, 1.0}};
  m.nodal_loads.emplace_back(std::vector<int>{3 * h.node_a, 3 * h.node_b + 1}, std::vector<double>{0.5 * force, -0.5 * force}, ramp);
  m.dirichlet.emplace_back(std::vector<int>{3 * h.node_a + 2}, std::vector<double>{}, PiecewiseLinear::constant(0.0));
  return h;
}

PulloutCylinder make_pullout_cylinder(int cells_around, int cells_axial, double force) {
  const double R = 4.953, L = 10.35;
  StructureSpec spec;
  spec.shell.shape = ShellShape::cylinder;
  spec.shell.radius = R;
  spec.shell.length = L / 2;
  spec.shell.sweep_deg = 90.0;
  spec.shell.cells = cells_around;
  spec.shell.axial_cells = cells_axial;
  spec.shell.section = small_strain_shell_section(10.5e6, 0.3125, 0.094);
  spec.shell.edges = {{"z0", ShellEdgeCondition::Type::symmetry, 2}};
  PulloutCylinder c;
  c.structure = build_unpressurized_shell(spec);
  fe::FeModel& m = c.structure.model;
  // The model spans z ∈ [0, L/2] with z = 0 the mid-length plane: A and B there, C on the free end.
  c.node_a = nearest_node(m.mesh, Vec3(0, R, 0));
  c.node_b = nearest_node(m.mesh, Vec3(R, 0, 0));
  c.node_c = nearest_node(m.mesh, Vec3(R, 0, L / 2));
  const PiecewiseLinear ramp{{0.0, 1.0}, {0.0, 1.0}};
  // A lies on two symmetry planes: a quarter of the point force.
  m.nodal_loads.emplace_back(std::vector<int>{3 * c.node_a + 1}, std::vector<double>{0.25 * force}, ramp);
  return c;
}

std::array<double, 2> RolledCantilever::tip(double M) const {
  const double theta = M * length / bending_stiffness;
  if (theta < 1e-12) return {0.0, 0.0};
  return {length * (std::sin(theta) / theta - 1.0), length * (1.0 - std::cos(theta)) / theta};
}

RolledCantilever make_rolled_cantilever(int cells, int cells_across, double fraction, bool hold_lateral) {
  const double L = 12.0, W = 1.0, t = 0.1, E = 1.2e6;
  StructureSpec spec;
  spec.shell.shape = ShellShape::strip;
  spec.shell.length = L;
  spec.shell.width = W;
  spec.shell.cells = cells;
  spec.shell.axial_cells = cells_across;
  spec.shell.section = small_strain_shell_section(E, 0.0, t);
  spec.shell.edges = {{"xmin", ShellEdgeCondition::Type::clamped, -1}};
  RolledCantilever c;
  c.structure = build_unpressurized_shell(spec);
  c.length = L;
  c.bending_stiffness = E * W * t * t * t / 12.0;
  c.max_moment = 2.0 * M_PI * c.bending_stiffness / L;
  fe::FeModel& m = c.structure.model;
  c.tip_node = nearest_node(m.mesh, Vec3(L, 0, 0));
  if (hold_lateral) {
    std::vector<int> lateral(m.mesh.num_nodes());
    for (int n = 0; n < m.mesh.num_nodes(); ++n) lateral[n] = 3 * n + 1;
    m.dirichlet.emplace_back(lateral, std::vector<double>{}, PiecewiseLinear::constant(0.0));
  }
  const ShellSurface surface = make_shell_surface(spec.shell);
  const auto pairs = fe::shell_edge_moment_pairs(m.mesh, c.structure.shell->triangles(), surface.edges.at("xmax"), "xmax");
  // About −y: the chord along +x turns toward +z (the strip rolls up).
  c.moment = std::make_shared<fe::ShellEdgeMoment>(pairs, Vec3(0, -1, 0), PiecewiseLinear{{0.0, 1.0}, {0.0, fraction * c.max_moment}},
                                                   "shell_edge_moment");
  m.add(c.moment);
  return c;
}

MaterialPtr thin_wall_tube_law(bool fibers) {
  GentHGOParams g;
  g.G = 1.0;
  g.Jm = 1e4;
  g.K = 1000.0;
  g.invariant = FiberInvariant::isochoric;
  if (fibers)
    for (double s : {1.0, -1.0}) {
      FiberFamily f;
      f.direction = Vec3(std::cos(s * 40.0 * M_PI / 180.0), std::sin(s * 40.0 * M_PI / 180.0), 0.0);
      f.k1 = 2.0;
      f.k2 = 1.0;
      g.fibers.push_back(f);
    }
  return make_material(make_gent_hgo(g));
}

Mat3 tube_wall_cauchy(const Material& law, double hoop_stretch) {
  Mat3 F = Mat3::Zero();
  F(0, 0) = hoop_stretch;
  F(1, 1) = 1.0;
  F(2, 2) = 1.0 / hoop_stretch;
  Mat3 P;
  law.evaluate(F, nullptr, nullptr, 0.0, P, nullptr);
  return P * F.transpose();
}

double ThinWallTube::radius(const fe::Simulation& sim) const {
  const std::vector<Vec3> x = sim.current_positions();
  double r = 0.0;
  for (int n : radius_nodes) r += std::hypot(x[n].x(), x[n].y()) / double(radius_nodes.size());
  return r;
}

namespace {

/// The z dofs of the nodes at z = L.
std::vector<int> end_z_dofs(const fe::Mesh& mesh, double length) {
  std::vector<int> dofs;
  for (int n = 0; n < mesh.num_nodes(); ++n)
    if (std::abs(mesh.nodes[n].z() - length) < 1e-9 * length) dofs.push_back(3 * n + 2);
  return dofs;
}

}  // namespace

ThinWallTube make_thin_wall_tube_shell(const MaterialPtr& law, const ThinWallTubeSize& size, int cells, double pressure) {
  StructureSpec spec;
  spec.kind = StructureKind::shell;
  spec.shell.shape = ShellShape::cylinder;
  spec.shell.radius = size.radius;
  spec.shell.length = size.length;
  spec.shell.sweep_deg = 90.0;
  spec.shell.cells = cells;
  spec.shell.axial_cells = 2;
  spec.shell.frame.kind = fe::ShellFrameRule::Kind::cylindrical;
  spec.shell.frame.axis = Vec3::UnitZ();
  spec.shell.section = std::make_shared<ShellSection>(std::vector<ShellLayer>{{law, size.wall, 3}});
  spec.shell.edges = {{"z0", ShellEdgeCondition::Type::symmetry, 2}, {"z1", ShellEdgeCondition::Type::symmetry, 2}};
  spec.control = LoadControl::pressure;
  spec.load = PiecewiseLinear{{0.0, 1.0}, {0.0, pressure}};
  ThinWallTube t;
  t.structure = build_structure(spec);
  for (int n = 0; n < t.structure.model.mesh.num_nodes(); ++n) t.radius_nodes.push_back(n);
  t.end_dofs = end_z_dofs(t.structure.model.mesh, size.length);
  return t;
}

ThinWallTube make_thin_wall_tube_solid(const MaterialPtr& law, const ThinWallTubeSize& size, int cells, int axial_cells, double pressure) {
  StructureSpec spec;
  spec.kind = StructureKind::tube;
  spec.tube.inner_radius = size.radius - 0.5 * size.wall;
  spec.tube.outer_radius = size.radius + 0.5 * size.wall;
  spec.tube.length = size.length;
  spec.tube.radial_cells = 1;
  spec.tube.circumferential_cells = cells;
  spec.tube.axial_cells = axial_cells;
  spec.tube.sweep_deg = 90.0;
  spec.tet10 = true;
  spec.plane_strain = true;
  spec.material = law;
  spec.fiber_frame = FiberFrame::cylindrical;
  spec.control = LoadControl::pressure;
  spec.load = PiecewiseLinear{{0.0, 1.0}, {0.0, pressure}};
  ThinWallTube t;
  t.structure = build_structure(spec);
  const fe::Mesh& mesh = t.structure.model.mesh;
  for (int n = 0; n < mesh.num_nodes(); ++n)
    if (std::abs(std::hypot(mesh.nodes[n].x(), mesh.nodes[n].y()) - size.radius) < 1e-6 * size.radius) t.radius_nodes.push_back(n);
  t.end_dofs = end_z_dofs(mesh, size.length);
  return t;
}

}  // namespace softhom::macro
