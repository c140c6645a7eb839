// softhom macro: structure-scale nonlinear FE (tubes, balloons, plates, bending actuators).
//
// The scene (geometry, material, load path, solver, output) is parsed by macro::parse_macro_scene
// (macro/scene.hpp, every key declared there); this file wires the run and its outputs.
#include <chrono>
#include <iostream>

#include "commands.hpp"
#include "run_control.hpp"
#include "scene_source.hpp"
#include "softhom/io/fields.hpp"
#include "softhom/io/files.hpp"
#include "softhom/core/mpi.hpp"
#include "softhom/io/scene.hpp"
#include "softhom/io/summary.hpp"
#include "softhom/macro/devices.hpp"
#include "softhom/macro/mesh_generation.hpp"
#include "softhom/macro/scene.hpp"
#include "softhom/macro/structures.hpp"
#include "softhom/materials/errors.hpp"

namespace softhom::app {
namespace {

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
  return run_macro_scene(options, load_scene_or_default(options, "macro_tube_plane_strain"));
}

int run_macro_scene(const CommandOptions& given, const LoadedScene& scene) {
  // Under mpirun every rank runs the same (replicated) Newton iteration and shares the petsc linear
  // solver; rank 0 alone writes response.csv, device.csv, the fields and summary.json, and reports progress.
  const bool root = mpi::world_rank() == 0;
  CommandOptions options = given;
  if (!root) options.quiet = true;
  const auto wall_start = std::chrono::steady_clock::now();
  macro::MacroScene ms = macro::parse_macro_scene(scene.table, scene.file, macro::mesh_cache_dir(options.out));
  const macro::Structure structure = macro::build_structure(ms.spec);
  ms.spec.imported.mesh = fe::Mesh{};  // built into structure.model: not kept twice for the run
  fe::Simulation sim(structure.model, ms.newton);
  const std::string tag = "[macro " + scene.name + "] ";
  if (!options.quiet)
    std::cerr << tag << structure.model.mesh.num_hexes() << " hex8 + " << structure.model.mesh.tets.size() << " tet10, "
              << sim.num_free_dofs() << " free dofs, "
              << fe::to_string(sim.solver_kind()) << "\n";

  std::unique_ptr<io::ProgressiveCsv> table_on_root;
  if (root) table_on_root = std::make_unique<io::ProgressiveCsv>(options.out / "response.csv", response_columns(structure));
  auto add_row = [&] {
    const auto row = macro::probe_values(structure, sim);
    if (table_on_root) table_on_root->add_row(row);
  };
  add_row();
  // [device]: the device's own quantities (device.csv) and its geometric stop (gripper fingertips).
  std::unique_ptr<macro::DeviceProbe> device;
  std::unique_ptr<io::ProgressiveCsv> device_table;
  std::string device_stop;
  std::vector<double> device_row;
  if (ms.device.kind != macro::DeviceKind::none) {
    device = std::make_unique<macro::DeviceProbe>(ms.device, structure);
    if (root) device_table = std::make_unique<io::ProgressiveCsv>(options.out / "device.csv", device->columns());
    device_row = device->values(sim);
    if (device_table) device_table->add_row(device_row);
  }
  std::unique_ptr<io::FieldWriter> writer;
  if (ms.fields && root) {
    writer = std::make_unique<io::FieldWriter>(options.out / "fields", field_mesh(structure.model.mesh));
    writer->set_attribute("frame", "global Cartesian frame of the structure's mesh (x, y, z); tensors row-major");
    if (ms.fields_at(0.0)) write_fields(*writer, sim);
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
    add_row();
    if (writer && ms.fields_at(t)) write_fields(*writer, sim);
    ++done;
    if (device) {
      const std::vector<double> row = device->values(sim);
      if (device_table) device_table->add_row(row);
      const double next = done < ms.times.size() ? ms.times[done] : t;
      device_stop = device->stop_reason(row, &device_row, next);
      device_row = row;
      if (!device_stop.empty()) {
        if (root) std::cerr << tag << device_stop << " at t = " << format_number(t) << "\n";
        break;
      }
    }
    progress.update(tag + "t = " + format_number(t) + " / " + format_number(ms.times.back()) + " (" +
                    std::to_string(step.counts.newton_iterations) + " Newton iterations in " +
                    std::to_string(step.substeps) + " sub-steps, " + std::to_string(step.counts.cutbacks) +
                    " cut-backs)");
    raise_test_signal_after(done);
  }
  const bool completed = error.empty() && (done == ms.times.size() || !device_stop.empty());
  if (!completed && stop_requested()) error = interruption_message();
  progress.finish();
  for (const auto& line : sim.stats().log)
    if (!options.quiet) std::cerr << tag << line << "\n";
  if (writer) writer->close();
  if (!root) return run_exit_code(completed);
  io::ProgressiveCsv& table = *table_on_root;
  table.flush();
  if (device_table) device_table->flush();

  const fe::RunStats st = sim.stats();
  nlohmann::json summary = io::summary_base("macro", scene.file, scene.table);
  summary["material"] = ms.spec.material->describe();
  io::set_run_status(summary, completed, error);
  summary["columns"] = io::columns_json(table.table().columns());
  if (device) {
    nlohmann::json d;
    d["kind"] = ms.device.kind == macro::DeviceKind::cpasmo ? "cpasmo" : "gripper";
    d["file"] = "device.csv";
    d["columns"] = device_table->table().columns();
    d["stopped_before_contact"] = !device_stop.empty();
    d["stop_reason"] = device_stop;
    nlohmann::json last;  // the last row written (the last converged output step)
    const auto& cols = device_table->table().columns();
    for (std::size_t c = 0; c < cols.size() && c < device_row.size(); ++c) last[cols[c]] = device_row[c];
    d["final"] = last;
    summary["device"] = d;
  }
  summary["output_steps"] = done;
  summary["steps"] = st.steps;
  summary["newton_iterations"] = st.newton_iterations;
  summary["cutbacks"] = st.cutbacks;
  summary["line_search_backtracks"] = st.line_search_backtracks;
  summary["elements"] = structure.model.mesh.num_elements();
  summary["dofs"] = sim.num_free_dofs();
  summary["linear_solver"] = {{"route", st.linear_solver.route}, {"preconditioner", st.linear_solver.preconditioner},
                              {"description", st.linear_solver.description}, {"krylov_iterations", st.linear_solver.krylov_iterations},
                              {"factorizations", st.linear_solver.factorizations}, {"solves", st.linear_solver.solves}};
  summary["mpi_ranks"] = mpi::world_size();
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
