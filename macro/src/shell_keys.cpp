// Scene keys of shell structures: [geometry] type = "shell", the [shell] table with its layers and
// edges (shell_keys.hpp). Each key is declared once here.
#include "shell_keys.hpp"

#include <cmath>

#include <algorithm>
#include <filesystem>

#include "softhom/io/gmsh.hpp"
#include "softhom/io/scene.hpp"
#include "softhom/macro/mesh_generation.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/materials/shell_section.hpp"

namespace softhom::macro {
namespace {

using keys::Choices;
using keys::KeyTable;

struct ShellGeometryKeys {
  std::string type;
  ShellShape shape = ShellShape::sphere;
  double radius = 10.0, length = 10.0, width = 1.0, sweep_deg = 360.0, hole_deg = 18.0, angle_deg = 40.0;
  int cells = 8, axial_cells = 8;
  std::string file, geo;  ///< gmsh: a .msh, or a .geo meshed at run time into triangles
  double mesh_size = 0.0;
  std::vector<std::string> surfaces;  ///< gmsh: the physical surfaces that make the shell (all when empty)
};

struct LayerKeys {
  double thickness = 0.0;
  int points = 3;
  std::vector<double> fiber_angles;
  const toml::node* material = nullptr;
};

struct EdgeKeys {
  std::string edge;
  ShellEdgeCondition::Type type = ShellEdgeCondition::Type::clamped;
  int normal = -1;
};

struct ShellKeys {
  fe::ShellFrameRule::Kind frame = fe::ShellFrameRule::Kind::global;
  std::vector<double> frame_axis{1.0, 0.0, 0.0}, frame_origin{0.0, 0.0, 0.0};
  PlaneStressMode plane_stress = PlaneStressMode::incompressible;
  ThicknessRule thickness_rule = ThicknessRule::lobatto;
  const toml::node* layers = nullptr;
  const toml::node* edges = nullptr;
};

const KeyTable<LayerKeys>& layer_table() {
  static const KeyTable<LayerKeys> t = [] {
    KeyTable<LayerKeys> k("shell.layers[]", "One layer of the shell's section, bottom (against the normal) to top.");
    k.number("thickness", &LayerKeys::thickness, kLength, "mm", "reference thickness of the layer").required()
        .integer("points", &LayerKeys::points, keys::closed_range(1, 5), "",
                 "integration points through the layer (Lobatto 2..5: its faces are points; Gauss 1..5)")
        .numbers("fiber_angles", &LayerKeys::fiber_angles, keys::closed_range(-360, 360), 0, 8, "deg",
                 "one fiber family per angle, measured from the frame's e1 toward e2 in the tangent plane")
        .custom("material", "table",
                "the layer's law ([material] keys); with fiber_angles its fiber families give k1, k2 only (one family "
                "serves every angle; an anisotropic preset needs none)",
                [](const toml::node& n, const std::string&, LayerKeys& l) { l.material = &n; })
        .required();
    return k;
  }();
  return t;
}

const KeyTable<EdgeKeys>& edge_table() {
  using T = ShellEdgeCondition::Type;
  static const KeyTable<EdgeKeys> t = [] {
    KeyTable<EdgeKeys> k("shell.edges[]", "A condition on a named boundary edge of the surface (others are free).");
    k.text("edge", &EdgeKeys::edge, "edge name of the shape (x0, y0, z0, z1, theta0, xmin, hole, free, ...) or a physical curve of a gmsh surface").required()
        .choice("type", &EdgeKeys::type,
                Choices<T>{{{"clamped", T::clamped},
                            {"simply_supported", T::simply_supported},
                            {"symmetry", T::symmetry},
                            {"diaphragm", T::diaphragm},
                            {"free", T::free}},
                           {}},
                "clamped (u = 0, conormal kept), simply_supported (u = 0, free rotation), symmetry (u·n = 0, conormal "
                "kept), diaphragm (u = 0 in the plane normal to `normal`, free rotation), free")
        .choice("normal", &EdgeKeys::normal, Choices<int>{{{"x", 0}, {"y", 1}, {"z", 2}}, {}},
                "symmetry and diaphragm: the axis normal to the plane (default: the first letter of the edge's name)")
        .default_text("from the edge name");
    return k;
  }();
  return t;
}

const KeyTable<ShellKeys>& shell_keys_table() {
  static const KeyTable<ShellKeys> t = [] {
    KeyTable<ShellKeys> k("shell", "Shell structures (geometry.type = \"shell\"): section, fiber frame and edges.");
    k.choice("frame", &ShellKeys::frame,
             Choices<fe::ShellFrameRule::Kind>{{{"global", fe::ShellFrameRule::Kind::global},
                                                {"cylindrical", fe::ShellFrameRule::Kind::cylindrical}},
                                               {}},
             "local frame of each triangle: e1 the projection of frame_axis onto the tangent plane (global; within 1e-3 "
             "of the normal the y axis, then z, is projected instead, with a warning), or the circumferential "
             "direction about the axis frame_axis through frame_origin (cylindrical); e3 the normal")
        .numbers("frame_axis", &ShellKeys::frame_axis, keys::any_value(), 3, 3, "", "the frame's axis (not zero)")
        .numbers("frame_origin", &ShellKeys::frame_origin, keys::any_value(), 3, 3, "mm", "cylindrical: a point of the axis")
        .choice("plane_stress", &ShellKeys::plane_stress,
                Choices<PlaneStressMode>{{{"incompressible", PlaneStressMode::incompressible},
                                          {"compressible", PlaneStressMode::compressible}},
                                         {}},
                "S33 = 0 by J = 1 (the laws' volumetric energy replaced by the pressure: no locking) or by the "
                "thickness stretch of the law with its bulk modulus")
        .choice("thickness_rule", &ShellKeys::thickness_rule,
                Choices<ThicknessRule>{{{"lobatto", ThicknessRule::lobatto}, {"gauss", ThicknessRule::gauss}}, {}},
                "points through each layer: Gauss–Lobatto (faces included) or Gauss–Legendre")
        .custom("layers", "list of tables", "the section's layers, bottom to top ([[shell.layers]])",
                [](const toml::node& n, const std::string&, ShellKeys& s) { s.layers = &n; })
        .required()
        .custom("edges", "list of tables", "conditions on named edges ([[shell.edges]])",
                [](const toml::node& n, const std::string&, ShellKeys& s) { s.edges = &n; });
    return k;
  }();
  return t;
}

/// With fiber_angles the layer's angles give the directions: families of the material table (or of
/// an anisotropic preset, one family when none is given) need only their k1, k2 (κ), so a direction
/// that fiber_angles then replaces is filled in where none is given.
void with_placeholder_directions(toml::table& material) {
  auto placeholder = [] { return toml::array{1.0, 0.0, 0.0}; };
  if (!material.contains("fibers")) {
    toml::table family;
    family.insert("direction", placeholder());
    material.insert("fibers", toml::array{std::move(family)});
    return;
  }
  if (toml::array* families = material["fibers"].as_array())
    for (auto& f : *families)
      if (toml::table* t = f.as_table(); t && !t->contains("direction") && !t->contains("angle_deg"))
        t->insert("direction", placeholder());
}

std::shared_ptr<const ShellSection> read_section(const ShellKeys& k) {
  const toml::array& arr = keys::read_array(*k.layers, "shell.layers");
  std::vector<ShellLayer> layers;
  for (std::size_t i = 0; i < arr.size(); ++i) {
    const std::string field = keys::index_field("shell.layers", i);
    LayerKeys l;
    layer_table().read(keys::read_table(*arr.get(i), field), field, l);
    toml::table material = keys::read_table(*l.material, field + ".material");
    if (!l.fiber_angles.empty()) with_placeholder_directions(material);
    MaterialSpec spec = io::parse_material(material, field + ".material");
    const MaterialPtr law = l.fiber_angles.empty() ? build_material(spec) : layer_material(spec, l.fiber_angles);
    layers.push_back({law, l.thickness, l.points});
  }
  return std::make_shared<ShellSection>(std::move(layers), k.plane_stress, k.thickness_rule, "shell.layers");
}

std::vector<ShellEdgeCondition> read_edges(const ShellKeys& k) {
  std::vector<ShellEdgeCondition> out;
  if (!k.edges) return out;
  const toml::array& arr = keys::read_array(*k.edges, "shell.edges");
  for (std::size_t i = 0; i < arr.size(); ++i) {
    const std::string field = keys::index_field("shell.edges", i);
    EdgeKeys e;
    edge_table().read(keys::read_table(*arr.get(i), field), field, e);
    out.push_back({e.edge, e.type, e.normal});
  }
  return out;
}

const KeyTable<ShellGeometryKeys>& shell_geometry_table() {
  using O = ShellGeometryKeys;
  static const KeyTable<O> t = [] {
    KeyTable<O> k("geometry (shell)", "A thin shell's mid-surface, built in or from Gmsh ([shell] gives its section and edges).");
    k.text("type", &O::type, "structure kind: \"shell\"").required()
        .choice("shape", &O::shape,
                Choices<ShellShape>{{{"sphere", ShellShape::sphere},
                                     {"sphere_octant", ShellShape::sphere_octant},
                                     {"cylinder", ShellShape::cylinder},
                                     {"strip", ShellShape::strip},
                                     {"hemisphere", ShellShape::hemisphere},
                                     {"vault", ShellShape::vault},
                                     {"gmsh", ShellShape::gmsh}},
                                    {}},
                "sphere (closed; rigid motions held at three poles), sphere_octant (symmetry edges x0, y0, z0), cylinder "
                "(along z, edges z0, z1; sweep 90: symmetry theta0, theta1), strip (z = 0, edges xmin, xmax, ymin, "
                "ymax), hemisphere (quarter with a hole: symmetry x0, y0, edges hole, z0), vault (quarter barrel vault: "
                "symmetry x0, y0, diaphragm xL, edge free), gmsh (the triangles of a mesh file or of a .geo meshed at run "
                "time: its physical curves are the edges)")
        .required()
        .number("radius", &O::radius, kLength, "mm", "sphere, cylinder, hemisphere and vault radius")
        .number("length", &O::length, kLength, "mm", "cylinder and vault length (whole), strip length along x")
        .number("width", &O::width, kLength, "mm", "strip width along y")
        .number("sweep_deg", &O::sweep_deg, keys::left_open(0, 360), "deg", "cylinder: 360 (closed around) or an open sector")
        .number("hole_deg", &O::hole_deg, keys::open_range(0, 90), "deg", "hemisphere: half-angle of the hole about z")
        .number("angle_deg", &O::angle_deg, keys::open_range(0, 90), "deg", "vault: half opening angle")
        .integer("cells", &O::cells, kCells, "", "cells along the first direction (spheres: along an octant's edge)")
        .integer("axial_cells", &O::axial_cells, kCells, "", "cells along the second direction (cylinder: axial)")
        .text("file", &O::file, "gmsh: MSH 4.1 file of 3- or 6-node triangles (a 6-node one becomes its four 3-node "
                                "triangles), relative to the scene file (or give geo)")
        .text("geo", &O::geo, "gmsh: Gmsh geometry, relative to the scene file, meshed into triangles with gmsh -2 "
                              "-setnumber mesh_size (instead of file)")
        .number("mesh_size", &O::mesh_size, kLength, "mm", "gmsh: element size passed to the .geo (required with geo)")
        .custom(
            "surfaces", "list of strings", "gmsh: the physical surfaces that make the shell; each also gets its own "
                                           "probes in response.csv",
            [](const toml::node& n, const std::string& f, O& o) {
              const toml::array& a = keys::read_array(n, f);
              for (std::size_t i = 0; i < a.size(); ++i) o.surfaces.push_back(keys::read_text(*a.get(i), keys::index_field(f, i)));
            },
            "every physical surface");
    return k;
  }();
  return t;
}

/// The gmsh shape's surface: the triangles of the named physical surfaces, the physical curves as edges.
ShellSurface read_gmsh_shell(const ShellGeometryKeys& g, const std::filesystem::path& scene_file,
                             const std::filesystem::path& mesh_cache) {
  const std::filesystem::path path = scene_mesh_file(g.file, g.geo, g.mesh_size, scene_file, mesh_cache, 2);
  io::GmshSurface m = io::read_gmsh_surface(path, g.surfaces, g.geo.empty() ? "geometry.file" : "geometry.geo", "geometry.surfaces");
  ShellSurface out;
  out.mesh.nodes = std::move(m.nodes);
  out.triangles = std::move(m.triangles);
  out.edges = std::move(m.curves);
  out.groups = std::move(m.groups);
  if (!g.surfaces.empty())  // probes for the named surfaces only
    for (auto it = out.groups.begin(); it != out.groups.end();)
      it = std::count(g.surfaces.begin(), g.surfaces.end(), it->first) ? std::next(it) : out.groups.erase(it);
  return out;
}

}  // namespace

void read_shell(const toml::table& scene, const toml::table& geometry, StructureSpec& s, const std::filesystem::path& scene_file,
                const std::filesystem::path& mesh_cache) {
  ShellGeometryKeys g;
  shell_geometry_table().read(geometry, "geometry", g);
  if (g.shape != ShellShape::gmsh)
    for (const char* key : {"file", "geo", "mesh_size", "surfaces"})
      if (geometry.contains(key)) throw InputError(std::string("geometry.") + key, "", "only with geometry.shape = \"gmsh\"");
  s.kind = StructureKind::shell;
  ShellStructureSpec& sh = s.shell;
  sh.shape = g.shape;
  sh.radius = g.radius;
  sh.length = g.length;
  sh.width = g.width;
  sh.sweep_deg = g.sweep_deg;
  sh.hole_deg = g.hole_deg;
  sh.angle_deg = g.angle_deg;
  sh.cells = g.cells;
  sh.axial_cells = g.axial_cells;
  const toml::node* node = scene.get("shell");
  if (!node) throw InputError("shell", "", "missing: a shell needs its [shell] table with [[shell.layers]]");
  ShellKeys k;
  shell_keys_table().read(keys::read_table(*node, "shell"), "shell", k);
  const Vec3 axis(k.frame_axis[0], k.frame_axis[1], k.frame_axis[2]);
  if (!(axis.norm() > 0.0)) throw InputError("shell.frame_axis", "[0, 0, 0]", "the frame's axis must not be zero");
  sh.frame.kind = k.frame;
  sh.frame.axis = axis.normalized();
  sh.frame.origin = Vec3(k.frame_origin[0], k.frame_origin[1], k.frame_origin[2]);
  sh.section = read_section(k);
  sh.edges = read_edges(k);
  if (g.shape == ShellShape::gmsh) sh.imported = read_gmsh_shell(g, scene_file, mesh_cache);
}

std::vector<keys::TableDoc> shell_scene_tables() {
  return {shell_geometry_table().describe(), shell_keys_table().describe(), layer_table().describe(), edge_table().describe()};
}

std::vector<std::string> shell_geometry_key_names() { return shell_geometry_table().names(); }

}  // namespace softhom::macro
