#include "softhom/macro/helix_tube.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "softhom/materials/errors.hpp"

namespace softhom::macro {
namespace {

double radians(double deg) { return deg * std::numbers::pi / 180.0; }

/// The fiber-size key the scene gave (the one an error about the fiber size names).
std::string size_key(const HelixTubeSpec& s) {
  return s.fiber_radius > 0.0 ? "helix_tube.fiber_radius" : "helix_tube.volume_fraction";
}
std::string size_value(const HelixTubeSpec& s) {
  return format_number(s.fiber_radius > 0.0 ? s.fiber_radius : s.volume_fraction);
}

Vec3 mean_displacement(const std::vector<int>& nodes, const std::vector<Vec3>& X, const std::vector<Vec3>& x) {
  Vec3 u = Vec3::Zero();
  for (int n : nodes) u += x[n] - X[n];
  return u / double(nodes.size());
}

double mean_z(const std::vector<int>& nodes, const std::vector<Vec3>& y) {
  double z = 0.0;
  for (int n : nodes) z += y[n][2];
  return z / double(nodes.size());
}

double mean_radius(const std::vector<int>& nodes, const std::vector<Vec3>& y) {
  double r = 0.0;
  for (int n : nodes) r += std::hypot(y[n][0], y[n][1]);
  return r / double(nodes.size());
}

/// Rotation about z taking the nodes' reference xy-positions to their current ones (least squares).
double rotation_deg(const std::vector<int>& nodes, const std::vector<Vec3>& X, const std::vector<Vec3>& x) {
  double cross = 0.0, dot = 0.0;
  for (int n : nodes) {
    cross += X[n][0] * x[n][1] - X[n][1] * x[n][0];
    dot += X[n][0] * x[n][0] + X[n][1] * x[n][1];
  }
  return std::atan2(cross, dot) * 180.0 / std::numbers::pi;
}

}  // namespace

double helix_fiber_spacing(const HelixTubeSpec& s) {
  const double rm = s.inner_radius + 0.5 * s.wall_thickness;
  return 2.0 * std::numbers::pi * rm * std::cos(radians(s.helix_angle_deg)) / double(s.fibers);
}

double helix_fiber_radius(const HelixTubeSpec& s) {
  if (s.fiber_radius > 0.0) return s.fiber_radius;
  return std::sqrt(s.volume_fraction * helix_fiber_spacing(s) * s.wall_thickness / std::numbers::pi);
}

double helix_volume_fraction(const HelixTubeSpec& s) {
  const double r = helix_fiber_radius(s);
  return std::numbers::pi * r * r / (helix_fiber_spacing(s) * s.wall_thickness);
}

void check_helix_tube(const HelixTubeSpec& s) {
  if (s.fibers == 0) {
    if (s.volume_fraction > 0.0 || s.fiber_radius > 0.0)
      throw InputError(size_key(s), size_value(s), "a fiber size without fibers (helix_tube.fibers = 0)");
    if (s.fiber_mesh_size > 0.0)
      throw InputError("helix_tube.fiber_mesh_size", format_number(s.fiber_mesh_size),
                       "a fiber mesh size without fibers (helix_tube.fibers = 0)");
    return;
  }
  if ((s.volume_fraction > 0.0) == (s.fiber_radius > 0.0))
    throw InputError("helix_tube.volume_fraction", s.volume_fraction > 0.0 ? format_number(s.volume_fraction) : "",
                     "give exactly one of volume_fraction and fiber_radius");
  const double r = helix_fiber_radius(s), spacing = helix_fiber_spacing(s);
  if (2.0 * r > 0.8 * s.wall_thickness)
    throw InputError(size_key(s), size_value(s),
                     "fiber radius " + format_number(r) + " mm is too large for the wall: the fiber must leave matrix on both "
                     "faces, 2 r <= 0.8 helix_tube.wall_thickness = " + format_number(0.8 * s.wall_thickness) + " mm");
  if (2.0 * r > 0.8 * spacing)
    throw InputError(size_key(s), size_value(s),
                     "fiber radius " + format_number(r) + " mm: neighbouring fibers (spacing " + format_number(spacing) +
                         " mm perpendicular to them) would nearly touch, 2 r <= 0.8 spacing; use more fibers or a thicker wall");
}

std::vector<std::pair<std::string, double>> helix_tube_geo_parameters(const HelixTubeSpec& s) {
  std::vector<std::pair<std::string, double>> p = {
      {"inner_radius", s.inner_radius},       {"wall_thickness", s.wall_thickness},
      {"length", s.length},                   {"cap_thickness", s.cap_thickness},
      {"helix_angle_deg", s.helix_angle_deg}, {"fibers", double(s.fibers)},
      {"fiber_radius", s.fibers > 0 ? helix_fiber_radius(s) : 0.0}};
  // Passed only when set, so the meshes (and mesh-cache names) of scenes without it stay as they were.
  if (s.fiber_mesh_size > 0.0) p.emplace_back("fiber_mesh_size", s.fiber_mesh_size);
  return p;
}

TubeGauge::TubeGauge(const fe::Mesh& mesh, const std::string& field) {
  for (const char* name : {"inner", "outer", "zmax"})
    if (!mesh.has_surface(name))
      throw InputError(field, "\"tube\"", std::string("the tube gauge needs the physical surface \"") + name + "\"");
  const auto& X = mesh.nodes;
  end_ = fe::surface_nodes(mesh, "zmax");
  const std::vector<int> inner = fe::surface_nodes(mesh, "inner"), outer = fe::surface_nodes(mesh, "outer");
  double z0 = 1e300, z1 = -1e300;
  for (int n : inner) z0 = std::min(z0, X[n][2]), z1 = std::max(z1, X[n][2]);
  const double L = z1 - z0, za = z0 + 0.25 * L, zb = z0 + 0.75 * L, band = 0.1 * L;
  for (int n : outer) {
    const double z = X[n][2];
    if (std::abs(z - za) <= band) band_a_.push_back(n);
    if (std::abs(z - zb) <= band) band_b_.push_back(n);
    if (z >= za && z <= zb) outer_.push_back(n);
  }
  for (int n : inner)
    if (X[n][2] >= za && X[n][2] <= zb) inner_.push_back(n);
  if (band_a_.empty() || band_b_.empty() || outer_.empty() || inner_.empty() || end_.empty())
    throw InputError(field, "\"tube\"", "the mesh has no nodes in the tube's gauge section (middle half of the wall's length)");
}

std::vector<std::string> TubeGauge::columns() {
  return {"axial_stretch", "radial_stretch_outer", "radial_stretch_inner", "twist_end_deg", "twist_gauge_deg",
          "end_displacement_mm"};
}

std::vector<double> TubeGauge::values(const std::vector<Vec3>& X, const std::vector<Vec3>& x) const {
  const double axial = (mean_z(band_b_, x) - mean_z(band_a_, x)) / (mean_z(band_b_, X) - mean_z(band_a_, X));
  return {axial,
          mean_radius(outer_, x) / mean_radius(outer_, X),
          mean_radius(inner_, x) / mean_radius(inner_, X),
          rotation_deg(end_, X, x),
          rotation_deg(band_b_, X, x) - rotation_deg(band_a_, X, x),
          mean_displacement(end_, X, x)[2]};
}

}  // namespace softhom::macro
