// [[fibers]] of macro scenes: one table per fiber family (fiber_geometry.hpp), every key declared once.
#include "fiber_keys.hpp"

namespace softhom::macro {
namespace {

using keys::Choices;
using keys::KeyTable;

/// The keys of one [[fibers]] table, flat (the spec's law and options are filled from them).
struct FiberKeys {
  FiberGeometry geometry = FiberGeometry::double_helix;
  double angle_deg = 45.0, pitch = 0.0, radius = 0.0, z_from = 0.0, z_to = -1.0;
  int count = 6, elements = 0, order = 1;
  std::vector<double> start_deg;
  std::vector<double> from{0, 0, 0}, to{1, 0, 0}, spacing{0, 0, 0};
  fe::FiberLawKind law = fe::FiberLawKind::linear;
  double modulus = 10.0, area = 0.0;
  bool cable = false, volume_correction = false;
  fe::FiberTie tie = fe::FiberTie::embedded;
  std::string surface;
  std::string group, file;
  double mesh_size = 0.0;
};

const keys::Range kLength = keys::left_open(0.0, 1e6);

const KeyTable<FiberKeys>& fibers_table() {
  static const KeyTable<FiberKeys> t = [] {
    using O = FiberKeys;
    KeyTable<O> k("fibers[]", "Fibers tied to the structure: 2- or 3-node truss/cable elements whose nodes follow the solid "
                              "(embedded in its elements, or on a named surface); no unknowns of their own.");
    k.choice("geometry", &O::geometry,
             Choices<FiberGeometry>{{{"double_helix", FiberGeometry::double_helix},
                                     {"helix", FiberGeometry::helix},
                                     {"straight", FiberGeometry::straight},
                                     {"gmsh", FiberGeometry::gmsh}},
                                    {}},
             "helices about the z axis (double: the mirror family at −angle from the same start angles), straight lines, "
             "or the lines of a Gmsh physical curve group")
        .number("angle_deg", &O::angle_deg, keys::right_open(0, 90), "deg", "helix angle from the tube axis")
        .number("pitch", &O::pitch, keys::at_least(0), "mm", "axial advance per turn (> 0: replaces angle_deg)")
        .integer("count", &O::count, keys::closed_range(1, 100000), "", "fibers per family (helices: start angles spread over 360°)")
        .numbers("start_deg", &O::start_deg, keys::any_value(), 0, 100000, "deg",
                 "start angles of a family's helices at z_from (given: count is their number)")
        .number("radius", &O::radius, keys::at_least(0), "mm",
                "helix radius (0: a tube's outer radius for tie = \"surface\", its mid-wall for \"embedded\")")
        .number("z_from", &O::z_from, keys::any_value(), "mm", "helix start along the axis")
        .number("z_to", &O::z_to, keys::any_value(), "mm", "helix end along the axis (< 0: a tube's length)")
        .numbers("from", &O::from, keys::any_value(), 3, 3, "mm", "straight: first fiber's start point")
        .numbers("to", &O::to, keys::any_value(), 3, 3, "mm", "straight: first fiber's end point")
        .numbers("spacing", &O::spacing, keys::any_value(), 3, 3, "mm", "straight: shift from one fiber to the next")
        .text("group", &O::group, "gmsh: the physical curve group (name or tag) whose 2- or 3-node lines are the fiber elements")
        .text("file", &O::file,
              "gmsh: the .msh (or .geo, meshed at mesh_size with quadratic lines) holding the group, relative to the scene "
              "(default: the geometry's own Gmsh mesh)")
        .number("mesh_size", &O::mesh_size, keys::at_least(0), "mm", "gmsh: the mesh size of a .geo file")
        .integer("elements", &O::elements, keys::closed_range(0, 1000000), "",
                 "elements per fiber (0: about the host's smallest cell size long)")
        .integer("order", &O::order, keys::closed_range(1, 2), "", "1: 2-node elements, 2: 3-node (quadratic) elements")
        .choice("law", &O::law,
                Choices<fe::FiberLawKind>{{{"linear", fe::FiberLawKind::linear}, {"neo-hookean", fe::FiberLawKind::neo_hookean}}, {}},
                "1D law: linear N = E A (λ − 1) (Biot strain), or neo-Hookean N = (E/3) A (λ − λ⁻²)")
        .number("modulus", &O::modulus, keys::left_open(0, 1e9), "MPa", "Young's modulus E of the fiber")
        .number("area", &O::area, keys::left_open(0, 1e6), "mm²", "cross-section A of one fiber").required()
        .flag("cable", &O::cable, "tension only: no force in compression")
        .flag("volume_correction", &O::volume_correction,
              "subtract the host's uniaxial stress along the fiber over A (the solid the fiber displaces; embedded only)")
        .choice("tie", &O::tie, Choices<fe::FiberTie>{{{"embedded", fe::FiberTie::embedded}, {"surface", fe::FiberTie::surface}}, {}},
                "fiber nodes follow the solid element containing them, or the faces of `surface`")
        .text("surface", &O::surface, "tie = \"surface\": the named face set (a tube's default: \"outer\")");
    return k;
  }();
  return t;
}

/// The keys of a Gmsh curve group only with geometry = "gmsh", and its group with it.
void check_curve_group_keys(const FiberKeys& k, const std::string& field) {
  const bool gmsh = k.geometry == FiberGeometry::gmsh;
  if (gmsh && k.group.empty()) throw InputError(field + ".group", "", "missing: the physical curve group of the fibers");
  if (gmsh && k.elements > 0)
    throw InputError(field + ".elements", std::to_string(k.elements), "not with geometry = \"gmsh\": the file's lines are the elements");
  if (!gmsh && !k.group.empty()) throw InputError(field + ".group", "\"" + k.group + "\"", "only with geometry = \"gmsh\"");
  if (!gmsh && !k.file.empty()) throw InputError(field + ".file", "\"" + k.file + "\"", "only with geometry = \"gmsh\"");
  if (k.mesh_size > 0.0 && !k.file.ends_with(".geo"))
    throw InputError(field + ".mesh_size", format_number(k.mesh_size), "only with a .geo file");
  if (k.file.ends_with(".geo") && !(k.mesh_size > 0.0))
    throw InputError(field + ".mesh_size", "", "missing: required with a .geo file");
}

FiberSpec spec_of(const FiberKeys& k, const std::string& field) {
  FiberSpec s;
  s.geometry = k.geometry;
  s.angle_deg = k.angle_deg;
  s.pitch = k.pitch;
  s.count = k.start_deg.empty() ? k.count : int(k.start_deg.size());
  s.start_deg = k.start_deg;
  s.radius = k.radius;
  s.z_from = k.z_from;
  s.z_to = k.z_to;
  s.from = Vec3(k.from[0], k.from[1], k.from[2]);
  s.to = Vec3(k.to[0], k.to[1], k.to[2]);
  s.spacing = Vec3(k.spacing[0], k.spacing[1], k.spacing[2]);
  s.elements = k.elements;
  s.options.law = {k.law, k.modulus, k.area, k.cable};
  s.options.order = k.order;
  s.options.tie = k.tie;
  s.options.surface = k.surface;
  s.options.volume_correction = k.volume_correction;
  s.options.field = field;
  s.group = k.group;
  s.file = k.file;
  s.mesh_size = k.mesh_size;
  check_curve_group_keys(k, field);
  if (!k.surface.empty() && k.tie != fe::FiberTie::surface)
    throw InputError(field + ".surface", "\"" + k.surface + "\"", "only with tie = \"surface\"");
  return s;
}

}  // namespace

keys::TableDoc fibers_table_doc() { return fibers_table().describe(); }

std::vector<FiberSpec> read_fibers(const toml::node* node) {
  std::vector<FiberSpec> out;
  if (!node) return out;
  const toml::array& arr = keys::read_array(*node, "fibers");
  for (std::size_t i = 0; i < arr.size(); ++i) {
    const std::string field = keys::index_field("fibers", i);
    FiberKeys k;
    fibers_table().read(keys::read_table(*arr.get(i), field), field, k);
    out.push_back(spec_of(k, field));
  }
  return out;
}

}  // namespace softhom::macro
