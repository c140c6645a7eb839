// Macro scene files → StructureSpec + Newton options (macro/scene.hpp). Each table is declared once
// below (name, type, default, range, unit, doc); the readers use the same names and ranges.
#include "softhom/macro/scene.hpp"

#include <algorithm>
#include <cmath>

#include "softhom/fe/gmsh.hpp"
#include "softhom/io/scene.hpp"
#include "softhom/materials/errors.hpp"

namespace softhom::macro {
namespace {

using io::KeyRow;
using io::KeyTableDoc;

// Scenes are in mm. A structure larger than 1 km is a unit mistake; beyond it the generators'
// coordinates lose all digits (outer_radius = 1e300 produced empty surfaces, not an error).
constexpr double kMaxLength = 1e6;
// Cells along one direction; the total mesh size is bounded by the generators' node limit.
constexpr int kMaxCells = 100000;
constexpr double kInf = std::numeric_limits<double>::infinity();

const std::string kLengthRange = "(0, 1e6]";
const std::string kCellRange = "[1, 100000]";

const KeyTableDoc& scene_table() {
  static const KeyTableDoc t{
      "", "A macro scene: structure, material, load path, solver and output.",
      {{"description", "string", "", "", "", "free text, copied to summary.json"},
       {"geometry", "table", "", "", "", "the structure (required)"},
       {"material", "table", "", "", "", "material of the structure (region 0), fibers in the fiber frame"},
       {"material_lower", "table", "", "", "", "actuator only: the stiffer lower half (y < 0)"},
       {"load", "table", "", "", "", "load control and path (required)"},
       {"solver", "table", "", "", "", "Newton and linear-solver settings"},
       {"output", "table", "", "", "", "field output"},
       {"boundary", "array of tables", "", "", "", "gmsh only: constraints on physical surfaces"},
       {"probe", "table", "", "", "", "gmsh only: surface whose mean displacement is reported"},
       {"regions", "table", "", "", "", "gmsh only: a material table per physical volume"}},
      {}};
  return t;
}

// Keys of [geometry] by type. "type", "elements" and "fiber_frame" are common to all.
std::vector<KeyRow> common_geometry_rows() {
  return {{"type", "choice", "", "tube | actuator | sphere | plate | gmsh", "", "structure kind (required)"},
          {"elements", "choice", "hex8", "hex8 | tet10", "", "generated hexes, or each split into quadratic tets"},
          {"fiber_frame", "choice", "global", "global | cylindrical | spherical", "",
           "frame of the material's fiber directions (cylindrical: angle from the tube axis)"}};
}

KeyTableDoc geometry_table(const std::string& type, const std::string& doc, std::vector<KeyRow> rows) {
  std::vector<KeyRow> all = common_geometry_rows();
  if (type == "gmsh") all.erase(all.begin() + 1);  // an imported mesh keeps its own elements
  all.insert(all.end(), rows.begin(), rows.end());
  return KeyTableDoc{"geometry (type = \"" + type + "\")", doc, all, {}};
}

std::vector<KeyRow> tube_rows(bool actuator) {
  std::vector<KeyRow> rows{
      {"inner_radius", "number", "", kLengthRange, "mm", "cavity radius R_i (required)"},
      {"outer_radius", "number", "", "(inner_radius, 1e6]", "mm", "outer radius R_o > R_i (required)"},
      {"length", "number", "", kLengthRange, "mm", "axial length (required)"},
      {"radial_cells", "integer", "2", kCellRange, "", "cells through the wall"},
      {"circumferential_cells", "integer", "16", kCellRange, "", "cells around the swept angle"},
      {"axial_cells", "integer", "1", kCellRange, "", "cells along the axis"},
      {"sweep_deg", "number", "360", "90 | 360", "deg", "full tube or a quarter with symmetry planes"},
      {"cap_thickness", "number", actuator ? "" : "0", actuator ? kLengthRange : "[0, 1e6]", "mm",
       actuator ? "end cap at z = length (required)" : "end cap at z = length (0: open tube)"},
      {"cap_axial_cells", "integer", "1", kCellRange, "", "cells through the cap"},
      {"cap_core_cells", "integer", "2", kCellRange, "", "cells across the cap's core block"}};
  if (!actuator)
    rows.push_back({"plane_strain", "flag", "false", "true | false", "", "u_z = 0 on both ends (no cap)"});
  return rows;
}

const std::vector<KeyTableDoc>& geometry_tables() {
  static const std::vector<KeyTableDoc> t{
      geometry_table("tube", "Thick tube inflated by its cavity; plane-strain ends or clamped at z = 0.", tube_rows(false)),
      geometry_table("actuator", "Capped two-material tube clamped at z = 0 ([material_lower] for y < 0).",
                     tube_rows(true)),
      geometry_table("sphere", "One eighth of a thick sphere with symmetry planes, inflated.",
                     {{"inner_radius", "number", "", kLengthRange, "mm", "cavity radius (required)"},
                      {"thickness", "number", "", kLengthRange, "mm", "wall thickness (required)"},
                      {"radial_cells", "integer", "2", kCellRange, "", "cells through the wall"},
                      {"patch_cells", "integer", "8", kCellRange, "", "cells along each edge of the three patches"}}),
      geometry_table("plate", "Block in uniaxial tension along x.",
                     {{"size", "array of 3 numbers", "", kLengthRange + " each", "mm", "[Lx, Ly, Lz] (required)"},
                      {"cells", "array of 3 integers", "", kCellRange + " each", "", "[nx, ny, nz] (required)"}}),
      geometry_table("gmsh", "An imported MSH 4.1 mesh with [[boundary]], [probe] and [regions.*].",
                     {{"file", "string", "", "", "", "mesh file, relative to the scene file (required)"}})};
  return t;
}

const KeyTableDoc& boundary_table() {
  static const KeyTableDoc t{"boundary[i]", "gmsh only: u_i = 0 on a physical surface (at least one is required).",
                             {{"surface", "string", "", "a physical surface of the mesh", "", "(required)"},
                              {"fix", "array of strings", "", "\"x\", \"y\", \"z\" (at least one)", "",
                               "fixed displacement components (required)"}},
                             {}};
  return t;
}

const KeyTableDoc& probe_table() {
  static const KeyTableDoc t{"probe", "gmsh only: reported mean displacement.",
                             {{"surface", "string", "", "a physical surface of the mesh", "",
                               "its mean displacement is a response.csv column"}},
                             {}};
  return t;
}

const KeyTableDoc& load_table() {
  static const KeyTableDoc t{
      "load", "Load control and its piecewise-linear path.",
      {{"control", "choice", "", "pressure | volume | stretch", "", "plate: stretch; cavities: pressure or volume (required)"},
       {"path", "array of [t, value]", "", "t from 0, increasing; values finite (stretch, volume ratio > 0)",
        "s, MPa | V/V0 | λ", "the controlled value over time (required)"},
       {"steps", "integer", "20", "[1, 1000000]", "", "uniform output steps over the path"},
       {"surface", "string or array of strings", "", "physical surfaces", "", "gmsh only: loaded cavity surface(s)"},
       {"cavity_mask", "array of 3 numbers", "[1, 1, 1]", "", "", "gmsh only: components of the cavity volume"}},
      {}};
  return t;
}

const KeyTableDoc& solver_table() {
  static const KeyTableDoc t{
      "solver", "Newton iteration and linear solver (same spelling as point and rve scenes).",
      {{"tolerance", "number", "1e-8", "(0, 1)", "", "‖R_free‖ ≤ tolerance · force scale"},
       {"max_newton_iterations", "integer", "25", "[1, 1000]", "", "Newton iterations per sub-step"},
       {"max_krylov_iterations", "integer", "40", "[1, 100000]", "", "GMRES iterations before a refactorization"},
       {"max_cutbacks", "integer", "12", "[0, 60]", "", "consecutive halvings of one output interval"},
       {"max_step_seconds", "number", "0", ">= 0", "s", "wall-time budget of one output interval (0: unlimited)"},
       {"substeps", "integer", "1", "[1, 1000000]", "", "sub-steps per output interval at the start"},
       {"mixed_pressure", "flag", "true", "true | false", "", "three-field (u, θ, p) iteration for compressible laws"},
       {"formulation", "choice", "fbar", "fbar | standard", "", "hex8 volumetric treatment"},
       {"linear_solver", "choice", "auto", "auto | cholmod | umfpack", "", "sparse direct solver"},
       {"verbose", "flag", "false", "true | false", "", "Newton iteration log on stderr"}},
      {{"max_iterations", "max_newton_iterations"},
       {"krylov_max", "max_krylov_iterations"},
       {"mixed", "mixed_pressure"}}};
  return t;
}

const KeyTableDoc& output_table() {
  static const KeyTableDoc t{
      "output", "Field output (fields/ XDMF + HDF5).",
      {{"fields", "flag or array of numbers", "true", "times within the load path", "s",
        "true: every output step; false: none; [t1, ...]: snapshots at these times (added to the output steps)"}},
      {}};
  return t;
}

std::string list_field(const std::string& path, std::size_t k) { return path + "[" + std::to_string(k) + "]"; }

double finite_entry(const toml::node& node, const std::string& field) {
  const auto v = node.value<double>();
  if (!v) throw InputError(field, io::describe_value(node), "must be a number");
  if (!std::isfinite(*v)) throw InputError(field, io::describe_value(node), "must be a finite number");
  return *v;
}

PiecewiseLinear parse_path(const toml::table& t, const std::string& path, LoadControl control) {
  const std::string field = path + ".path";
  const auto* arr = t["path"].as_array();
  if (!arr || arr->empty()) throw InputError(field, t["path"] ? io::describe_value(*t.get("path")) : "", "need [[t0, v0], [t1, v1], ...]");
  PiecewiseLinear f{{}, {}};
  for (std::size_t k = 0; k < arr->size(); ++k) {
    const auto* pt = (*arr)[k].as_array();
    const std::string pf = list_field(field, k);
    if (!pt || pt->size() != 2) throw InputError(pf, io::describe_value((*arr)[k]), "each point is [t, value]");
    const double tv = finite_entry(*pt->get(0), pf + "[0]"), vv = finite_entry(*pt->get(1), pf + "[1]");
    if (!f.t.empty() && !(tv > f.t.back())) throw InputError(pf + "[0]", format_number(tv), "times must increase");
    if (control != LoadControl::pressure && !(vv > 0.0))
      throw InputError(pf + "[1]", format_number(vv),
                       control == LoadControl::stretch ? "a stretch must be > 0" : "a volume ratio must be > 0");
    f.t.push_back(tv);
    f.v.push_back(vv);
  }
  if (f.t.front() != 0.0) throw InputError(list_field(field, 0) + "[0]", format_number(f.t.front()), "must start at t = 0");
  if (f.t.size() < 2) throw InputError(field, "", "need at least two points");
  return f;
}

std::vector<std::string> string_list(const toml::node_view<const toml::node>& node, const std::string& field) {
  std::vector<std::string> out;
  if (const auto v = node.value_exact<std::string>()) {
    out.push_back(*v);
  } else if (const auto* arr = node.as_array()) {
    for (std::size_t k = 0; k < arr->size(); ++k) {
      const auto v = (*arr)[k].value_exact<std::string>();
      if (!v) throw InputError(list_field(field, k), io::describe_value((*arr)[k]), "entries must be strings");
      out.push_back(*v);
    }
  } else if (node) {
    throw InputError(field, io::describe_value(*node.node()), "expected a string or an array of strings");
  }
  return out;
}

Vec3 vec3_of(const toml::node_view<const toml::node>& node, const std::string& field) {
  const auto* arr = node.as_array();
  if (!arr || arr->size() != 3) throw InputError(field, node ? io::describe_value(*node.node()) : "", "need three numbers");
  Vec3 v;
  for (int d = 0; d < 3; ++d) v[d] = finite_entry(*arr->get(std::size_t(d)), list_field(field, std::size_t(d)));
  return v;
}

std::string required_string(const toml::table& t, const std::string& key, const std::string& path, const std::string& why) {
  const std::string v = io::get_string_or(t, key, path, "");
  if (v.empty()) throw InputError(path + "." + key, "", why);
  return v;
}

const KeyTableDoc& geometry_decl(const std::string& type) {
  for (const KeyTableDoc& t : geometry_tables())
    if (t.path == "geometry (type = \"" + type + "\")") return t;
  throw InputError("geometry.type", type.empty() ? "" : "\"" + io::printable(type) + "\"",
                   type.empty() ? "missing (tube, actuator, sphere, plate or gmsh)" : "expected tube, actuator, sphere, plate or gmsh");
}

/// Keys of another geometry type name the types they belong to (sphere.thickness in a tube scene).
void check_geometry_keys(const toml::table& g, const std::string& type) {
  const KeyTableDoc& decl = geometry_decl(type);
  for (const auto& [k, node] : g) {
    const std::string key(k.str());
    if (std::any_of(decl.rows.begin(), decl.rows.end(), [&](const KeyRow& r) { return r.name == key; })) continue;
    std::string owners;
    for (const KeyTableDoc& other : geometry_tables())
      if (std::any_of(other.rows.begin(), other.rows.end(), [&](const KeyRow& r) { return r.name == key; }))
        owners += (owners.empty() ? "" : ", ") + other.path.substr(other.path.find('"') + 1,
                                                                  other.path.rfind('"') - other.path.find('"') - 1);
    if (!owners.empty())
      throw InputError("geometry." + key, io::describe_value(node),
                       "not a key of geometry.type = \"" + type + "\" (only for " + owners + ")");
    io::check_declared(g, "geometry", decl);  // the unknown-key message with its suggestion
  }
}

void parse_tube(const toml::table& g, StructureSpec& s, bool actuator) {
  auto& t = s.tube;
  t.inner_radius = io::require_number_in(g, "inner_radius", "geometry", 0.0, kMaxLength, true);
  t.outer_radius = io::require_number_in(g, "outer_radius", "geometry", 0.0, kMaxLength, true);
  if (!(t.outer_radius > t.inner_radius))
    throw InputError("geometry.outer_radius", format_number(t.outer_radius),
                     "must exceed geometry.inner_radius = " + format_number(t.inner_radius));
  t.length = io::require_number_in(g, "length", "geometry", 0.0, kMaxLength, true);
  t.radial_cells = io::get_int_in(g, "radial_cells", "geometry", 2, 1, kMaxCells);
  t.circumferential_cells = io::get_int_in(g, "circumferential_cells", "geometry", 16, 1, kMaxCells);
  t.axial_cells = io::get_int_in(g, "axial_cells", "geometry", 1, 1, kMaxCells);
  t.sweep_deg = io::get_number_in(g, "sweep_deg", "geometry", 360.0, 0.0, 360.0, true);
  if (t.sweep_deg != 90.0 && t.sweep_deg != 360.0)
    throw InputError("geometry.sweep_deg", format_number(t.sweep_deg), "only 90 (quarter) or 360 are supported");
  if (actuator) {
    t.cap_thickness = io::require_number_in(g, "cap_thickness", "geometry", 0.0, kMaxLength, true);
  } else {
    t.cap_thickness = io::get_number_in(g, "cap_thickness", "geometry", 0.0, 0.0, kMaxLength);
    s.plane_strain = io::get_bool_or(g, "plane_strain", "geometry", false);
    if (s.plane_strain && t.cap_thickness > 0.0)
      throw InputError("geometry.plane_strain", "true",
                       "incompatible with geometry.cap_thickness = " + format_number(t.cap_thickness));
  }
  t.cap_axial_cells = io::get_int_in(g, "cap_axial_cells", "geometry", 1, 1, kMaxCells);
  t.cap_core_cells = io::get_int_in(g, "cap_core_cells", "geometry", 2, 1, kMaxCells);
}

void parse_sphere(const toml::table& g, StructureSpec& s) {
  s.sphere.inner_radius = io::require_number_in(g, "inner_radius", "geometry", 0.0, kMaxLength, true);
  s.sphere.thickness = io::require_number_in(g, "thickness", "geometry", 0.0, kMaxLength, true);
  s.sphere.radial_cells = io::get_int_in(g, "radial_cells", "geometry", 2, 1, kMaxCells);
  s.sphere.patch_cells = io::get_int_in(g, "patch_cells", "geometry", 8, 1, kMaxCells);
}

void parse_plate(const toml::table& g, StructureSpec& s) {
  const auto* size = g["size"].as_array();
  const auto* cells = g["cells"].as_array();
  if (!size || size->size() != 3)
    throw InputError("geometry.size", g.contains("size") ? io::describe_value(*g.get("size")) : "", "need [Lx, Ly, Lz] in mm");
  if (!cells || cells->size() != 3)
    throw InputError("geometry.cells", g.contains("cells") ? io::describe_value(*g.get("cells")) : "", "need [nx, ny, nz]");
  for (std::size_t d = 0; d < 3; ++d) {
    const std::string sf = list_field("geometry.size", d), cf = list_field("geometry.cells", d);
    const double L = finite_entry(*size->get(d), sf);
    if (!(L > 0.0 && L <= kMaxLength)) throw InputError(sf, format_number(L), "must lie in " + kLengthRange);
    s.plate.size[d] = L;
    const toml::node& cn = *cells->get(d);
    const auto ci = cn.value_exact<std::int64_t>();
    const auto cd = cn.value_exact<double>();
    const bool whole = ci || (cd && std::isfinite(*cd) && *cd == std::floor(*cd));
    const double c = ci ? double(*ci) : cd ? *cd : 0.0;
    if (!whole || c < 1 || c > kMaxCells) throw InputError(cf, io::describe_value(cn), "must be a whole number in " + kCellRange);
    s.plate.cells[d] = int(c);
  }
}

void parse_boundaries(const toml::table& scene, ImportedSpec& im) {
  const auto* arr = scene["boundary"].as_array();
  if (scene.contains("boundary") && !arr) throw InputError("boundary", "", "expected [[boundary]] tables");
  if (!arr || arr->empty())
    throw InputError("boundary", "",
                     "the body is not constrained: give [[boundary]] tables with surface and fix = [\"x\", ...]");
  for (std::size_t k = 0; k < arr->size(); ++k) {
    const std::string field = list_field("boundary", k);
    const auto* t = (*arr)[k].as_table();
    if (!t) throw InputError(field, io::describe_value((*arr)[k]), "expected [[boundary]] tables");
    io::check_declared(*t, field, boundary_table());
    ImportedSpec::Fix f;
    f.surface = required_string(*t, "surface", field, "missing physical surface name");
    if (!im.mesh.has_surface(f.surface))
      throw InputError(field + ".surface", "\"" + io::printable(f.surface) + "\"", "no physical surface of that name in the mesh");
    for (const std::string& c : string_list((*t)["fix"], field + ".fix")) {
      if (c != "x" && c != "y" && c != "z") throw InputError(field + ".fix", io::printable(c), "components are \"x\", \"y\", \"z\"");
      f.components[c[0] - 'x'] = true;
    }
    if (!f.components[0] && !f.components[1] && !f.components[2])
      throw InputError(field + ".fix", (*t)["fix"] ? io::describe_value(*t->get("fix")) : "",
                       "fixes no component: the body is not constrained on this surface (give fix = [\"x\", ...])");
    im.fixed.push_back(f);
  }
}

/// [geometry] type = "gmsh": the mesh, constraints on physical surfaces and region materials.
void parse_imported(const toml::table& scene, const toml::table& g, const std::filesystem::path& scene_file,
                    StructureSpec& s) {
  s.kind = StructureKind::imported;
  const std::string file = required_string(g, "file", "geometry", "a gmsh geometry needs file = \"mesh.msh\"");
  std::filesystem::path path(file);
  if (path.is_relative() && !scene_file.empty()) path = scene_file.parent_path() / path;
  if (!std::filesystem::exists(path)) throw InputError("geometry.file", path.string(), "no such file");
  auto& im = s.imported;
  im.mesh = fe::read_gmsh(path);
  parse_boundaries(scene, im);
  if (scene.contains("probe")) {
    const auto* probe = scene["probe"].as_table();
    if (!probe) throw InputError("probe", "", "expected a [probe] table");
    io::check_declared(*probe, "probe", probe_table());
    im.probe_surface = io::get_string_or(*probe, "surface", "probe", "");
  }
  if (scene.contains("regions")) {
    const auto* regions = scene["regions"].as_table();
    if (!regions) throw InputError("regions", "", "expected [regions.<physical volume>] tables");
    for (const auto& [name, node] : *regions) {
      const std::string field = "regions." + std::string(name.str());
      const auto* t = node.as_table();
      if (!t) throw InputError(field, io::describe_value(node), "expected a material table");
      if (std::find(im.mesh.region_names.begin(), im.mesh.region_names.end(), std::string(name.str())) ==
          im.mesh.region_names.end())
        throw InputError(field, "", "no physical volume of that name in " + path.string());
      im.region_materials[std::string(name.str())] = build_material(io::parse_material(*t, field));
    }
  }
}

void parse_geometry(const toml::table& scene, const std::filesystem::path& scene_file, StructureSpec& s) {
  const auto* g = scene["geometry"].as_table();
  if (!g) throw InputError("geometry", "", "missing [geometry] table");
  const std::string type = io::get_string_or(*g, "type", "geometry", "");
  check_geometry_keys(*g, type);
  if (type == "tube" || type == "actuator") {
    s.kind = type == "tube" ? StructureKind::tube : StructureKind::actuator;
    parse_tube(*g, s, type == "actuator");
  } else if (type == "sphere") {
    s.kind = StructureKind::sphere;
    parse_sphere(*g, s);
  } else if (type == "plate") {
    s.kind = StructureKind::plate;
    parse_plate(*g, s);
  } else {
    parse_imported(scene, *g, scene_file, s);
  }
  for (const char* key : {"boundary", "probe", "regions"})
    if (type != "gmsh" && scene.contains(key)) throw InputError(key, "", "only for geometry.type = \"gmsh\"");
  if (type != "gmsh") s.tet10 = io::get_choice(*g, "elements", "geometry", "hex8", {"hex8", "tet10"}) == "tet10";
  const std::string frame = io::get_choice(*g, "fiber_frame", "geometry", "global", {"global", "cylindrical", "spherical"});
  s.fiber_frame = frame == "global" ? FiberFrame::global : frame == "cylindrical" ? FiberFrame::cylindrical : FiberFrame::spherical;
}

void parse_materials(const toml::table& scene, StructureSpec& s) {
  const auto* mat = scene["material"].as_table();
  if (!mat) throw InputError("material", "", "missing [material] table");
  s.material = build_material(io::parse_material(*mat, "material"));
  if (scene.contains("material_lower")) {
    if (s.kind != StructureKind::actuator) throw InputError("material_lower", "", "only for geometry.type = \"actuator\"");
    const auto* lower = scene["material_lower"].as_table();
    if (!lower) throw InputError("material_lower", "", "expected a material table");
    s.material_region1 = build_material(io::parse_material(*lower, "material_lower"));
  }
}

/// Uniform output steps merged with the field times (a relative 1e-9 of the end merges coincident ones).
std::vector<double> output_times(double end, int steps, const std::vector<double>& extra) {
  std::vector<double> times;
  for (int k = 1; k <= steps; ++k) times.push_back(end * k / steps);
  for (double t : extra)
    if (t > 0.0) times.push_back(t);
  std::sort(times.begin(), times.end());
  std::vector<double> merged;
  for (double t : times)
    if (merged.empty() || t - merged.back() > 1e-9 * end) merged.push_back(t);
  merged.back() = end;
  return merged;
}

void parse_load(const toml::table& scene, MacroScene& m) {
  StructureSpec& s = m.spec;
  const auto* load = scene["load"].as_table();
  if (!load) throw InputError("load", "", "missing [load] table");
  io::check_declared(*load, "load", load_table());
  if (s.kind == StructureKind::imported) {
    s.imported.load_surfaces = string_list((*load)["surface"], "load.surface");
    for (const std::string& n : s.imported.load_surfaces)
      if (!s.imported.mesh.has_surface(n))
        throw InputError("load.surface", "\"" + io::printable(n) + "\"", "no physical surface of that name in the mesh");
    if ((*load)["cavity_mask"]) s.imported.cavity_mask = vec3_of((*load)["cavity_mask"], "load.cavity_mask");
  } else if (load->contains("surface") || load->contains("cavity_mask")) {
    throw InputError(load->contains("surface") ? "load.surface" : "load.cavity_mask", "",
                     "only for geometry.type = \"gmsh\" (generated structures load their cavity)");
  }
  const std::string control = io::get_choice(*load, "control", "load", "", {"pressure", "volume", "stretch"});
  s.control = control == "pressure" ? LoadControl::pressure : control == "volume" ? LoadControl::volume : LoadControl::stretch;
  if ((s.kind == StructureKind::plate) != (s.control == LoadControl::stretch))
    throw InputError("load.control", "\"" + control + "\"",
                     s.kind == StructureKind::plate ? "a plate is driven by stretch"
                                                    : "a structure with a cavity is driven by pressure or volume");
  s.load = parse_path(*load, "load", s.control);
  const int steps = io::get_int_in(*load, "steps", "load", 20, 1, 1000000);
  m.times = output_times(s.load.end_time(), steps, m.field_times);
}

void parse_solver(const toml::table& scene, MacroScene& m) {
  if (!scene.contains("solver")) return;
  const auto* sv = scene["solver"].as_table();
  if (!sv) throw InputError("solver", "", "expected a [solver] table");
  if (const toml::node* kt = sv->get("krylov_tolerance"))
    throw InputError("solver.krylov_tolerance", io::describe_value(*kt),
                     "not a macro setting: the GMRES tolerance follows the Newton residual (forcing term); "
                     "limit max_krylov_iterations instead");
  io::check_declared(*sv, "solver", solver_table());
  fe::NewtonOptions& n = m.newton;
  n.tolerance = io::get_number_in(*sv, "tolerance", "solver", n.tolerance, 0.0, 1.0, true, true);
  n.max_iterations = io::get_int_in(*sv, "max_newton_iterations", "solver", n.max_iterations, 1, 1000);
  n.krylov_max = io::get_int_in(*sv, "max_krylov_iterations", "solver", n.krylov_max, 1, 100000);
  n.max_cutbacks = io::get_int_in(*sv, "max_cutbacks", "solver", n.max_cutbacks, 0, 60);
  n.max_step_seconds = io::get_number_in(*sv, "max_step_seconds", "solver", n.max_step_seconds, 0.0, kInf);
  n.initial_substeps = io::get_int_in(*sv, "substeps", "solver", 1, 1, 1000000);
  n.mixed = io::get_bool_or(*sv, "mixed_pressure", "solver", n.mixed);
  n.verbose = io::get_bool_or(*sv, "verbose", "solver", false);
  const std::string f = io::get_choice(*sv, "formulation", "solver", "fbar", {"fbar", "standard"});
  m.spec.formulation = f == "fbar" ? fe::Formulation::fbar : fe::Formulation::standard;
  const std::string ls = io::get_choice(*sv, "linear_solver", "solver", "auto", {"auto", "cholmod", "umfpack"});
  n.solver = ls == "auto" ? fe::SolverKind::automatic : ls == "cholmod" ? fe::SolverKind::cholmod : fe::SolverKind::umfpack;
}

/// [output] fields = true | false | [t1, ...]; the times must lie on the load path [0, end].
void parse_output(const toml::table& scene, const toml::table& load, MacroScene& m) {
  if (!scene.contains("output")) return;
  const auto* out = scene["output"].as_table();
  if (!out) throw InputError("output", "", "expected an [output] table");
  io::check_declared(*out, "output", output_table());
  const toml::node* node = out->get("fields");
  if (!node) return;
  if (const auto b = node->value_exact<bool>()) {
    m.fields = *b;
    return;
  }
  const auto* arr = node->as_array();
  if (!arr || arr->empty())
    throw InputError("output.fields", io::describe_value(*node), "expected true, false or a list of times [t1, t2, ...]");
  // The path's end time, read leniently here: parse_load reports a malformed path.
  double end = 0.0;
  if (const auto* p = load["path"].as_array(); p && !p->empty())
    if (const auto* last = p->back().as_array(); last && !last->empty()) end = last->get(0)->value<double>().value_or(0.0);
  for (std::size_t k = 0; k < arr->size(); ++k) {
    const std::string field = list_field("output.fields", k);
    const double t = finite_entry(*arr->get(k), field);
    if (!(t >= 0.0 && t <= end))
      throw InputError(field, format_number(t), "outside the load path [0, " + format_number(end) + "]");
    m.field_times.push_back(t);
  }
  std::sort(m.field_times.begin(), m.field_times.end());
}

}  // namespace

bool MacroScene::fields_at(double t) const {
  if (!fields) return false;
  if (field_times.empty()) return true;
  const double tol = 1e-9 * (times.empty() ? 1.0 : std::max(1.0, times.back()));
  return std::any_of(field_times.begin(), field_times.end(), [&](double f) { return std::abs(f - t) <= tol; });
}

MacroScene parse_macro_scene(const toml::table& scene, const std::filesystem::path& scene_file) {
  io::check_declared(scene, "", scene_table());
  MacroScene m;
  parse_geometry(scene, scene_file, m.spec);
  parse_materials(scene, m.spec);
  const auto* load = scene["load"].as_table();
  if (!load) throw InputError("load", "", "missing [load] table");
  parse_output(scene, *load, m);  // before the load: field times join the output times
  parse_load(scene, m);
  parse_solver(scene, m);
  return m;
}

std::vector<io::KeyTableDoc> macro_key_tables() {
  std::vector<io::KeyTableDoc> out{scene_table()};
  for (const auto& g : geometry_tables()) out.push_back(g);
  out.push_back(boundary_table());
  out.push_back(probe_table());
  out.push_back(load_table());
  out.push_back(solver_table());
  out.push_back(output_table());
  return out;
}

}  // namespace softhom::macro
