// Shell structures (shell_structure.hpp): the built-in surfaces, their edge conditions and loads.
#include "softhom/macro/shell_structure.hpp"

#include <algorithm>
#include <cmath>

#include "softhom/macro/structures.hpp"
#include "softhom/materials/errors.hpp"

namespace softhom::macro {
namespace {

using Type = ShellEdgeCondition::Type;

void hold(fe::FeModel& m, const std::vector<int>& nodes, int component) {
  std::vector<int> dofs;
  for (int n : nodes) dofs.push_back(3 * n + component);
  if (!dofs.empty()) m.dirichlet.emplace_back(std::move(dofs), std::vector<double>{}, PiecewiseLinear::constant(0.0));
}

/// The axis normal to a symmetry or diaphragm edge: given, or the first letter of its name.
int edge_normal(const ShellEdgeCondition& c, const std::string& field) {
  if (c.normal >= 0) return c.normal;
  if (!c.edge.empty() && c.edge[0] >= 'x' && c.edge[0] <= 'z') return c.edge[0] - 'x';
  throw InputError(field + ".normal", "", "missing: the axis normal to the plane of edge \"" + c.edge + "\" (\"x\", \"y\" or \"z\")");
}

/// The node of `nodes` nearest to p.
int nearest(const std::vector<Vec3>& nodes, const Vec3& p) {
  int best = 0;
  for (int n = 1; n < int(nodes.size()); ++n)
    if ((nodes[n] - p).norm() < (nodes[best] - p).norm()) best = n;
  return best;
}

/// Signed volume enclosed by the triangles (outward positive), closed up to planes through the origin,
/// or (about_centroid) up to cones from the nodes' centroid.
double enclosed_volume(const fe::Mesh& mesh, const std::vector<fe::Tri3>& tris, bool about_centroid = false) {
  std::vector<Vec3> x = mesh.nodes;
  if (about_centroid) {
    Vec3 c = Vec3::Zero();
    for (const Vec3& p : x) c += p;
    c /= double(std::max<std::size_t>(x.size(), 1));
    for (Vec3& p : x) p -= c;
  }
  return fe::cavity_volume(x, fe::shell_load_faces(tris), Vec3(1, 1, 1));
}

/// Applies the edge conditions: Dirichlet groups into m, rotation conditions into `edges`; returns the
/// names of the symmetry edges (which may close a cavity).
std::vector<std::string> apply_edges(const ShellSurface& surface, const std::vector<ShellEdgeCondition>& conditions,
                                     fe::FeModel& m, std::vector<std::pair<std::array<int, 2>, fe::ShellEdge>>& edges) {
  std::vector<std::string> symmetry;
  for (std::size_t k = 0; k < conditions.size(); ++k) {
    const ShellEdgeCondition& c = conditions[k];
    const std::string field = "shell.edges[" + std::to_string(k) + "]";
    const auto found = surface.edges.find(c.edge);
    if (found == surface.edges.end()) {
      std::string names;
      for (const auto& [name, list] : surface.edges) names += (names.empty() ? "" : ", ") + ("\"" + name + "\"");
      throw InputError(field + ".edge", "\"" + c.edge + "\"", "the surface has no edge of that name (it has " + (names.empty() ? std::string("none") : names) + ")");
    }
    const std::vector<int> nodes = surface.edge_nodes(c.edge);
    const bool clamped_rotation = c.type == Type::clamped || c.type == Type::symmetry;
    for (const auto& e : found->second) edges.push_back({e, clamped_rotation ? fe::ShellEdge::clamped : fe::ShellEdge::free});
    switch (c.type) {
      case Type::clamped:
      case Type::simply_supported:
        for (int i = 0; i < 3; ++i) hold(m, nodes, i);
        break;
      case Type::symmetry:
        hold(m, nodes, edge_normal(c, field));
        symmetry.push_back(c.edge);
        break;
      case Type::diaphragm: {
        const int n = edge_normal(c, field);
        for (int i = 0; i < 3; ++i)
          if (i != n) hold(m, nodes, i);
        break;
      }
      case Type::free: break;
    }
  }
  return symmetry;
}

/// Volume control needs a cavity: every boundary edge on a symmetry plane.
void require_cavity(const fe::ShellDomain& shell, const ShellSurface& surface, const std::vector<std::string>& symmetry) {
  std::vector<std::pair<int, int>> closing;
  for (const std::string& name : symmetry)
    for (const auto& e : surface.edges.at(name)) closing.push_back({std::min(e[0], e[1]), std::max(e[0], e[1])});
  std::sort(closing.begin(), closing.end());
  const auto& tris = shell.triangles();
  for (int t = 0; t < int(tris.size()); ++t)
    for (int k = 0; k < 3; ++k) {
      if (shell.topology().neighbour[t][k] >= 0) continue;
      const int a = tris[t][(k + 1) % 3], b = tris[t][(k + 2) % 3];
      if (!std::binary_search(closing.begin(), closing.end(), std::make_pair(std::min(a, b), std::max(a, b))))
        throw InputError("load.control", "\"volume\"",
                         "volume control needs a closed surface (or one closed by symmetry edges), but element " +
                             std::to_string(t) + " has an open boundary edge (nodes " + std::to_string(a) + ", " +
                             std::to_string(b) + ")");
    }
}

}  // namespace

ShellSurface make_shell_surface(const ShellStructureSpec& s) {
  switch (s.shape) {
    case ShellShape::sphere: return make_shell_sphere(s.radius, s.cells, false);
    case ShellShape::sphere_octant: return make_shell_sphere(s.radius, s.cells, true);
    case ShellShape::cylinder: return make_shell_cylinder(s.radius, s.length, s.sweep_deg, s.cells, s.axial_cells);
    case ShellShape::strip: return make_shell_strip(s.length, s.width, s.cells, s.axial_cells);
    case ShellShape::hemisphere: return make_shell_hemisphere(s.radius, s.hole_deg, s.cells);
    case ShellShape::vault: return make_shell_vault(s.radius, s.length, s.angle_deg, s.cells, s.axial_cells);
    case ShellShape::gmsh: return s.imported;
  }
  return {};
}

std::vector<ShellEdgeCondition> default_shell_edges(ShellShape shape, double sweep_deg) {
  auto sym = [](const char* edge, int normal) { return ShellEdgeCondition{edge, Type::symmetry, normal}; };
  switch (shape) {
    case ShellShape::sphere_octant: return {sym("x0", 0), sym("y0", 1), sym("z0", 2)};
    case ShellShape::cylinder:
      if (std::abs(sweep_deg - 90.0) < 1e-9) return {sym("theta0", 1), sym("theta1", 0)};
      return {};
    case ShellShape::hemisphere: return {sym("x0", 0), sym("y0", 1)};
    case ShellShape::vault: return {sym("x0", 0), sym("y0", 1), ShellEdgeCondition{"xL", Type::diaphragm, 0}};
    default: return {};
  }
}

double shell_nodes_estimate(const ShellStructureSpec& s) {
  switch (s.shape) {
    case ShellShape::sphere: return 4.0 * double(s.cells) * s.cells + 2.0;
    case ShellShape::sphere_octant: return 0.5 * double(s.cells + 1) * (s.cells + 2);
    case ShellShape::hemisphere: return double(s.cells + 1) * (s.cells + 1);
    case ShellShape::gmsh: return double(s.imported.mesh.num_nodes());
    default: return double(s.cells + 1) * (s.axial_cells + 1);
  }
}

void build_shell(Structure& s) {
  const ShellStructureSpec& spec = s.spec.shell;
  fe::FeModel& m = s.model;
  ShellSurface surface = make_shell_surface(spec);
  m.mesh = surface.mesh;
  // Orient consistently first; a closed (or symmetry-closed) surface then faces out of its cavity.
  const fe::ShellTopology top = fe::shell_topology(surface.triangles, m.mesh.num_nodes(), true, "shell");
  // An imported surface (a vessel open at its ends) faces away from its nodes' centroid in the mean:
  // the flux of x − c through it is positive, as a closed surface's outward one is (its openings add
  // their share with the same sign when they face away from c too).
  const bool imported = spec.shape == ShellShape::gmsh;
  const bool cavity = s.spec.control == LoadControl::volume || top.boundary_edges == 0 || imported;
  if (cavity && enclosed_volume(m.mesh, surface.triangles, imported) < 0.0)
    for (fe::Tri3& t : surface.triangles) std::swap(t[1], t[2]);
  // The scene's conditions first (shell.edges[k] in messages), then the shape's own symmetry edges
  // that none of them replaces.
  std::vector<ShellEdgeCondition> conditions = spec.edges;
  for (const ShellEdgeCondition& d : default_shell_edges(spec.shape, spec.sweep_deg))
    if (std::none_of(spec.edges.begin(), spec.edges.end(), [&](const ShellEdgeCondition& c) { return c.edge == d.edge; }))
      conditions.push_back(d);
  fe::ShellSpec shell{surface.triangles, {}, spec.section, spec.frame, true, surface.groups};
  const std::vector<std::string> symmetry = apply_edges(surface, conditions, m, shell.edges);
  if (spec.shape == ShellShape::sphere) {
    // A closed sphere has no edge to hold: its six rigid motions are held by the tangential
    // components at three poles, which leave every symmetric deformation free.
    const double R = spec.radius;
    hold(m, {nearest(m.mesh.nodes, Vec3(R, 0, 0))}, 1);
    hold(m, {nearest(m.mesh.nodes, Vec3(R, 0, 0))}, 2);
    hold(m, {nearest(m.mesh.nodes, Vec3(0, R, 0))}, 0);
    hold(m, {nearest(m.mesh.nodes, Vec3(0, R, 0))}, 2);
    hold(m, {nearest(m.mesh.nodes, Vec3(0, 0, R))}, 0);
    hold(m, {nearest(m.mesh.nodes, Vec3(0, 0, R))}, 1);
  }
  auto domain = std::make_shared<fe::ShellDomain>(m.mesh, shell);
  s.shell = domain;
  m.add(domain);
  // The mid-surface as named faces for [[contact.obstacles]]: "shell" (all of it) and each named group,
  // each triangle a quad with its last node doubled (the contact's quad rule integrates it exactly).
  const std::vector<fe::Quad> mid = fe::shell_load_faces(domain->triangles());
  m.mesh.surfaces["shell"] = mid;
  for (const auto& [name, members] : surface.groups)
    for (int t : members) m.mesh.surfaces[name].push_back(mid[t]);
  for (int n = 0; n < m.mesh.num_nodes(); ++n) s.inner_nodes.push_back(n);
  const std::vector<fe::Quad> faces = fe::shell_load_faces(domain->triangles());
  if (s.spec.control == LoadControl::pressure) {
    m.pressures.emplace_back(faces, s.spec.load);
  } else if (s.spec.control == LoadControl::volume) {
    require_cavity(*domain, surface, symmetry);
    m.cavity = fe::CavityControl(faces, Vec3(1, 1, 1), s.spec.load);
  } else {
    throw InputError("load.control", "\"stretch\"", "a shell is driven by pressure or volume");
  }
}

}  // namespace softhom::macro
