// Triangulated mid-surfaces for shells (shell_geometry.hpp): structured grids mapped onto spheres,
// cylinders, vaults and strips, glued where patches meet.
#include "softhom/macro/shell_geometry.hpp"

#include <algorithm>
#include <cmath>
#include <functional>

#include "softhom/materials/errors.hpp"

namespace softhom::macro {
namespace {

/// A (nu × nv) grid mapped by `map` from [0, 1]², each cell split along the same diagonal; `name` names
/// the four sides (u = 0, u = 1, v = 0, v = 1; "" unnamed). (Alternating diagonals, where nodes of 4 and
/// 8 triangles alternate, give the patch curvature a soft mode: a cantilever strip of square cells
/// bent 1.5 times as far as Euler–Bernoulli's, against 1.06 → 1.016 → 1.005 with one diagonal.)
ShellSurface mapped_grid(int nu, int nv, const std::function<Vec3(double, double)>& map,
                         const std::array<std::string, 4>& name) {
  ShellSurface s;
  auto node = [&](int i, int j) { return i + (nu + 1) * j; };
  for (int j = 0; j <= nv; ++j)
    for (int i = 0; i <= nu; ++i) s.mesh.nodes.push_back(map(double(i) / nu, double(j) / nv));
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      const int a = node(i, j), b = node(i + 1, j), c = node(i + 1, j + 1), d = node(i, j + 1);
      s.triangles.push_back({a, b, c});
      s.triangles.push_back({a, c, d});
    }
  for (int j = 0; j < nv; ++j) {
    if (!name[0].empty()) s.edges[name[0]].push_back({node(0, j), node(0, j + 1)});
    if (!name[1].empty()) s.edges[name[1]].push_back({node(nu, j), node(nu, j + 1)});
  }
  for (int i = 0; i < nu; ++i) {
    if (!name[2].empty()) s.edges[name[2]].push_back({node(i, 0), node(i + 1, 0)});
    if (!name[3].empty()) s.edges[name[3]].push_back({node(i, nv), node(i + 1, nv)});
  }
  return s;
}

/// Merges nodes closer than tol · (bounding size) and renumbers triangles and edges; drops triangles
/// that became degenerate.
void merge_nodes(ShellSurface& s, double tol = 1e-9) {
  const int nn = s.mesh.num_nodes();
  std::vector<int> order(nn);
  for (int k = 0; k < nn; ++k) order[k] = k;
  double size = 0.0;
  for (const Vec3& x : s.mesh.nodes) size = std::max(size, x.cwiseAbs().maxCoeff());
  const double eps = tol * std::max(size, 1e-300);
  std::sort(order.begin(), order.end(), [&](int a, int b) { return s.mesh.nodes[a].x() < s.mesh.nodes[b].x(); });
  std::vector<int> rep(nn, -1);
  for (int a = 0; a < nn; ++a) {
    const int p = order[a];
    if (rep[p] >= 0) continue;
    rep[p] = p;
    for (int b = a + 1; b < nn && s.mesh.nodes[order[b]].x() - s.mesh.nodes[p].x() <= eps; ++b)
      if (rep[order[b]] < 0 && (s.mesh.nodes[order[b]] - s.mesh.nodes[p]).norm() <= eps) rep[order[b]] = p;
  }
  std::vector<int> id(nn, -1);
  std::vector<Vec3> nodes;
  for (int k = 0; k < nn; ++k)
    if (rep[k] == k) {
      id[k] = int(nodes.size());
      nodes.push_back(s.mesh.nodes[k]);
    }
  s.mesh.nodes = nodes;
  std::vector<fe::Tri3> tris;
  for (fe::Tri3 t : s.triangles) {
    for (int& n : t) n = id[rep[n]];
    if (t[0] != t[1] && t[1] != t[2] && t[0] != t[2]) tris.push_back(t);
  }
  s.triangles = tris;
  for (auto& [name, list] : s.edges)
    for (auto& e : list)
      for (int& n : e) n = id[rep[n]];
}

/// Turns every triangle whose normal points toward `inside(centroid)` (convex surfaces).
void orient_outward(ShellSurface& s, const std::function<Vec3(const Vec3&)>& outward) {
  for (fe::Tri3& t : s.triangles) {
    const Vec3 &a = s.mesh.nodes[t[0]], &b = s.mesh.nodes[t[1]], &c = s.mesh.nodes[t[2]];
    if ((b - a).cross(c - a).dot(outward((a + b + c) / 3.0)) < 0.0) std::swap(t[1], t[2]);
  }
}

void append(ShellSurface& to, const ShellSurface& from) {
  const int off = to.mesh.num_nodes();
  to.mesh.nodes.insert(to.mesh.nodes.end(), from.mesh.nodes.begin(), from.mesh.nodes.end());
  for (fe::Tri3 t : from.triangles) to.triangles.push_back({t[0] + off, t[1] + off, t[2] + off});
  for (const auto& [name, list] : from.edges)
    for (const auto& e : list) to.edges[name].push_back({e[0] + off, e[1] + off});
}

void require(bool ok, const std::string& field, double value, const std::string& why) {
  if (!ok) throw InputError(field, format_number(value), why);
}

}  // namespace

std::vector<int> ShellSurface::edge_nodes(const std::string& name) const {
  std::vector<int> out;
  const auto it = edges.find(name);
  if (it == edges.end()) return out;
  for (const auto& e : it->second) out.insert(out.end(), e.begin(), e.end());
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

ShellSurface make_shell_sphere(double radius, int n, bool octant) {
  require(radius > 0.0, "shell.radius", radius, "must be > 0");
  require(n >= 1, "shell.cells", n, "must be ≥ 1");
  // The octahedron face x + y + z = 1, x, y, z ≥ 0 subdivided into n² triangles (barycentric grid
  // (n − i − j, i, j) / n), projected onto the sphere.
  ShellSurface oct;
  std::vector<std::vector<int>> id(n + 1);
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i + j <= n; ++i) {
      id[j].push_back(oct.mesh.num_nodes());
      oct.mesh.nodes.push_back(radius * Vec3(double(n - i - j), double(i), double(j)).normalized());
    }
  for (int j = 0; j < n; ++j)
    for (int i = 0; i + j < n; ++i) {
      oct.triangles.push_back({id[j][i], id[j][i + 1], id[j + 1][i]});
      if (i + j + 1 < n) oct.triangles.push_back({id[j][i + 1], id[j + 1][i + 1], id[j + 1][i]});
    }
  for (int k = 0; k < n; ++k) {
    oct.edges["z0"].push_back({id[0][k], id[0][k + 1]});         // j = 0
    oct.edges["y0"].push_back({id[k][0], id[k + 1][0]});         // i = 0
    oct.edges["x0"].push_back({id[k][n - k], id[k + 1][n - k - 1]});  // i + j = n
  }
  if (octant) {
    orient_outward(oct, [](const Vec3& c) { return c; });
    return oct;
  }
  ShellSurface s;
  for (int k = 0; k < 8; ++k) {
    ShellSurface part = oct;
    for (Vec3& x : part.mesh.nodes) x = Vec3((k & 1) ? -x.x() : x.x(), (k & 2) ? -x.y() : x.y(), (k & 4) ? -x.z() : x.z());
    part.edges.clear();
    append(s, part);
  }
  merge_nodes(s);
  orient_outward(s, [](const Vec3& c) { return c; });
  return s;
}

ShellSurface make_shell_cylinder(double radius, double length, double sweep_deg, int n_around, int n_axial) {
  require(radius > 0.0, "shell.radius", radius, "must be > 0");
  require(length > 0.0, "shell.length", length, "must be > 0");
  require(sweep_deg > 0.0 && sweep_deg <= 360.0, "shell.sweep_deg", sweep_deg, "must be in (0, 360]");
  const double sweep = sweep_deg * M_PI / 180.0;
  const bool closed = sweep_deg == 360.0;
  ShellSurface s = mapped_grid(
      n_around, n_axial,
      [&](double u, double v) { return Vec3(radius * std::cos(sweep * u), radius * std::sin(sweep * u), length * v); },
      {closed ? "" : "theta0", closed ? "" : "theta1", "z0", "z1"});
  if (closed) merge_nodes(s);
  orient_outward(s, [](const Vec3& c) { return Vec3(c.x(), c.y(), 0.0); });
  return s;
}

ShellSurface make_shell_strip(double lx, double ly, int nx, int ny) {
  require(lx > 0.0, "shell.length", lx, "must be > 0");
  require(ly > 0.0, "shell.width", ly, "must be > 0");
  ShellSurface s = mapped_grid(nx, ny, [&](double u, double v) { return Vec3(lx * u, ly * v, 0.0); },
                               {"xmin", "xmax", "ymin", "ymax"});
  orient_outward(s, [](const Vec3&) { return Vec3::UnitZ(); });
  return s;
}

ShellSurface make_shell_hemisphere(double radius, double hole_deg, int n) {
  require(radius > 0.0, "shell.radius", radius, "must be > 0");
  require(hole_deg > 0.0 && hole_deg < 90.0, "shell.hole_deg", hole_deg, "must be in (0, 90)");
  const double polar0 = hole_deg * M_PI / 180.0;
  // u: azimuth 0 → 90°, v: polar angle from the equator (90°) up to the hole's edge.
  ShellSurface s = mapped_grid(
      n, n,
      [&](double u, double v) {
        const double phi = 0.5 * M_PI * u, theta = 0.5 * M_PI - v * (0.5 * M_PI - polar0);
        return Vec3(radius * std::sin(theta) * std::cos(phi), radius * std::sin(theta) * std::sin(phi), radius * std::cos(theta));
      },
      {"y0", "x0", "z0", "hole"});
  orient_outward(s, [](const Vec3& c) { return c; });
  return s;
}

ShellSurface make_shell_vault(double radius, double length, double phi_deg, int nx, int ny) {
  require(radius > 0.0, "shell.radius", radius, "must be > 0");
  require(length > 0.0, "shell.length", length, "must be > 0");
  require(phi_deg > 0.0 && phi_deg < 90.0, "shell.angle_deg", phi_deg, "must be in (0, 90)");
  const double phi = phi_deg * M_PI / 180.0;
  ShellSurface s = mapped_grid(
      nx, ny,
      [&](double u, double v) {
        const double a = v * phi;
        return Vec3(0.5 * length * u, radius * std::sin(a), radius * std::cos(a));
      },
      {"x0", "xL", "y0", "free"});
  orient_outward(s, [](const Vec3& c) { return Vec3(0.0, c.y(), c.z()); });
  return s;
}

}  // namespace softhom::macro
