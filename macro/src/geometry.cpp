#include "softhom/macro/geometry.hpp"

#include <cmath>
#include <functional>

#include "softhom/materials/errors.hpp"

namespace softhom::macro {
namespace {

using fe::Mesh;

/// Appends a structured block of n0 × n1 × n2 hexes whose nodes are map(i/n0, j/n1, k/n2).
void add_block(Mesh& mesh, std::array<int, 3> n, const std::function<Vec3(double, double, double)>& map, int region = 0) {
  // Node ids and dof numbers are ints (3 per node) and every hex costs ~1 KB of solver memory: refuse
  // meshes beyond 5e7 nodes with a message instead of overflowing an index or failing an allocation.
  const double nodes = double(mesh.num_nodes()) + double(n[0] + 1) * double(n[1] + 1) * double(n[2] + 1);
  if (nodes > 5e7)
    throw InputError("geometry", std::to_string(n[0]) + " x " + std::to_string(n[1]) + " x " + std::to_string(n[2]) + " cells",
                     "mesh too large (" + std::to_string(nodes) + " nodes; at most 5e7)");
  const int base = mesh.num_nodes();
  auto id = [&](int i, int j, int k) { return base + i + (n[0] + 1) * (j + (n[1] + 1) * k); };
  for (int k = 0; k <= n[2]; ++k)
    for (int j = 0; j <= n[1]; ++j)
      for (int i = 0; i <= n[0]; ++i) mesh.nodes.push_back(map(double(i) / n[0], double(j) / n[1], double(k) / n[2]));
  for (int k = 0; k < n[2]; ++k)
    for (int j = 0; j < n[1]; ++j)
      for (int i = 0; i < n[0]; ++i) {
        mesh.hexes.push_back({id(i, j, k), id(i + 1, j, k), id(i + 1, j + 1, k), id(i, j + 1, k), id(i, j, k + 1),
                              id(i + 1, j, k + 1), id(i + 1, j + 1, k + 1), id(i, j + 1, k + 1)});
        mesh.region.push_back(region);
      }
}

void check_positive(double v, const char* field) {
  if (!(v > 0.0)) throw InputError(field, format_number(v), "must be positive");
}
void check_cells(int v, const char* field) {
  if (v < 1) throw InputError(field, std::to_string(v), "must be at least 1");
}

bool near(double a, double b, double tol) { return std::abs(a - b) <= tol; }

}  // namespace

fe::Mesh make_plate(const PlateSpec& s) {
  for (int d = 0; d < 3; ++d) {
    check_positive(s.size[d], "geometry.size");
    check_cells(s.cells[d], "geometry.cells");
  }
  Mesh mesh;
  add_block(mesh, s.cells, [&](double a, double b, double c) { return Vec3(a * s.size[0], b * s.size[1], c * s.size[2]); });
  const double tol = 1e-9 * s.size.maxCoeff();
  fe::name_boundary_faces(mesh, [&](const Vec3& c, const Vec3& n) -> std::string {
    static const char* names[3][2] = {{"xmin", "xmax"}, {"ymin", "ymax"}, {"zmin", "zmax"}};
    for (int d = 0; d < 3; ++d) {
      if (near(c[d], 0.0, tol) && n[d] < -0.5) return names[d][0];
      if (near(c[d], s.size[d], tol) && n[d] > 0.5) return names[d][1];
    }
    return "";
  });
  return mesh;
}

fe::Mesh make_cook_membrane(int n) {
  check_cells(n, "geometry.cells");
  Mesh mesh;
  add_block(mesh, {n, n, 1}, [](double xi, double eta, double z) {
    const double yb = 44.0 * xi, yt = 44.0 + 16.0 * xi;  // bottom and top edge at x = 48 xi
    return Vec3(48.0 * xi, yb + eta * (yt - yb), z);
  });
  fe::name_boundary_faces(mesh, [](const Vec3& c, const Vec3& nrm) -> std::string {
    if (c[0] < 1e-9 && nrm[0] < -0.5) return "clamped";
    if (c[0] > 48.0 - 1e-9 && nrm[0] > 0.5) return "tip";
    return "";
  });
  return mesh;
}

fe::Mesh make_tube(const TubeSpec& s) {
  check_positive(s.inner_radius, "geometry.inner_radius");
  if (!(s.outer_radius > s.inner_radius))
    throw InputError("geometry.outer_radius", format_number(s.outer_radius), "must exceed inner_radius");
  // Below the faces' position tolerance the cavity's faces collapse onto the axis: no "inner" surface.
  if (s.inner_radius < 1e-6 * s.outer_radius)
    throw InputError("geometry.inner_radius", format_number(s.inner_radius),
                     "must be at least 1e-06 of outer_radius (" + format_number(s.outer_radius) + "): a cavity that thin has no surface");
  check_positive(s.length, "geometry.length");
  check_cells(s.radial_cells, "geometry.radial_cells");
  check_cells(s.circumferential_cells, "geometry.circumferential_cells");
  check_cells(s.axial_cells, "geometry.axial_cells");
  if (!(s.sweep_deg > 0.0 && s.sweep_deg <= 360.0))
    throw InputError("geometry.sweep_deg", format_number(s.sweep_deg), "must lie in (0, 360]");
  if (s.cap_thickness < 0.0) throw InputError("geometry.cap_thickness", format_number(s.cap_thickness), "must be >= 0");
  const double sweep = s.sweep_deg * M_PI / 180.0;
  const double Ri = s.inner_radius, Ro = s.outer_radius, L = s.length;
  Mesh mesh;
  auto cyl = [](double r, double th, double z) { return Vec3(r * std::cos(th), r * std::sin(th), z); };
  add_block(mesh, {s.radial_cells, s.circumferential_cells, s.axial_cells},
            [&](double a, double b, double c) { return cyl(Ri + a * (Ro - Ri), b * sweep, c * L); });
  if (s.cap_thickness > 0.0) {
    check_cells(s.cap_axial_cells, "geometry.cap_axial_cells");
    check_cells(s.cap_core_cells, "geometry.cap_core_cells");
    const double zc = L + s.cap_thickness;
    add_block(mesh, {s.radial_cells, s.circumferential_cells, s.cap_axial_cells},
              [&](double a, double b, double c) { return cyl(Ri + a * (Ro - Ri), b * sweep, L + c * (zc - L)); });
    // Core disk: the innermost ring collapses onto the axis (wedges as degenerate hexes).
    add_block(mesh, {s.cap_core_cells, s.circumferential_cells, s.cap_axial_cells},
              [&](double a, double b, double c) { return cyl(a * Ri, b * sweep, L + c * (zc - L)); });
  }
  fe::merge_coincident_nodes(mesh);
  fe::orient_hexes(mesh);
  if (s.split_y) {
    const auto cs = element_centroids(mesh);
    for (int e = 0; e < mesh.num_elements(); ++e) mesh.region[e] = cs[e][1] < 0.0 ? 1 : 0;
  }
  const double tol = 1e-6 * Ro;
  const double zmax = L + s.cap_thickness;
  const bool full = s.sweep_deg >= 360.0 - 1e-9;
  fe::name_boundary_faces(mesh, [&](const Vec3& c, const Vec3& n) -> std::string {
    const double r = std::hypot(c[0], c[1]);
    const Vec3 er = r > 0 ? Vec3(c[0] / r, c[1] / r, 0.0) : Vec3::Zero();
    if (near(c[2], 0.0, tol) && n[2] < -0.9) return "zmin";
    if (near(c[2], zmax, tol) && n[2] > 0.9) return "zmax";
    if (s.cap_thickness > 0.0 && near(c[2], L, tol) && n[2] < -0.9 && r < Ri) return "cap_inner";
    // Face centroids of a faceted cylinder lie slightly inside the radius: compare with a cell tolerance.
    if (n.dot(er) < -0.9 && r < Ri + 0.5 * (Ro - Ri) / s.radial_cells) return "inner";
    if (n.dot(er) > 0.9 && r > Ro - 0.5 * (Ro - Ri) / s.radial_cells) return "outer";
    if (!full && std::abs(c[1]) < tol && n[1] < -0.9) return "ysym";
    if (!full && std::abs(c[0]) < tol && n[0] < -0.9) return "xsym";
    return "";
  });
  return mesh;
}

fe::Mesh make_sphere_octant(const SphereSpec& s) {
  check_positive(s.inner_radius, "geometry.inner_radius");
  check_positive(s.thickness, "geometry.thickness");
  check_cells(s.radial_cells, "geometry.radial_cells");
  check_cells(s.patch_cells, "geometry.patch_cells");
  const double Ri = s.inner_radius, Ro = Ri + s.thickness;
  Mesh mesh;
  // Patch p: directions normalise(cube face point) with equal-angle spacing t = tan(π/4 · ξ).
  for (int p = 0; p < 3; ++p)
    add_block(mesh, {s.patch_cells, s.patch_cells, s.radial_cells}, [&](double a, double b, double c) {
      const double u = std::tan(M_PI / 4 * a), v = std::tan(M_PI / 4 * b);
      Vec3 d;
      d[p] = 1.0;
      d[(p + 1) % 3] = u;
      d[(p + 2) % 3] = v;
      return Vec3((Ri + c * (Ro - Ri)) * d.normalized());
    });
  fe::merge_coincident_nodes(mesh);
  fe::orient_hexes(mesh);
  const double tol = 1e-6 * Ro;
  fe::name_boundary_faces(mesh, [&](const Vec3& c, const Vec3& n) -> std::string {
    const Vec3 er = c.normalized();
    if (std::abs(c[0]) < tol && n[0] < -0.9) return "x0";
    if (std::abs(c[1]) < tol && n[1] < -0.9) return "y0";
    if (std::abs(c[2]) < tol && n[2] < -0.9) return "z0";
    if (n.dot(er) < -0.5) return "inner";
    if (n.dot(er) > 0.5) return "outer";
    return "";
  });
  return mesh;
}

std::vector<Vec3> element_centroids(const fe::Mesh& mesh) {
  std::vector<Vec3> out(mesh.num_elements(), Vec3::Zero());
  for (int e = 0; e < mesh.num_elements(); ++e) {
    // Vertex average (a tet's first 4 nodes are its vertices).
    const int nv = mesh.is_tet(e) ? 4 : 8;
    for (int a = 0; a < nv; ++a) out[e] += mesh.nodes[mesh.element_nodes(e)[a]];
    out[e] /= double(nv);
  }
  return out;
}

Mat3 cylindrical_frame(const Vec3& x) {
  const double r = std::hypot(x[0], x[1]);
  const Vec3 er = r > 0 ? Vec3(x[0] / r, x[1] / r, 0.0) : Vec3::UnitX();
  Mat3 Q;
  Q.col(0) = Vec3::UnitZ().cross(er);
  Q.col(1) = Vec3::UnitZ();
  Q.col(2) = er;
  return Q;
}

Mat3 spherical_frame(const Vec3& x) {
  const Vec3 er = x.normalized();
  Vec3 t1 = Vec3::UnitZ().cross(er);
  if (t1.norm() < 1e-8) t1 = Vec3::UnitX();
  t1.normalize();
  Mat3 Q;
  Q.col(0) = t1;
  Q.col(1) = er.cross(t1);
  Q.col(2) = er;
  return Q;
}

}  // namespace softhom::macro
