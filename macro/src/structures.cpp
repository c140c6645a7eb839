#include "softhom/materials/system_memory.hpp"
#include "softhom/macro/structures.hpp"

#include <algorithm>
#include <cmath>
#include <map>

#include "softhom/materials/errors.hpp"

namespace softhom::macro {
namespace {

void fix(fe::FeModel& m, const std::vector<int>& nodes, int component, double scale = 0.0,
         const PiecewiseLinear& value = PiecewiseLinear::constant(0.0)) {
  fe::DirichletGroup g;
  for (int n : nodes) g.dofs.push_back(3 * n + component);
  g.scale.assign(g.dofs.size(), scale == 0.0 ? 1.0 : scale);
  g.value = scale == 0.0 ? PiecewiseLinear::constant(0.0) : value;
  m.dirichlet.push_back(std::move(g));
}

template <class Names>
std::vector<fe::Quad> concat(const fe::Mesh& mesh, const Names& names) {
  std::vector<fe::Quad> out;
  for (const auto& n : names) {
    const auto it = mesh.surfaces.find(n);
    if (it != mesh.surfaces.end()) out.insert(out.end(), it->second.begin(), it->second.end());
  }
  return out;
}
std::vector<fe::Quad> concat(const fe::Mesh& mesh, std::initializer_list<const char*> names) {
  return concat<std::initializer_list<const char*>>(mesh, names);
}
template <class Names>
std::vector<fe::Tri6> concat_tris(const fe::Mesh& mesh, const Names& names) {
  std::vector<fe::Tri6> out;
  for (const auto& n : names) {
    const auto& f = mesh.tri_surface(n);
    out.insert(out.end(), f.begin(), f.end());
  }
  return out;
}
std::vector<fe::Tri6> concat_tris(const fe::Mesh& mesh, std::initializer_list<const char*> names) {
  return concat_tris<std::initializer_list<const char*>>(mesh, names);
}

/// The generated hex mesh, or its split into tet10 with mid-edge nodes on the structure's curved
/// surfaces (cylinders about z for tubes, spheres about the origin for the balloon).
fe::Mesh maybe_tets(fe::Mesh mesh, const StructureSpec& spec) {
  if (!spec.tet10) return mesh;
  switch (spec.kind) {
    case StructureKind::tube:
    case StructureKind::actuator:
      return fe::hex_to_tet10(mesh, [](const Vec3& a, const Vec3& b) {
        const double ra = std::hypot(a[0], a[1]), rb = std::hypot(b[0], b[1]);
        const Vec3 m = 0.5 * (a + b);
        const double rm = std::hypot(m[0], m[1]);
        // Points on the axis (cap core) or edges crossing it keep the straight midpoint.
        if (ra < 1e-9 || rb < 1e-9 || rm < 1e-9 || std::abs(ra - rb) > 1e-9 * (ra + rb)) return m;
        return Vec3(m[0] * ra / rm, m[1] * ra / rm, m[2]);
      });
    case StructureKind::sphere:
      return fe::hex_to_tet10(mesh, [](const Vec3& a, const Vec3& b) {
        const double ra = a.norm(), rb = b.norm();
        const Vec3 m = 0.5 * (a + b);
        if (std::abs(ra - rb) > 1e-9 * (ra + rb)) return m;
        return Vec3(m * (ra / m.norm()));
      });
    default:
      return fe::hex_to_tet10(mesh);
  }
}

/// Per-element materials in the fiber frame; identical frames share one rotated copy.
void assign_materials(Structure& s) {
  const auto& spec = s.spec;
  fe::Mesh& mesh = s.model.mesh;
  const MaterialPtr m1 = spec.material_region1 ? spec.material_region1 : spec.material;
  const auto centroids = element_centroids(mesh);
  std::map<int, std::map<std::pair<long, long>, MaterialPtr>> cache;
  // Imported meshes: the material of a region is looked up by its physical name.
  std::vector<MaterialPtr> by_region;
  if (spec.kind == StructureKind::imported)
    for (const std::string& name : mesh.region_names) {
      const auto it = spec.imported.region_materials.find(name);
      by_region.push_back(it != spec.imported.region_materials.end() ? it->second : spec.material);
    }
  s.model.element_material.resize(mesh.num_elements());
  for (int e = 0; e < mesh.num_elements(); ++e) {
    const int region = mesh.region.empty() ? 0 : mesh.region[e];
    const MaterialPtr& base = spec.kind == StructureKind::imported
                                  ? (region < int(by_region.size()) ? by_region[region] : spec.material)
                                  : (region == 1 ? m1 : spec.material);
    if (spec.fiber_frame == FiberFrame::global || base->fiber_directions().empty()) {
      s.model.element_material[e] = base;
      continue;
    }
    const Vec3& c = centroids[e];
    const Mat3 Q = spec.fiber_frame == FiberFrame::cylindrical ? cylindrical_frame(c) : spherical_frame(c);
    // Key on the rotation (rounded) so that elements of one angular column share a material.
    const std::pair<long, long> key{std::lround(1e9 * Q(0, 0)) * 3 + std::lround(1e9 * Q(1, 0)),
                                    std::lround(1e9 * Q(2, 2)) + 7 * std::lround(1e9 * Q(0, 2))};
    auto& slot = cache[spec.kind == StructureKind::imported ? region : int(region == 1)][key];
    if (!slot) slot = MaterialPtr(base->rotated(Q));
    s.model.element_material[e] = slot;
  }
}

double mean_radius(const std::vector<Vec3>& x, const std::vector<int>& nodes, bool spherical) {
  double sum = 0.0;
  for (int n : nodes) sum += spherical ? x[n].norm() : std::hypot(x[n][0], x[n][1]);
  return nodes.empty() ? 0.0 : sum / nodes.size();
}

/// The cavity's load on `faces` and `tris`: a follower pressure, or the cavity-volume control with
/// `mask` (see fe::CavityControl); `refusal` says what drives the structure otherwise.
void load_cavity(fe::FeModel& m, const StructureSpec& spec, std::vector<fe::Quad> faces, std::vector<fe::Tri6> tris,
                 const Vec3& mask, const char* refusal) {
  if (spec.control == LoadControl::pressure)
    m.pressures.emplace_back(std::move(faces), spec.load, std::move(tris));
  else if (spec.control == LoadControl::volume)
    m.cavity = fe::CavityControl(std::move(faces), mask, spec.load, std::move(tris));
  else
    throw InputError("load.control", "stretch", refusal);
}

/// Uniaxial tension along x: xmin held in x, xmax moved by (λ(t) − 1) L_x, the rigid modes pinned.
void build_plate(Structure& s) {
  const StructureSpec& spec = s.spec;
  fe::FeModel& m = s.model;
  m.mesh = maybe_tets(make_plate(spec.plate), spec);
  if (spec.control != LoadControl::stretch) throw InputError("load.control", "", "a plate is driven by load.stretch");
  const double L = spec.plate.size[0];
  fix(m, fe::surface_nodes(m.mesh, "xmin"), 0);
  // λ(t) − 1 as u_x / L on the loaded face.
  PiecewiseLinear strain = spec.load;
  for (double& v : strain.v) v -= 1.0;
  s.end_nodes = fe::surface_nodes(m.mesh, "xmax");
  fix(m, s.end_nodes, 0, L, strain);
  for (int n : s.end_nodes) s.load_dofs.push_back(3 * n);
  const auto origin = fe::select_nodes(m.mesh, [](const Vec3& x) { return x.norm() < 1e-9; });
  const auto corner_y = fe::select_nodes(m.mesh, [&](const Vec3& x) {
    return std::abs(x[0]) < 1e-9 && std::abs(x[2]) < 1e-9 && std::abs(x[1] - spec.plate.size[1]) < 1e-9;
  });
  fix(m, origin, 1);
  fix(m, origin, 2);
  fix(m, corner_y, 2);
}

/// The tube's ends: plane strain (u_z = 0 at both, a full ring pinned in plane), or clamped at z = 0.
void hold_tube_ends(fe::FeModel& m, const TubeSpec& t, bool plane_strain, bool quarter) {
  const auto zmin = fe::surface_nodes(m.mesh, "zmin");
  if (plane_strain) {
    if (t.cap_thickness > 0.0) throw InputError("geometry.plane_strain", "true", "incompatible with an end cap");
    fix(m, zmin, 2);
    fix(m, fe::surface_nodes(m.mesh, "zmax"), 2);
    if (!quarter) {
      // Full ring in plane strain: pin the rigid in-plane translation and rotation.
      const auto a = fe::select_nodes(m.mesh, [&](const Vec3& x) { return std::abs(x[1]) < 1e-9 && x[0] > 0 && std::abs(x[2]) < 1e-12; });
      const auto b = fe::select_nodes(m.mesh, [&](const Vec3& x) { return std::abs(x[0]) < 1e-9 && x[1] > 0 && std::abs(x[2]) < 1e-12; });
      fix(m, a, 1);
      fix(m, b, 0);
    }
    return;
  }
  // Clamped at z = 0 (the dissertation's "right side totally fixed"); the other end is free
  // (capped) so axial extension, twist and bending can develop.
  for (int c = 0; c < 3; ++c) fix(m, zmin, c);
}

/// An inflated tube, or the capped two-material actuator.
void build_tube(Structure& s) {
  const StructureSpec& spec = s.spec;
  fe::FeModel& m = s.model;
  TubeSpec t = spec.tube;
  t.split_y = spec.kind == StructureKind::actuator;
  if (spec.kind == StructureKind::actuator && !(t.cap_thickness > 0.0))
    throw InputError("geometry.cap_thickness", format_number(t.cap_thickness), "an actuator needs an end cap");
  m.mesh = maybe_tets(make_tube(t), spec);
  const bool quarter = t.sweep_deg < 360.0 - 1e-9;
  if (quarter) {
    if (std::abs(t.sweep_deg - 90.0) > 1e-9)
      throw InputError("geometry.sweep_deg", format_number(t.sweep_deg), "only 90 (quarter) or 360 are supported");
    fix(m, fe::surface_nodes(m.mesh, "ysym"), 1);
    fix(m, fe::surface_nodes(m.mesh, "xsym"), 0);
  }
  hold_tube_ends(m, t, spec.plane_strain, quarter);
  s.inner_nodes = fe::surface_nodes(m.mesh, "inner");
  s.end_nodes = fe::surface_nodes(m.mesh, "zmax");
  // Under volume control the cavity is closed by z = 0 (x·n = 0 there) and, when not capped, by the
  // plane z = L: the in-plane mask makes that plane contribute nothing.
  const Vec3 mask = t.cap_thickness > 0.0 ? Vec3(1, 1, 1) : Vec3(1, 1, 0);
  load_cavity(m, spec, concat(m.mesh, {"inner", "cap_inner"}), concat_tris(m.mesh, {"inner", "cap_inner"}), mask,
              "a tube is driven by pressure or volume");
}

/// An eighth of a sphere on its three symmetry planes, inflated.
void build_sphere(Structure& s) {
  fe::FeModel& m = s.model;
  m.mesh = maybe_tets(make_sphere_octant(s.spec.sphere), s.spec);
  fix(m, fe::surface_nodes(m.mesh, "x0"), 0);
  fix(m, fe::surface_nodes(m.mesh, "y0"), 1);
  fix(m, fe::surface_nodes(m.mesh, "z0"), 2);
  s.inner_nodes = fe::surface_nodes(m.mesh, "inner");
  load_cavity(m, s.spec, m.mesh.surface("inner"), m.mesh.tri_surface("inner"), Vec3(1, 1, 1),
              "a sphere is driven by pressure or volume");
}

/// An imported mesh with its fixed surfaces, loaded surfaces and probe surface (named in the mesh).
void build_imported(Structure& s, const ImportedSpec& im) {
  const StructureSpec& spec = s.spec;
  fe::FeModel& m = s.model;
  m.mesh = im.mesh;
  if (m.mesh.num_elements() == 0) throw InputError("geometry.file", "", "the mesh has no volume elements");
  for (const auto& f : im.fixed) {
    if (!m.mesh.has_surface(f.surface))
      throw InputError("boundary.surface", f.surface, "no physical surface of that name in the mesh");
    const auto nodes = fe::surface_nodes(m.mesh, f.surface);
    for (int c = 0; c < 3; ++c)
      if (f.components[c]) fix(m, nodes, c);
  }
  for (const auto& n : im.load_surfaces)
    if (!m.mesh.has_surface(n)) throw InputError("load.surface", n, "no physical surface of that name in the mesh");
  if (!im.probe_surface.empty()) {
    if (!m.mesh.has_surface(im.probe_surface))
      throw InputError("probe.surface", im.probe_surface, "no physical surface of that name in the mesh");
    s.end_nodes = fe::surface_nodes(m.mesh, im.probe_surface);
  }
  for (const auto& n : im.load_surfaces) {
    const auto nodes = fe::surface_nodes(m.mesh, n);
    s.inner_nodes.insert(s.inner_nodes.end(), nodes.begin(), nodes.end());
  }
  std::sort(s.inner_nodes.begin(), s.inner_nodes.end());
  s.inner_nodes.erase(std::unique(s.inner_nodes.begin(), s.inner_nodes.end()), s.inner_nodes.end());
  if (spec.control == LoadControl::pressure && im.load_surfaces.empty()) return;  // unloaded
  if (spec.control == LoadControl::volume && im.load_surfaces.empty())
    throw InputError("load.surface", "", "volume control needs the cavity surface");
  load_cavity(m, spec, concat(m.mesh, im.load_surfaces), concat_tris(m.mesh, im.load_surfaces), im.cavity_mask,
              "an imported mesh is driven by pressure or volume");
}

}  // namespace

Structure build_structure(const StructureSpec& spec) {
  if (!spec.material && spec.kind != StructureKind::shell) throw InputError("material", "", "missing material");
  // Refused before any of it is allocated when the machine cannot hold the mesh and its factorization.
  refuse_if_too_large(spec, double(softhom::available_memory_bytes()), size_field(spec));
  Structure s;
  s.spec = spec;
  // model.mesh is the structure's mesh; the spec's copy of an imported one is read from `spec` below
  // and not kept (on a device mesh every copy is ~25 B per dof on every rank).
  s.spec.imported.mesh = fe::Mesh{};
  s.model.formulation = spec.formulation;
  switch (spec.kind) {
    case StructureKind::plate: build_plate(s); break;
    case StructureKind::tube:
    case StructureKind::actuator: build_tube(s); break;
    case StructureKind::sphere: build_sphere(s); break;
    case StructureKind::imported: build_imported(s, spec.imported); break;
    case StructureKind::shell: build_shell(s); break;
  }
  assign_materials(s);
  add_fibers(s);
  add_contacts(spec.contact, s.model);  // after the materials: the penalty scales with them
  return s;
}

std::vector<std::string> probe_names(const Structure& s) {
  switch (s.spec.kind) {
    case StructureKind::plate: return {"time", "stretch", "force", "nominal_stress"};
    case StructureKind::sphere: return {"time", "pressure", "stretch", "volume", "inner_radius"};
    case StructureKind::tube:
      return {"time", "pressure", "volume", "inner_radius", "stretch", "axial_stretch", "twist_deg"};
    case StructureKind::actuator: return {"time", "pressure", "volume", "tip_angle_deg", "tip_deflection"};
    case StructureKind::imported:
      return {"time", "pressure", "volume", "mean_radius", "probe_ux", "probe_uy", "probe_uz"};
    case StructureKind::shell: return {"time", "pressure", "volume", "volume_ratio", "mean_radius"};
  }
  return {};
}

std::vector<double> probe_values(const Structure& s, const fe::Simulation& sim) {
  const double t = sim.time();
  const auto x = sim.current_positions();
  const auto& X = s.model.mesh.nodes;
  const auto& spec = s.spec;
  double p = 0.0, volume = 0.0;
  if (s.model.cavity) {
    p = sim.cavity_pressure();
    volume = fe::cavity_volume(x, s.model.cavity->faces, s.model.cavity->mask, s.model.cavity->tris);
  } else if (!s.model.pressures.empty()) {
    p = s.model.pressures[0].pressure(t);
    Vec3 mask = spec.tube.cap_thickness > 0.0 || spec.kind == StructureKind::sphere ? Vec3(1, 1, 1) : Vec3(1, 1, 0);
    if (spec.kind == StructureKind::imported) mask = spec.imported.cavity_mask;
    if (spec.kind == StructureKind::shell) mask = Vec3(1, 1, 1);
    volume = fe::cavity_volume(x, s.model.pressures[0].faces, mask, s.model.pressures[0].tris);
  }
  switch (spec.kind) {
    case StructureKind::plate: {
      const double lambda = spec.load(t);
      const double force = sim.reaction(s.load_dofs);
      return {t, lambda, force, force / (spec.plate.size[1] * spec.plate.size[2])};
    }
    case StructureKind::sphere: {
      const double r = mean_radius(x, s.inner_nodes, true);
      return {t, p, r / spec.sphere.inner_radius, volume, r};
    }
    case StructureKind::tube: {
      const double r = mean_radius(x, s.inner_nodes, false);
      // Axial stretch and twist from the free end's nodes (outer rim: away from the cap's axis).
      double z = 0.0, Z = 0.0, twist = 0.0;
      int count = 0;
      for (int n : s.end_nodes) {
        const double R = std::hypot(X[n][0], X[n][1]);
        if (R < spec.tube.inner_radius - 1e-9) continue;
        z += x[n][2];
        Z += X[n][2];
        twist += std::remainder(std::atan2(x[n][1], x[n][0]) - std::atan2(X[n][1], X[n][0]), 2 * M_PI);
        ++count;
      }
      const double zc = spec.tube.length + spec.tube.cap_thickness;
      const double axial = count ? (z / count) / (Z / count) : 1.0;
      (void)zc;
      return {t, p, volume, r, r / spec.tube.inner_radius, axial, count ? twist / count * 180.0 / M_PI : 0.0};
    }
    case StructureKind::actuator: {
      // Tip angle α (dissertation Fig. 30/32): angle between the tube axis and the line from the
      // clamped end's centre to the centre of the free end.
      Vec3 c = Vec3::Zero(), c0 = Vec3::Zero();
      for (int n : s.end_nodes) {
        c += x[n];
        c0 += X[n];
      }
      c /= double(s.end_nodes.size());
      c0 /= double(s.end_nodes.size());
      const double alpha = std::atan2(std::hypot(c[0], c[1]), c[2]) * 180.0 / M_PI;
      return {t, p, volume, alpha, (c - c0).norm()};
    }
    case StructureKind::imported: {
      // Mean distance of the loaded surface's nodes from the z axis; mean displacement of the probe surface.
      Vec3 du = Vec3::Zero();
      for (int n : s.end_nodes) du += (x[n] - X[n]) / double(s.end_nodes.size());
      return {t, p, volume, mean_radius(x, s.inner_nodes, false), du[0], du[1], du[2]};
    }
    case StructureKind::shell: {
      // The volume enclosed by the surface (closed by its symmetry planes), its ratio to the reference
      // one, and the mean distance of the nodes from the origin (a balloon's radius).
      const auto faces = fe::shell_load_faces(s.shell->triangles());
      const double v = fe::cavity_volume(x, faces, Vec3(1, 1, 1)), v0 = fe::cavity_volume(X, faces, Vec3(1, 1, 1));
      return {t, p, v, v0 != 0.0 ? v / v0 : 0.0, mean_radius(x, s.inner_nodes, true)};
    }
  }
  return {};
}

}  // namespace softhom::macro
