// Macro scene files → StructureSpec + Newton options (macro/scene.hpp). Each table is declared once
// below (keys::KeyTable: name, type, default, range, unit, doc); reading, defaults and the reference
// tables of `softhom keys macro` all come from these declarations.
#include "softhom/materials/system_memory.hpp"
#include "softhom/macro/scene.hpp"

#include "softhom/fe/petsc_options.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>

#include "contact_keys.hpp"
#include "device_keys.hpp"
#include "shell_keys.hpp"
#include "fiber_keys.hpp"
#include "helix_tube_keys.hpp"
#include "softhom/io/gmsh.hpp"
#include "softhom/io/scene.hpp"
#include "softhom/macro/mesh_generation.hpp"
#include "softhom/materials/errors.hpp"

namespace softhom::macro {
namespace {

using keys::Choices;
using keys::KeyTable;


/// The keys every generated geometry shares, plus the members of its generator's spec.
template <class Spec>
struct GeometryKeys : Spec {
  std::string type;
  bool tet10 = false;
  FiberFrame fiber_frame = FiberFrame::global;
};

/// A member of the generator's spec as a member of its GeometryKeys (base-to-derived conversion).
template <class O, class M, class B>
M O::*in(M B::*m) {
  return m;
}

struct TubeKeys : GeometryKeys<TubeSpec> {
  bool plane_strain = false;
  TubeKeys() {
    radial_cells = 2;
    sweep_deg = 360.0;
  }
};
struct SphereKeys : GeometryKeys<SphereSpec> {};
struct PlateKeys : GeometryKeys<PlateSpec> {};
struct GmshKeys {
  std::string type, file, geo;
  double mesh_size = 0.0;
  std::vector<std::pair<std::string, double>> geo_parameters;  ///< -setnumber NAME VALUE for the .geo
  FiberFrame fiber_frame = FiberFrame::global;
};

const Choices<FiberFrame> kFrames{{{"global", FiberFrame::global},
                                   {"cylindrical", FiberFrame::cylindrical},
                                   {"spherical", FiberFrame::spherical}},
                                  {}};
const std::string kTypes = "\"tube\", \"actuator\", \"sphere\", \"plate\", \"gmsh\", \"shell\"";

template <class O>
void add_common(KeyTable<O>& t, bool elements) {
  t.text("type", in<O>(&O::type), "structure kind: " + kTypes).required();
  if constexpr (requires { &O::tet10; })
    if (elements)
      t.choice("elements", in<O>(&O::tet10), Choices<bool>{{{"hex8", false}, {"tet10", true}}, {}},
               "generated hexes, or each split into 10-node tets (mid nodes on curved surfaces)");
  t.choice("fiber_frame", in<O>(&O::fiber_frame), kFrames,
           "frame of the material's fiber directions (cylindrical: angle from the tube axis)");
}

KeyTable<TubeKeys> tube_table(bool actuator) {
  using O = TubeKeys;
  KeyTable<O> t(actuator ? "geometry (actuator)" : "geometry (tube)",
                actuator ? "Capped two-material tube clamped at z = 0 ([material_lower] for y < 0)."
                         : "Thick tube inflated by its cavity; plane-strain ends, or clamped at z = 0 when capped.");
  add_common(t, true);
  t.number("inner_radius", in<O>(&TubeSpec::inner_radius), kLength, "mm", "cavity radius R_i").required()
      .number("outer_radius", in<O>(&TubeSpec::outer_radius), kLength, "mm", "outer radius, > inner_radius").required()
      .number("length", in<O>(&TubeSpec::length), kLength, "mm", "axial length").required()
      .integer("radial_cells", in<O>(&TubeSpec::radial_cells), kCells, "", "cells through the wall")
      .integer("circumferential_cells", in<O>(&TubeSpec::circumferential_cells), kCells, "", "cells around the swept angle")
      .integer("axial_cells", in<O>(&TubeSpec::axial_cells), kCells, "", "cells along the axis")
      .number("sweep_deg", in<O>(&TubeSpec::sweep_deg), keys::left_open(0, 360), "deg",
              "360 (full tube) or 90 (quarter with symmetry planes)")
      .number("cap_thickness", in<O>(&TubeSpec::cap_thickness), actuator ? kLength : keys::closed_range(0, 1e6), "mm",
              actuator ? "end cap at z = length" : "end cap at z = length (0: open ends)");
  if (actuator) t.required();
  t.integer("cap_axial_cells", in<O>(&TubeSpec::cap_axial_cells), kCells, "", "cells through the cap")
      .integer("cap_core_cells", in<O>(&TubeSpec::cap_core_cells), kCells, "", "cells across the cap's core block");
  if (!actuator) t.flag("plane_strain", &O::plane_strain, "u_z = 0 on both ends (open tube only)");
  return t;
}

KeyTable<SphereKeys> sphere_table() {
  using O = SphereKeys;
  KeyTable<O> t("geometry (sphere)", "One eighth of a thick sphere with symmetry planes, inflated.");
  add_common(t, true);
  t.number("inner_radius", in<O>(&SphereSpec::inner_radius), kLength, "mm", "cavity radius").required()
      .number("thickness", in<O>(&SphereSpec::thickness), kLength, "mm", "wall thickness").required()
      .integer("radial_cells", in<O>(&SphereSpec::radial_cells), kCells, "", "cells through the wall")
      .integer("patch_cells", in<O>(&SphereSpec::patch_cells), kCells, "", "cells along each edge of the three patches");
  return t;
}

KeyTable<PlateKeys> plate_table() {
  using O = PlateKeys;
  KeyTable<O> t("geometry (plate)", "Block in uniaxial tension along x.");
  add_common(t, true);
  t.custom(
       "size", "list of numbers", "[Lx, Ly, Lz]",
       [](const toml::node& n, const std::string& f, O& o) {
         const std::vector<double> v = keys::read_numbers(n, f, kLength, 3, 3);
         o.size = Vec3(v[0], v[1], v[2]);
       },
       "", "3 entries, each " + kLength.describe(), "mm")
      .required()
      .custom(
          "cells", "list of integers", "[nx, ny, nz]",
          [](const toml::node& n, const std::string& f, O& o) {
            const std::vector<int> v = keys::read_ints<int>(n, f, kCells, 3, 3);
            o.cells = {v[0], v[1], v[2]};
          },
          "", "3 entries, each " + kCells.describe())
      .required();
  return t;
}

/// [geometry] geo_parameters: names a .geo may define (letters, digits, '_', not starting with a digit) and
/// finite numbers.
std::vector<std::pair<std::string, double>> read_geo_parameters(const toml::node& node, const std::string& field) {
  std::vector<std::pair<std::string, double>> out;
  for (const auto& [key, value] : keys::read_table(node, field)) {
    const std::string name(key.str()), f = field + "." + name;
    const bool identifier = !name.empty() && !std::isdigit(static_cast<unsigned char>(name[0])) &&
                            std::all_of(name.begin(), name.end(), [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; });
    if (!identifier) throw InputError(f, "\"" + name + "\"", "not a .geo constant name (letters, digits, _)");
    if (name == "mesh_size") throw InputError(f, "", "give it as geometry.mesh_size");
    out.emplace_back(name, keys::read_number(value, f));
  }
  return out;
}

KeyTable<GmshKeys> gmsh_table() {
  KeyTable<GmshKeys> t("geometry (gmsh)",
                       "An imported MSH 4.1 mesh (its own elements), or a .geo meshed at run time by gmsh into quadratic "
                       "tets (cached by geometry hash and size), with [[boundary]], [probe], [regions.*], [device].");
  add_common(t, false);
  t.text("file", &GmshKeys::file, "mesh file, relative to the scene file (or give geo)")
      .text("geo", &GmshKeys::geo, "Gmsh geometry, relative to the scene file, meshed with -setnumber mesh_size (instead of file)")
      .number("mesh_size", &GmshKeys::mesh_size, kLength, "mm", "element size passed to the .geo (required with geo)")
      .custom("geo_parameters", "table of numbers",
              "further numbers passed to the .geo (-setnumber NAME VALUE; its DefineConstant names), e.g. { sample_radius = 0.5 }",
              [](const toml::node& n, const std::string& f, GmshKeys& o) { o.geo_parameters = read_geo_parameters(n, f); },
              "{}");
  return t;
}

struct BoundaryKeys {
  std::string surface;
  std::vector<std::string> fix;
};

const KeyTable<BoundaryKeys>& boundary_table() {
  static const KeyTable<BoundaryKeys> t = [] {
    KeyTable<BoundaryKeys> k("boundary[]", "gmsh only: u_i = 0 on a physical surface (at least one table is required).");
    k.text("surface", &BoundaryKeys::surface, "a physical surface of the mesh").required();
    k.custom(
         "fix", "list of strings", "fixed displacement components",
         [](const toml::node& n, const std::string& f, BoundaryKeys& b) {
           const toml::array& a = keys::read_array(n, f);
           for (std::size_t i = 0; i < a.size(); ++i) b.fix.push_back(keys::read_text(*a.get(i), keys::index_field(f, i)));
         },
         "", "\"x\", \"y\", \"z\" (at least one)")
        .required();
    return k;
  }();
  return t;
}

struct ProbeKeys {
  std::string surface;
};

const KeyTable<ProbeKeys>& probe_table() {
  static const KeyTable<ProbeKeys> t = [] {
    KeyTable<ProbeKeys> k("probe", "gmsh only: a surface whose mean displacement is a response.csv column.");
    k.text("surface", &ProbeKeys::surface, "a physical surface of the mesh");
    return k;
  }();
  return t;
}

struct LoadKeys {
  LoadControl control = LoadControl::pressure;
  const toml::node* path = nullptr;
  int steps = 20;
  std::vector<std::string> surfaces;
  std::optional<Vec3> cavity_mask;
};

std::vector<std::string> string_list(const toml::node& n, const std::string& f) {
  if (!n.is_array()) return {keys::read_text(n, f)};
  std::vector<std::string> out;
  const toml::array& a = keys::read_array(n, f);
  for (std::size_t i = 0; i < a.size(); ++i) out.push_back(keys::read_text(*a.get(i), keys::index_field(f, i)));
  return out;
}

const KeyTable<LoadKeys>& load_table() {
  static const KeyTable<LoadKeys> t = [] {
    KeyTable<LoadKeys> k("load", "Load control and its piecewise-linear path.");
    k.choice("control", &LoadKeys::control,
             Choices<LoadControl>{{{"pressure", LoadControl::pressure},
                                   {"volume", LoadControl::volume},
                                   {"stretch", LoadControl::stretch}},
                                  {}},
             "plate: stretch λ(t); cavities: follower pressure p(t) [MPa] or volume ratio V/V0(t)")
        .required()
        .custom(
            "path", "list of [t, value]", "the controlled value over time [s]",
            [](const toml::node& n, const std::string&, LoadKeys& l) { l.path = &n; }, "",
            "t from 0, increasing; values finite (stretch and volume ratio > 0)")
        .required()
        .integer("steps", &LoadKeys::steps, keys::closed_range(1, 1000000), "", "uniform output steps over the path")
        .custom(
            "surface", "string or list of strings", "gmsh only: the loaded cavity surface(s)",
            [](const toml::node& n, const std::string& f, LoadKeys& l) { l.surfaces = string_list(n, f); })
        .custom(
            "cavity_mask", "list of numbers", "gmsh only: components of the reported cavity volume",
            [](const toml::node& n, const std::string& f, LoadKeys& l) {
              const std::vector<double> v = keys::read_numbers(n, f, keys::closed_range(0, 1), 3, 3);
              l.cavity_mask = Vec3(v[0], v[1], v[2]);
            },
            "[1, 1, 1]", "3 entries, each [0, 1]");
    return k;
  }();
  return t;
}

const KeyTable<fe::NewtonOptions>& newton_table() {
  using O = fe::NewtonOptions;
  static const KeyTable<O> t = [] {
    KeyTable<O> k("solver", "");
    k.number("tolerance", &O::tolerance, keys::open_range(0, 1), "-", "‖R_free‖ ≤ tolerance · force scale")
        .integer("max_newton_iterations", &O::max_iterations, keys::closed_range(1, 1000), "-", "Newton iterations per sub-step")
        .renamed("max_iterations")
        .integer("max_krylov_iterations", &O::krylov_max, keys::closed_range(1, 100000), "-",
                 "GMRES iterations before a solve refactorizes and retries")
        .renamed("krylov_max")
        .integer("max_cutbacks", &O::max_cutbacks, keys::closed_range(0, 60), "-", "consecutive halvings of one output interval")
        .number("max_step_seconds", &O::max_step_seconds, keys::at_least(0), "s",
                "wall-time budget of one output interval's cut-backs (0: unlimited)")
        .integer("substeps", &O::initial_substeps, keys::closed_range(1, 1000000), "-", "sub-steps per output interval at the start")
        .flag("mixed_pressure", &O::mixed, "three-field (u, θ, p) iteration for laws with a volumetric modulus")
        .renamed("mixed")
        .choice("linear_solver", &O::solver,
                Choices<fe::SolverKind>{{{"auto", fe::SolverKind::automatic},
                                        {"cholmod", fe::SolverKind::cholmod},
                                        {"umfpack", fe::SolverKind::umfpack},
                                        {"petsc", fe::SolverKind::petsc}},
                                       {}},
                "linear solver: cholmod (sparse Cholesky, LU when it fails), umfpack (LU), petsc (GMRES + "
                "algebraic multigrid over MPI ranks); auto: petsc for meshes of quadratic tets from 1e5 free dofs on "
                "(faster than cholmod there, a quarter of its memory), cholmod otherwise and under volume control")
        .choice("petsc_preconditioner", &O::petsc_preconditioner,
                Choices<fe::PetscPreconditioner>{{{"auto", fe::PetscPreconditioner::automatic},
                                                  {"field-split", fe::PetscPreconditioner::field_split},
                                                  {"lu", fe::PetscPreconditioner::lu},
                                                  {"bddc", fe::PetscPreconditioner::bddc}},
                                                 {}},
                "petsc: field-split (the (u, p) Schur split with algebraic multigrid; linear memory), lu (MUMPS), or bddc "
                "(balancing domain decomposition, one subdomain per MPI rank factorized by MUMPS; on a given number of ranks "
                "Krylov counts flat in K/G and near-flat in mesh size; a direct solve's memory per subdomain); auto: lu under "
                "volume control, field-split otherwise")
        .choice("petsc_p_multigrid", &O::petsc_p_multigrid,
                Choices<fe::PMultigrid>{{{"auto", fe::PMultigrid::automatic}, {"on", fe::PMultigrid::on}, {"off", fe::PMultigrid::off}},
                                        {}},
                "petsc field-split on meshes with quadratic tets: the displacement block by the P2 -> P1 multigrid (on), "
                "BoomerAMG on the P2 block (off), or the multigrid replaced by BoomerAMG after a solve it fails (auto)")
        .number("petsc_augmentation", &O::petsc_augmentation, keys::at_least(0), "-",
                "petsc field-split: alpha of the augmented displacement block (a bulk modulus ~ alpha G kept there; 0: the "
                "plain split)")
        .default_text("10; 1 under the p-multigrid")
        .flag("petsc_nested_matrix", &O::petsc_nested_matrix,
              "petsc field-split under three-field elements: the system as a nest of its (u, p) blocks, the displacement "
              "block used in place (false: one matrix, of which the split extracts a copy)")
        .flag("petsc_current_modes", &O::petsc_current_modes,
              "petsc p-multigrid with a coarse solver that reads rigid-body modes (GAMG): those of the current positions "
              "(false: of the reference ones)")
        .flag("bddc_flux", &O::bddc_flux,
              "petsc bddc: the volume flux of the three-field elements on every face among the primal constraints")
        .text("petsc_options", &O::petsc_options,
              "PETSc options database entries for the petsc solver, e.g. \"-ksp_rtol 1e-10 -pc_type hypre\" (they override "
              "the keys above; a -pc_type replaces the preconditioner)")
        .flag("reuse_preconditioner", &O::reuse_preconditioner,
              "petsc: keep the preconditioner of an earlier tangent where its set-up outweighs its solve (a factorization, e.g. petsc_preconditioner = \"lu\"), while GMRES with it costs less than a new one")
        .flag("verbose", &O::verbose, "Newton iteration log on stderr");
    return k;
  }();
  return t;
}

struct SolverKeys {
  fe::NewtonOptions newton;
  fe::Formulation formulation = fe::Formulation::fbar;
};

const KeyTable<SolverKeys>& solver_table() {
  static const KeyTable<SolverKeys> t = [] {
    KeyTable<SolverKeys> k("solver", "Newton iteration and linear solver (the point and rve scenes' spelling).");
    k.include(newton_table(), &SolverKeys::newton)
        .choice("formulation", &SolverKeys::formulation,
                Choices<fe::Formulation>{{{"fbar", fe::Formulation::fbar}, {"standard", fe::Formulation::standard}}, {}},
                "hex8 volumetric treatment (mean-dilatation F-bar or plain Q1)");
    return k;
  }();
  return t;
}

struct OutputKeys {
  bool fields = true;
  std::vector<double> field_times;
};

const KeyTable<OutputKeys>& output_table() {
  static const KeyTable<OutputKeys> t = [] {
    KeyTable<OutputKeys> k("output", "Field output (fields/: XDMF + HDF5).");
    k.custom(
        "fields", "true/false or list of numbers",
        "true: every output step; false: none; [t1, ...]: snapshots at these times (added to the output steps)",
        [](const toml::node& n, const std::string& f, OutputKeys& o) {
          if (n.is_boolean()) {
            o.fields = keys::read_flag(n, f);
            return;
          }
          if (!n.is_array())
            throw InputError(f, keys::describe_value(n), "must be true, false or a list of times [t1, t2, ...]");
          o.field_times = keys::read_numbers(n, f, keys::at_least(0), 1);  // sorted once checked against the path
        },
        "true", "times within the load path", "s");
    return k;
  }();
  return t;
}

struct SceneKeysTop {
  std::string description;
};

const KeyTable<SceneKeysTop>& scene_table() {
  static const KeyTable<SceneKeysTop> t = [] {
    auto skip = [](const toml::node&, const std::string&, SceneKeysTop&) {};  // read by the table's own parser
    KeyTable<SceneKeysTop> k("", "A macro scene: structure, material, load path, solver and output.");
    k.text("description", &SceneKeysTop::description, "free text, copied to summary.json")
        .custom("geometry", "table", "the structure ([geometry] tables below)", skip).required()
        .custom("material", "table", "material of the structure (region 0), fibers given in the fiber frame (required but for shells)", skip)
        .custom("material_lower", "table", "actuator only: the stiffer lower half (y < 0)", skip)
        .custom("load", "table", "load control and path", skip).required()
        .custom("solver", "table", "Newton and linear-solver settings", skip)
        .custom("output", "table", "field output", skip)
        .custom("boundary", "list of tables", "gmsh only: constraints on physical surfaces", skip)
        .custom("probe", "table", "gmsh only: reported surface", skip)
        .custom("regions", "table", "gmsh only: a material table per physical volume", skip)
        .custom("device", "table", "device outputs (device.csv): Gmsh meshes; kind = \"tube\" and \"bending\" also generated tubes and actuators", skip)
        .custom("fibers", "list of tables", "fibers tied to the structure ([[fibers]] below)", skip)
        .custom("helix_tube", "table", "gmsh only: parameters of a tube with helical solid fibers, passed to its .geo", skip)
        .custom("contact", "table", "rigid obstacles against the structure and contact between its surfaces ([[contact.obstacles]], [[contact.pairs]], [[contact.self]])", skip)
        .custom("shell", "table", "shell only: section, fiber frame and edges", skip);
    return k;
  }();
  return t;
}

// --- Readers -----------------------------------------------------------------------------------

PiecewiseLinear read_path(const toml::node& node, const std::string& field, LoadControl control) {
  const toml::array& arr = keys::read_array(node, field);
  PiecewiseLinear f{{}, {}};
  for (std::size_t k = 0; k < arr.size(); ++k) {
    const std::string pf = keys::index_field(field, k);
    const std::vector<double> p = keys::read_numbers(*arr.get(k), pf, keys::any_value(), 2, 2);
    if (!f.t.empty() && !(p[0] > f.t.back())) throw InputError(pf + "[0]", format_number(p[0]), "times must increase");
    if (control != LoadControl::pressure && !(p[1] > 0.0))
      throw InputError(pf + "[1]", format_number(p[1]),
                       control == LoadControl::stretch ? "a stretch must be > 0" : "a volume ratio must be > 0");
    f.t.push_back(p[0]);
    f.v.push_back(p[1]);
  }
  if (f.t.size() < 2) throw InputError(field, keys::describe_value(node), "need at least two points [[0, v0], [t1, v1], ...]");
  if (f.t.front() != 0.0) throw InputError(field + "[0][0]", format_number(f.t.front()), "must start at t = 0");
  return f;
}

/// Reads `g` with the table of its type; a key of another type says which types it belongs to.
template <class O>
O read_geometry(const KeyTable<O>& t, const toml::table& g, const std::string& type) {
  for (const auto& [k, node] : g) {
    const std::string key(k.str());
    if (t.declares(key)) continue;
    std::string owners;
    for (const auto& [name, other] : std::vector<std::pair<std::string, std::vector<std::string>>>{
             {"tube", tube_table(false).names()}, {"actuator", tube_table(true).names()},
             {"sphere", sphere_table().names()}, {"plate", plate_table().names()}, {"gmsh", gmsh_table().names()},
             {"shell", shell_geometry_key_names()}})
      if (std::find(other.begin(), other.end(), key) != other.end()) owners += (owners.empty() ? "" : ", ") + name;
    if (!owners.empty())
      throw InputError("geometry." + key, keys::describe_value(node),
                       "not a key of geometry.type = \"" + type + "\" (only for " + owners + ")");
  }
  O o;
  t.read(g, "geometry", o);
  return o;
}

template <class O>
void set_common(const O& o, StructureSpec& s) {
  s.fiber_frame = o.fiber_frame;
  if constexpr (requires { o.tet10; }) s.tet10 = o.tet10;
}

void read_tube(const toml::table& g, const std::string& type, StructureSpec& s) {
  const bool actuator = type == "actuator";
  const TubeKeys o = read_geometry(tube_table(actuator), g, type);
  if (!(o.outer_radius > o.inner_radius))
    throw InputError("geometry.outer_radius", format_number(o.outer_radius),
                     "must exceed geometry.inner_radius = " + format_number(o.inner_radius));
  if (o.sweep_deg != 90.0 && o.sweep_deg != 360.0)
    throw InputError("geometry.sweep_deg", format_number(o.sweep_deg), "only 90 (quarter) or 360 are supported");
  if (o.plane_strain && o.cap_thickness > 0.0)
    throw InputError("geometry.plane_strain", "true", "incompatible with geometry.cap_thickness = " + format_number(o.cap_thickness));
  s.kind = actuator ? StructureKind::actuator : StructureKind::tube;
  s.tube = o;
  s.plane_strain = o.plane_strain;
  set_common(o, s);
}

void read_boundaries(const toml::table& scene, ImportedSpec& im) {
  const toml::node* node = scene.get("boundary");
  const toml::array* arr = node ? &keys::read_array(*node, "boundary") : nullptr;
  if (!arr || arr->empty())
    throw InputError("boundary", "", "the body is not constrained: give [[boundary]] tables with surface and fix = [\"x\", ...]");
  for (std::size_t k = 0; k < arr->size(); ++k) {
    const std::string field = keys::index_field("boundary", k);
    BoundaryKeys b;
    boundary_table().read(keys::read_table(*arr->get(k), field), field, b);
    ImportedSpec::Fix f;
    f.surface = b.surface;
    if (!im.mesh.has_surface(f.surface))
      throw InputError(field + ".surface", "\"" + f.surface + "\"", "no physical surface of that name in the mesh");
    for (std::size_t i = 0; i < b.fix.size(); ++i) {
      const std::string& c = b.fix[i];
      if (c != "x" && c != "y" && c != "z")
        throw InputError(keys::index_field(field + ".fix", i), "\"" + c + "\"", "components are \"x\", \"y\", \"z\"");
      f.components[c[0] - 'x'] = true;
    }
    if (b.fix.empty())
      throw InputError(field + ".fix", "[]", "fixes no component: the body is not constrained on this surface");
    im.fixed.push_back(f);
  }
}

/// [geometry] type = "gmsh": the mesh, constraints on physical surfaces and region materials.
void read_imported(const toml::table& scene, const toml::table& g, const std::filesystem::path& scene_file,
                   const std::filesystem::path& mesh_cache, StructureSpec& s) {
  const GmshKeys o = read_geometry(gmsh_table(), g, "gmsh");
  s.kind = StructureKind::imported;
  s.fiber_frame = o.fiber_frame;
  const toml::node* helix = scene.get("helix_tube");
  if (helix && o.geo.empty() && !o.file.empty())
    throw InputError("helix_tube", "", "only with geometry.geo (the .geo reads the tube's parameters)");
  auto geo_parameters = helix ? helix_tube_geo_parameters(read_helix_tube(*helix)) : std::vector<std::pair<std::string, double>>{};
  if (!o.geo_parameters.empty() && o.geo.empty())
    throw InputError("geometry.geo_parameters", "", "only with geometry.geo");
  geo_parameters.insert(geo_parameters.end(), o.geo_parameters.begin(), o.geo_parameters.end());
  const std::filesystem::path path = scene_mesh_file(o.file, o.geo, o.mesh_size, scene_file, mesh_cache, 3, geo_parameters);
  auto& im = s.imported;
  im.mesh = io::read_gmsh(path, "geometry.file", helix != nullptr);  // curved edges on thin fibers may invert tets
  im.file = path.string();
  read_boundaries(scene, im);
  ProbeKeys probe;
  probe_table().read_optional(scene.get("probe"), "probe", probe);
  if (!probe.surface.empty() && !im.mesh.has_surface(probe.surface))
    throw InputError("probe.surface", "\"" + probe.surface + "\"", "no physical surface of that name in the mesh");
  im.probe_surface = probe.surface;
  if (const toml::node* rn = scene.get("regions"))
    for (const auto& [name, node] : keys::read_table(*rn, "regions")) {
      const std::string field = "regions." + std::string(name.str());
      const toml::table& t = keys::read_table(node, field);
      if (std::find(im.mesh.region_names.begin(), im.mesh.region_names.end(), std::string(name.str())) ==
          im.mesh.region_names.end())
        throw InputError(field, "", "no physical volume of that name in " + path.string());
      im.region_materials[std::string(name.str())] = build_material(io::parse_material(t, field));
    }
}

void read_geometry_table(const toml::table& scene, const std::filesystem::path& scene_file,
                         const std::filesystem::path& mesh_cache, StructureSpec& s) {
  const toml::table& g = keys::read_table(*scene.get("geometry"), "geometry");
  const toml::node* tn = g.get("type");
  if (!tn) throw InputError("geometry.type", "", "missing: structure kind, " + kTypes);
  const std::string type = keys::read_text(*tn, "geometry.type");
  if (type == "tube" || type == "actuator") {
    read_tube(g, type, s);
  } else if (type == "sphere") {
    const SphereKeys o = read_geometry(sphere_table(), g, type);
    s.kind = StructureKind::sphere;
    s.sphere = o;
    set_common(o, s);
  } else if (type == "plate") {
    const PlateKeys o = read_geometry(plate_table(), g, type);
    s.kind = StructureKind::plate;
    s.plate = o;
    set_common(o, s);
  } else if (type == "gmsh") {
    read_imported(scene, g, scene_file, mesh_cache, s);
  } else if (type == "shell") {
    read_shell(scene, g, s, scene_file, mesh_cache);
  } else {
    throw InputError("geometry.type", keys::describe_value(*tn), "must be " + kTypes + keys::did_you_mean(type, {"tube", "actuator", "sphere", "plate", "gmsh", "shell"}));
  }
  for (const char* key : {"boundary", "probe", "regions", "helix_tube"})
    if (type != "gmsh" && scene.contains(key)) throw InputError(key, "", "only for geometry.type = \"gmsh\"");
  if (type != "shell" && scene.contains("shell")) throw InputError("shell", "", "only for geometry.type = \"shell\"");
}

void read_materials(const toml::table& scene, StructureSpec& s) {
  if (s.kind == StructureKind::shell) {  // each layer has its law
    if (scene.contains("material")) throw InputError("material", "", "a shell's laws are its layers' ([[shell.layers]] material)");
    return;
  }
  if (!scene.contains("material")) throw InputError("material", "", "missing: material of the structure");
  s.material = build_material(io::parse_material(keys::read_table(*scene.get("material"), "material"), "material"));
  if (const toml::node* lower = scene.get("material_lower")) {
    if (s.kind != StructureKind::actuator) throw InputError("material_lower", "", "only for geometry.type = \"actuator\"");
    s.material_region1 = build_material(io::parse_material(keys::read_table(*lower, "material_lower"), "material_lower"));
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

void read_load(const toml::table& scene, MacroScene& m) {
  StructureSpec& s = m.spec;
  LoadKeys l;
  load_table().read(keys::read_table(*scene.get("load"), "load"), "load", l);
  if (s.kind == StructureKind::imported) {
    for (const std::string& n : l.surfaces)
      if (!s.imported.mesh.has_surface(n))
        throw InputError("load.surface", "\"" + n + "\"", "no physical surface of that name in the mesh");
    if (l.surfaces.empty() && l.control != LoadControl::stretch)
      throw InputError("load.surface", "(missing)",
                       "pressure and volume control on a Gmsh mesh load a physical surface: name it (e.g. surface = \"inner\")");
    s.imported.load_surfaces = l.surfaces;
    if (l.cavity_mask) s.imported.cavity_mask = *l.cavity_mask;
  } else if (!l.surfaces.empty() || l.cavity_mask) {
    throw InputError(l.cavity_mask ? "load.cavity_mask" : "load.surface", "",
                     "only for geometry.type = \"gmsh\" (generated structures load their cavity)");
  }
  s.control = l.control;
  if ((s.kind == StructureKind::plate) != (s.control == LoadControl::stretch))
    throw InputError("load.control",
                     s.control == LoadControl::stretch ? "\"stretch\"" : s.control == LoadControl::volume ? "\"volume\"" : "\"pressure\"",
                     s.kind == StructureKind::plate ? "a plate is driven by stretch"
                                                    : "a structure with a cavity is driven by pressure or volume");
  s.load = read_path(*l.path, "load.path", s.control);
  for (std::size_t k = 0; k < m.field_times.size(); ++k)
    if (m.field_times[k] > s.load.end_time())
      throw InputError(keys::index_field("output.fields", k), format_number(m.field_times[k]),
                       "outside the load path [0, " + format_number(s.load.end_time()) + "]");
  std::sort(m.field_times.begin(), m.field_times.end());
  m.times = output_times(s.load.end_time(), l.steps, m.field_times);
}

void read_solver(const toml::table& scene, MacroScene& m) {
  const toml::node* node = scene.get("solver");
  if (!node) return;
  const toml::table& sv = keys::read_table(*node, "solver");
  if (const toml::node* kt = sv.get("krylov_tolerance"))
    throw InputError("solver.krylov_tolerance", keys::describe_value(*kt),
                     "not a macro setting: the GMRES tolerance follows the Newton residual (forcing term); "
                     "limit max_krylov_iterations instead");
  SolverKeys k{m.newton, m.spec.formulation};
  solver_table().read(sv, "solver", k);
  fe::check_petsc_options(k.newton.petsc_options);  // nothing of a shared scene writes outside --out
  m.newton = k.newton;
  m.spec.formulation = k.formulation;
}

void read_output(const toml::table& scene, MacroScene& m) {
  OutputKeys o;
  output_table().read_optional(scene.get("output"), "output", o);
  m.fields = o.fields;
  m.field_times = o.field_times;
}

/// The linear solver the scene's `auto` will be (fe::automatic_solver) from the size estimate, before the
/// mesh is built: the memory guard below counts a factor only on the direct path. (The estimate counts 3
/// dofs per node, constraints included: within a few per cent above the threshold the run may still
/// take CHOLMOD, whose factor is then ~1 GiB.)
fe::SolverKind automatic_solver_of(const toml::table& scene, const MacroScene& m) {
  const StructureSpec& s = m.spec;
  const bool quadratic_tets = s.kind == StructureKind::imported ? s.imported.mesh.hexes.empty() && !s.imported.mesh.tets.empty() : s.tet10;
  if (m.newton.solver != fe::SolverKind::automatic) return m.newton.solver;
  LoadKeys l;  // (read_load reads it again after the guard; its control is all the choice needs of it)
  load_table().read(keys::read_table(*scene.get("load"), "load"), "load", l);
  return fe::automatic_solver(m.newton, long(estimate_size(s).dofs), quadratic_tets, l.control == LoadControl::volume);
}

}  // namespace

bool MacroScene::fields_at(double t) const {
  if (!fields) return false;
  if (field_times.empty()) return true;
  const double tol = 1e-9 * (times.empty() ? 1.0 : std::max(1.0, times.back()));
  return std::any_of(field_times.begin(), field_times.end(), [&](double f) { return std::abs(f - t) <= tol; });
}

MacroScene parse_macro_scene(const toml::table& scene, const std::filesystem::path& scene_file,
                             const std::filesystem::path& mesh_cache) {
  SceneKeysTop top;
  scene_table().read(scene, "", top);
  MacroScene m;
  read_geometry_table(scene, scene_file, mesh_cache, m.spec);
  m.device = read_device(scene.get("device"));
  const bool generated_tube = m.spec.kind == StructureKind::tube || m.spec.kind == StructureKind::actuator;
  const bool gauge = m.device.kind == DeviceKind::tube || m.device.kind == DeviceKind::bending;
  if (m.device.kind != DeviceKind::none && m.spec.kind != StructureKind::imported && !(generated_tube && gauge))
    throw InputError("device.kind", "", generated_tube ? "a generated tube or actuator takes kind = \"tube\" or \"bending\""
                                                       : "only for geometry.type = \"gmsh\", \"tube\" or \"actuator\"");
  m.spec.fibers = read_fibers(scene.get("fibers"));  // tied to the mesh (and checked against it) when it is built
  read_fiber_curve_groups(m.spec.fibers, scene_file, m.spec.imported.file, mesh_cache);
  m.spec.contact = read_contact(scene.get("contact"));
  // The linear solver first: the memory estimate holds a factorization only on the direct path.
  read_solver(scene, m);
  m.spec.factorized_solver = automatic_solver_of(scene, m) != fe::SolverKind::petsc;
  // Before the materials and anything else: a 1000 x 1000 x 10 box is refused with its memory estimate.
  refuse_if_too_large(m.spec, double(softhom::available_memory_bytes()), size_field(m.spec));
  read_materials(scene, m.spec);
  read_output(scene, m);  // before the load: the field times join the output times
  read_load(scene, m);
  return m;
}

std::vector<keys::TableDoc> macro_scene_tables() {
  std::vector<keys::TableDoc> tables{scene_table().describe(), tube_table(false).describe(), tube_table(true).describe(), sphere_table().describe(),
           plate_table().describe(), gmsh_table().describe(), boundary_table().describe(), probe_table().describe(),
           load_table().describe(), solver_table().describe(), output_table().describe(),
          device_table().describe(), fibers_table_doc(), helix_tube_table().describe()};
  for (keys::TableDoc& t : contact_tables()) tables.push_back(std::move(t));
  const std::vector<keys::TableDoc> shells = shell_scene_tables();
  tables.insert(tables.end(), shells.begin(), shells.end());
  return tables;
}

}  // namespace softhom::macro
