// softhom macro: structure-scale nonlinear FE (tubes, balloons, plates, bending actuators).
//
// Scene layout (every key checked; errors name the TOML path):
//   [geometry] type = "tube" | "sphere" | "plate" | "actuator", sizes and cell counts (see
//              macro/geometry.hpp), plane_strain, fiber_frame = "global" | "cylindrical" | "spherical",
//              elements = "hex8" | "tet10" (generated hexes split into quadratic tets);
//              or type = "gmsh", file = "mesh.msh" (MSH 4.1, relative to the scene file)
//   gmsh only: [[boundary]] surface = "<physical surface>", fix = ["x", "y", "z"] (u_i = 0);
//              [load] surface = "<name>" or ["a", "b"] (follower pressure / cavity), cavity_mask = [1, 1, 0];
//              [probe] surface = "<name>" (mean displacement in response.csv);
//              [regions.<physical volume>] a material table for that region ([material] elsewhere)
//   [material] (io::parse_material; fibers given in the fiber frame), [material_lower] for actuators
//   [load]     control = "pressure" | "volume" | "stretch", path = [[t, value], ...], steps = N
//   [solver]   tolerance, max_iterations, max_cutbacks, substeps, formulation, linear_solver, verbose
//   [output]   fields = true
#include <chrono>
#include <iostream>

#include "softhom/io/gmsh.hpp"

#include "commands.hpp"
#include "run_control.hpp"
#include "scene_source.hpp"
#include "softhom/io/fields.hpp"
#include "softhom/io/files.hpp"
#include "softhom/io/scene.hpp"
#include "softhom/io/summary.hpp"
#include "softhom/macro/structures.hpp"
#include "softhom/materials/errors.hpp"

namespace softhom::app {
namespace {

PiecewiseLinear parse_path(const toml::table& t, const std::string& path) {
  const auto* arr = t["path"].as_array();
  if (!arr || arr->empty()) throw InputError(path + ".path", "", "need [[t0, v0], [t1, v1], ...]");
  PiecewiseLinear f{{}, {}};
  for (std::size_t k = 0; k < arr->size(); ++k) {
    const auto* pt = (*arr)[k].as_array();
    const std::string field = path + ".path[" + std::to_string(k) + "]";
    if (!pt || pt->size() != 2) throw InputError(field, "", "each point is [t, value]");
    const auto tv = (*pt)[0].value<double>(), vv = (*pt)[1].value<double>();
    if (!tv || !vv) throw InputError(field, "", "entries must be numbers");
    if (!f.t.empty() && !(*tv > f.t.back())) throw InputError(field, std::to_string(*tv), "times must increase");
    f.t.push_back(*tv);
    f.v.push_back(*vv);
  }
  if (f.t.front() != 0.0) throw InputError(path + ".path[0]", std::to_string(f.t.front()), "must start at t = 0");
  if (f.t.size() < 2) throw InputError(path + ".path", "", "need at least two points");
  return f;
}

int get_int(const toml::table& t, const char* key, const std::string& path, int fallback) {
  const double v = io::get_number_or(t, key, path, fallback);
  if (v != std::floor(v) || v < 1) throw InputError(path + "." + key, std::to_string(v), "must be a positive integer");
  // int(v) of a larger value is undefined (it produced negative cell counts and a failed allocation).
  if (v > 1e7) throw InputError(path + "." + key, std::to_string(v), "too large (at most 1e7)");
  return int(v);
}

struct MacroScene {
  macro::StructureSpec spec;
  fe::NewtonOptions newton;
  std::vector<double> times;
  bool fields = true;
};

std::vector<std::string> string_list(const toml::node_view<const toml::node>& node, const std::string& field) {
  std::vector<std::string> out;
  if (const auto v = node.value<std::string>()) {
    out.push_back(*v);
  } else if (const auto* arr = node.as_array()) {
    for (const auto& e : *arr) {
      const auto v = e.value<std::string>();
      if (!v) throw InputError(field, "", "entries must be strings");
      out.push_back(*v);
    }
  } else if (node) {
    throw InputError(field, "", "expected a string or an array of strings");
  }
  return out;
}

Vec3 vec3_of(const toml::node_view<const toml::node>& node, const std::string& field) {
  const auto* arr = node.as_array();
  if (!arr || arr->size() != 3) throw InputError(field, "", "need three numbers");
  Vec3 v;
  for (int d = 0; d < 3; ++d) {
    const auto x = (*arr)[d].value<double>();
    if (!x) throw InputError(field, "", "entries must be numbers");
    v[d] = *x;
  }
  return v;
}

/// [geometry] type = "gmsh": the mesh, constraints on physical surfaces and region materials.
void parse_imported(const toml::table& scene, const toml::table& g, const std::filesystem::path& scene_file,
                    macro::StructureSpec& s) {
  s.kind = macro::StructureKind::imported;
  const std::string file = io::get_string_or(g, "file", "geometry", "");
  if (file.empty()) throw InputError("geometry.file", "", "a gmsh geometry needs file = \"mesh.msh\"");
  std::filesystem::path path(file);
  if (path.is_relative() && !scene_file.empty()) path = scene_file.parent_path() / path;
  if (!std::filesystem::exists(path)) throw InputError("geometry.file", path.string(), "no such file");
  auto& im = s.imported;
  im.mesh = io::read_gmsh(path);
  if (const auto* arr = scene["boundary"].as_array()) {
    for (std::size_t k = 0; k < arr->size(); ++k) {
      const std::string field = "boundary[" + std::to_string(k) + "]";
      const auto* t = (*arr)[k].as_table();
      if (!t) throw InputError(field, "", "expected [[boundary]] tables");
      io::check_keys(*t, field, {"surface", "fix"});
      macro::ImportedSpec::Fix f;
      f.surface = io::get_string_or(*t, "surface", field, "");
      if (f.surface.empty()) throw InputError(field + ".surface", "", "missing physical surface name");
      for (const std::string& c : string_list((*t)["fix"], field + ".fix")) {
        if (c != "x" && c != "y" && c != "z") throw InputError(field + ".fix", c, "components are \"x\", \"y\", \"z\"");
        f.components[c[0] - 'x'] = true;
      }
      im.fixed.push_back(f);
    }
  } else if (scene["boundary"]) {
    throw InputError("boundary", "", "expected [[boundary]] tables");
  }
  if (const auto* probe = scene["probe"].as_table()) {
    io::check_keys(*probe, "probe", {"surface"});
    im.probe_surface = io::get_string_or(*probe, "surface", "probe", "");
  }
  if (const auto* regions = scene["regions"].as_table())
    for (const auto& [name, node] : *regions) {
      const std::string field = "regions." + std::string(name.str());
      const auto* t = node.as_table();
      if (!t) throw InputError(field, "", "expected a material table");
      if (std::find(im.mesh.region_names.begin(), im.mesh.region_names.end(), std::string(name.str())) ==
          im.mesh.region_names.end())
        throw InputError(field, "", "no physical volume of that name in " + path.string());
      im.region_materials[std::string(name.str())] = build_material(io::parse_material(*t, field));
    }
}

MacroScene parse_macro_scene(const toml::table& scene, const std::filesystem::path& scene_file = {}) {
  io::check_keys(scene, "", {"description", "geometry", "material", "material_lower", "load", "solver", "output",
                             "boundary", "probe", "regions"});
  MacroScene m;
  auto& s = m.spec;
  const auto* g = scene["geometry"].as_table();
  if (!g) throw InputError("geometry", "", "missing [geometry] table");
  const std::string type = io::get_string_or(*g, "type", "geometry", "");
  io::check_keys(*g, "geometry",
                 {"type", "inner_radius", "outer_radius", "length", "radial_cells", "circumferential_cells",
                  "axial_cells", "sweep_deg", "cap_thickness", "cap_axial_cells", "cap_core_cells", "plane_strain",
                  "thickness", "patch_cells", "size", "cells", "fiber_frame", "elements", "file"});
  if (type == "tube" || type == "actuator") {
    s.kind = type == "tube" ? macro::StructureKind::tube : macro::StructureKind::actuator;
    auto& t = s.tube;
    t.inner_radius = io::get_number(*g, "inner_radius", "geometry");
    t.outer_radius = io::get_number(*g, "outer_radius", "geometry");
    t.length = io::get_number(*g, "length", "geometry");
    t.radial_cells = get_int(*g, "radial_cells", "geometry", 2);
    t.circumferential_cells = get_int(*g, "circumferential_cells", "geometry", 16);
    t.axial_cells = get_int(*g, "axial_cells", "geometry", 1);
    t.sweep_deg = io::get_number_or(*g, "sweep_deg", "geometry", 360.0);
    t.cap_thickness = io::get_number_or(*g, "cap_thickness", "geometry", 0.0);
    t.cap_axial_cells = get_int(*g, "cap_axial_cells", "geometry", 1);
    t.cap_core_cells = get_int(*g, "cap_core_cells", "geometry", 2);
    s.plane_strain = (*g)["plane_strain"].value_or(false);
  } else if (type == "sphere") {
    s.kind = macro::StructureKind::sphere;
    s.sphere.inner_radius = io::get_number(*g, "inner_radius", "geometry");
    s.sphere.thickness = io::get_number(*g, "thickness", "geometry");
    s.sphere.radial_cells = get_int(*g, "radial_cells", "geometry", 2);
    s.sphere.patch_cells = get_int(*g, "patch_cells", "geometry", 8);
  } else if (type == "plate") {
    s.kind = macro::StructureKind::plate;
    const auto* size = (*g)["size"].as_array();
    const auto* cells = (*g)["cells"].as_array();
    if (!size || size->size() != 3) throw InputError("geometry.size", "", "need [Lx, Ly, Lz]");
    if (!cells || cells->size() != 3) throw InputError("geometry.cells", "", "need [nx, ny, nz]");
    for (int d = 0; d < 3; ++d) {
      s.plate.size[d] = (*size)[d].value<double>().value_or(-1.0);
      const double c = (*cells)[d].value<double>().value_or(0.0);
      if (!(c >= 1.0 && c <= 1e7 && c == std::floor(c)))
        throw InputError("geometry.cells", std::to_string(c), "cell counts must be integers in [1, 1e7]");
      s.plate.cells[d] = int(c);
    }
  } else if (type == "gmsh") {
    parse_imported(scene, *g, scene_file, s);
  } else {
    throw InputError("geometry.type", type, "expected tube, sphere, plate, actuator or gmsh");
  }
  if (type != "gmsh" && (scene["boundary"] || scene["probe"] || scene["regions"]))
    throw InputError(scene["boundary"] ? "boundary" : scene["probe"] ? "probe" : "regions", "",
                     "only for geometry.type = \"gmsh\"");
  const std::string elements = io::get_string_or(*g, "elements", "geometry", "hex8");
  if (elements == "tet10") s.tet10 = true;
  else if (elements != "hex8") throw InputError("geometry.elements", elements, "expected hex8 or tet10");
  if (type == "gmsh" && g->contains("elements"))
    throw InputError("geometry.elements", elements, "an imported mesh keeps its own elements");
  const std::string frame = io::get_string_or(*g, "fiber_frame", "geometry", "global");
  if (frame == "global") s.fiber_frame = macro::FiberFrame::global;
  else if (frame == "cylindrical") s.fiber_frame = macro::FiberFrame::cylindrical;
  else if (frame == "spherical") s.fiber_frame = macro::FiberFrame::spherical;
  else throw InputError("geometry.fiber_frame", frame, "expected global, cylindrical or spherical");

  const auto* mat = scene["material"].as_table();
  if (!mat) throw InputError("material", "", "missing [material] table");
  s.material = build_material(io::parse_material(*mat, "material"));
  if (const auto* lower = scene["material_lower"].as_table())
    s.material_region1 = build_material(io::parse_material(*lower, "material_lower"));

  const auto* load = scene["load"].as_table();
  if (!load) throw InputError("load", "", "missing [load] table");
  io::check_keys(*load, "load", {"control", "path", "steps", "surface", "cavity_mask"});
  if (s.kind == macro::StructureKind::imported) {
    s.imported.load_surfaces = string_list((*load)["surface"], "load.surface");
    if ((*load)["cavity_mask"]) s.imported.cavity_mask = vec3_of((*load)["cavity_mask"], "load.cavity_mask");
  } else if (load->contains("surface") || load->contains("cavity_mask")) {
    throw InputError("load.surface", "", "only for geometry.type = \"gmsh\" (generated structures load their cavity)");
  }
  const std::string control = io::get_string_or(*load, "control", "load", "");
  if (control == "pressure") s.control = macro::LoadControl::pressure;
  else if (control == "volume") s.control = macro::LoadControl::volume;
  else if (control == "stretch") s.control = macro::LoadControl::stretch;
  else throw InputError("load.control", control, "expected pressure, volume or stretch");
  s.load = parse_path(*load, "load");
  const int steps = get_int(*load, "steps", "load", 20);
  for (int k = 1; k <= steps; ++k) m.times.push_back(s.load.end_time() * k / steps);

  if (const auto* sv = scene["solver"].as_table()) {
    io::check_keys(*sv, "solver", {"tolerance", "max_iterations", "max_cutbacks", "substeps", "formulation", "linear_solver", "verbose"});
    m.newton.tolerance = io::get_number_or(*sv, "tolerance", "solver", m.newton.tolerance);
    if (!(m.newton.tolerance > 0 && m.newton.tolerance < 1))
      throw InputError("solver.tolerance", std::to_string(m.newton.tolerance), "must lie in (0, 1)");
    m.newton.max_iterations = get_int(*sv, "max_iterations", "solver", m.newton.max_iterations);
    m.newton.max_cutbacks = int(io::get_number_or(*sv, "max_cutbacks", "solver", m.newton.max_cutbacks));
    m.newton.initial_substeps = get_int(*sv, "substeps", "solver", 1);
    m.newton.verbose = (*sv)["verbose"].value_or(false);  // Newton iteration log on stderr
    const std::string f = io::get_string_or(*sv, "formulation", "solver", "fbar");
    if (f == "fbar") s.formulation = fe::Formulation::fbar;
    else if (f == "standard") s.formulation = fe::Formulation::standard;
    else throw InputError("solver.formulation", f, "expected fbar or standard");
    const std::string ls = io::get_string_or(*sv, "linear_solver", "solver", "auto");
    if (ls == "auto") m.newton.solver = fe::SolverKind::automatic;
    else if (ls == "cholmod") m.newton.solver = fe::SolverKind::cholmod;
    else if (ls == "umfpack") m.newton.solver = fe::SolverKind::umfpack;
    else throw InputError("solver.linear_solver", ls, "expected auto, cholmod or umfpack");
  }
  if (const auto* out = scene["output"].as_table()) {
    io::check_keys(*out, "output", {"fields"});
    m.fields = (*out)["fields"].value_or(true);
  }
  return m;
}

io::UnstructuredMesh field_mesh(const fe::Mesh& mesh) {
  io::UnstructuredMesh out;
  for (const Vec3& x : mesh.nodes) out.coordinates.insert(out.coordinates.end(), {x[0], x[1], x[2]});
  if (!mesh.hexes.empty() && !mesh.tets.empty())
    throw InputError("output.fields", "true", "field output of meshes mixing hexahedra and tetrahedra is not supported");
  for (const fe::Hex& h : mesh.hexes) out.connectivity.insert(out.connectivity.end(), h.begin(), h.end());
  for (const fe::Tet10& t : mesh.tets) {
    // XDMF/VTK Tetrahedron_10 orders the last two mid-edge nodes differently (tet10.hpp).
    long vtk[10];
    for (int a = 0; a < 10; ++a) vtk[fe::kTet10ToVtk[a]] = t[a];
    out.connectivity.insert(out.connectivity.end(), vtk, vtk + 10);
  }
  out.cell_type = mesh.tets.empty() ? io::CellType::hexa8 : io::CellType::tetra10;
  return out;
}

// Field names follow the response vocabulary of every subcommand (files.hpp): sigma is the Cauchy stress.
void write_fields(io::FieldWriter& w, const fe::Simulation& sim) {
  const fe::ElementFields f = sim.element_fields();
  w.begin_step(sim.time());
  w.add("displacement", sim.displacement(), 3, io::Centering::node, "mm");
  w.add("sigma", f.cauchy, 9, io::Centering::cell, "MPa");
  w.add("von_mises", f.von_mises, 1, io::Centering::cell, "MPa");
  w.add("J", f.J, 1, io::Centering::cell, "1");
  w.add("fiber_direction", f.fiber, 3, io::Centering::cell, "1");
  w.end_step();
}

// The structure's probe columns in the shared vocabulary: time is `t` as in every response.csv.
std::vector<std::string> response_columns(const macro::Structure& structure) {
  std::vector<std::string> columns = macro::probe_names(structure);
  for (auto& c : columns)
    if (c == "time") c = "t";
  return columns;
}

}  // namespace

int run_macro(const CommandOptions& options) {
  const auto wall_start = std::chrono::steady_clock::now();
  const LoadedScene scene = load_scene_or_default(options, "macro_tube_plane_strain");
  MacroScene ms = parse_macro_scene(scene.table, scene.file);
  const macro::Structure structure = macro::build_structure(ms.spec);
  fe::Simulation sim(structure.model, ms.newton);
  const std::string tag = "[macro " + scene.name + "] ";
  if (!options.quiet)
    std::cerr << tag << structure.model.mesh.num_hexes() << " hex8 + " << structure.model.mesh.tets.size() << " tet10, "
              << sim.num_free_dofs() << " free dofs, "
              << fe::to_string(sim.solver_kind()) << "\n";

  io::ProgressiveCsv table(options.out / "response.csv", response_columns(structure));
  table.add_row(macro::probe_values(structure, sim));
  std::unique_ptr<io::FieldWriter> writer;
  if (ms.fields) {
    writer = std::make_unique<io::FieldWriter>(options.out / "fields", field_mesh(structure.model.mesh));
    writer->set_attribute("frame", "global Cartesian frame of the structure's mesh (x, y, z); tensors row-major");
    write_fields(*writer, sim);
  }
  std::string error;
  std::size_t done = 0;
  Progress progress(options.quiet);
  for (double t : ms.times) {
    if (stop_requested()) break;  // between output times; the Newton loops poll inside a step
    const fe::AdvanceResult step = sim.advance_to(t);
    if (!step.reached()) {
      error = step.message;
      break;
    }
    table.add_row(macro::probe_values(structure, sim));
    if (writer) write_fields(*writer, sim);
    ++done;
    progress.update(tag + "t = " + format_number(t) + " / " + format_number(ms.times.back()) + " (" +
                    std::to_string(step.counts.newton_iterations) + " Newton iterations in " +
                    std::to_string(step.substeps) + " sub-steps, " + std::to_string(step.counts.cutbacks) +
                    " cut-backs)");
    raise_test_signal_after(done);
  }
  const bool completed = error.empty() && done == ms.times.size();
  if (!completed && stop_requested()) error = interruption_message();
  progress.finish();
  for (const auto& line : sim.stats().log)
    if (!options.quiet) std::cerr << tag << line << "\n";
  table.flush();
  if (writer) writer->close();

  const fe::RunStats st = sim.stats();
  nlohmann::json summary = io::summary_base("macro", scene.file, scene.table);
  summary["material"] = ms.spec.material->describe();
  io::set_run_status(summary, completed, error);
  summary["columns"] = io::columns_json(table.table().columns());
  summary["output_steps"] = done;
  summary["steps"] = st.steps;
  summary["newton_iterations"] = st.newton_iterations;
  summary["cutbacks"] = st.cutbacks;
  summary["line_search_backtracks"] = st.line_search_backtracks;
  summary["elements"] = structure.model.mesh.num_elements();
  summary["dofs"] = sim.num_free_dofs();
  summary["linear_solver"] = fe::to_string(sim.solver_kind());
  summary["assembly_time_s"] = st.assembly_time;
  summary["analysis_time_s"] = st.linear.analysis;
  summary["factorization_time_s"] = st.linear.factorization;
  summary["solve_time_s"] = st.linear.solve;
  summary["factorizations"] = st.linear.factorizations;
  summary["factorization_gflop"] = st.linear.flops / 1e9;
  summary["factor_nonzeros"] = st.linear.factor_nnz;
  summary["krylov_iterations"] = st.krylov_iterations;
  summary["krylov_time_s"] = st.krylov_time;
  summary["peak_memory_bytes"] = io::peak_memory_bytes();
  summary["warnings"] = st.log;
  summary["wall_time_s"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  io::write_summary(options.out, summary);
  if (!completed) {
    std::cerr << "softhom macro: stopped early: " << error << "\nsofthom macro: " << table.rows()
              << " converged rows kept in " << table.path().string() << "\n";
    return run_exit_code(false);
  }
  if (!options.quiet)
    std::cerr << "softhom macro: " << st.steps << " steps, " << st.newton_iterations << " Newton iterations → "
              << options.out.string() << "\n";
  return 0;
}

}  // namespace softhom::app
