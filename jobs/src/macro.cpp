// softhom macro: structure-scale nonlinear FE (tubes, balloons, plates, bending actuators).
//
// The scene (geometry, material, load path, solver, output) is parsed by macro::parse_macro_scene
// (macro/scene.hpp, every key declared there); this file wires the run and its outputs to the sink.
#include <algorithm>
#include <chrono>
#include <iostream>

#include <omp.h>

#include "softhom/io/fields.hpp"
#include "softhom/io/files.hpp"
#include "softhom/core/mpi.hpp"
#include "softhom/io/summary.hpp"
#include "softhom/jobs/jobs.hpp"
#include "softhom/jobs/run_control.hpp"
#include "softhom/jobs/thread_defaults.hpp"
#include "softhom/macro/devices.hpp"
#include "softhom/macro/mesh_generation.hpp"
#include "softhom/macro/scene.hpp"
#include "softhom/macro/structures.hpp"
#include "softhom/materials/errors.hpp"

namespace softhom::jobs {
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

io::CellType report_cell_type(fe::ReportCells::Type t) {
  switch (t) {
    case fe::ReportCells::Type::line2: return io::CellType::line2;
    case fe::ReportCells::Type::line3: return io::CellType::line3;
    case fe::ReportCells::Type::triangle3: return io::CellType::triangle3;
    case fe::ReportCells::Type::triangle6: return io::CellType::triangle6;
    case fe::ReportCells::Type::quad4: return io::CellType::quad4;
  }
  return io::CellType::triangle3;
}

io::UnstructuredMesh report_mesh(const fe::ReportCells& cells) {
  io::UnstructuredMesh out;
  for (const Vec3& x : cells.points) out.coordinates.insert(out.coordinates.end(), {x[0], x[1], x[2]});
  out.connectivity.assign(cells.connectivity.begin(), cells.connectivity.end());
  out.cell_type = report_cell_type(cells.type);
  return out;
}

/// The probes and fields the model's contributions report (shells, fibers, contact): extra columns of
/// response.csv and one time series <stem>.h5/.xdmf per field, whose cells are fixed at the start.
class ContributionRecorder {
 public:
  ContributionRecorder(const fe::Simulation& sim, Sink& sink, bool fields) : sim_(sim) {
    const fe::ContributionReport r = now();
    for (const auto& [name, value] : r.probes) columns_.push_back(name);
    if (!fields) return;
    for (const fe::ReportField& f : r.fields) writers_.push_back(sink.open_fields(f.cells.stem, report_mesh(f.cells)));
    if (std::none_of(writers_.begin(), writers_.end(), [](const auto& w) { return bool(w); })) writers_.clear();
  }
  const std::vector<std::string>& columns() const { return columns_; }
  /// This state's report, taken once: its probe values appended to a response row and, when `fields` is
  /// due, its arrays written as the next step of each field file.
  void record(std::vector<double>& row, bool fields) const {
    const fe::ContributionReport r = now();
    for (const auto& [name, value] : r.probes) row.push_back(value);
    if (!fields) return;
    for (std::size_t k = 0; k < writers_.size() && k < r.fields.size(); ++k) {
      if (!writers_[k]) continue;
      io::FieldWriter& w = *writers_[k];
      w.begin_step(sim_.time());
      for (const fe::ReportArray& a : r.fields[k].arrays)
        w.add(a.name, a.values, a.components, a.per_cell ? io::Centering::cell : io::Centering::node, a.unit);
      w.end_step();
    }
  }
  void close() {
    for (auto& w : writers_)
      if (w) w->close();
  }

 private:
  fe::ContributionReport now() const {
    fe::ContributionReport r;
    sim_.report(r);
    return r;
  }
  const fe::Simulation& sim_;
  std::vector<std::string> columns_;
  std::vector<std::unique_ptr<io::FieldWriter>> writers_;
};

/// The [device] of a run: its own quantities (table "device") and its geometric stop (gripper fingertips).
struct DeviceRecord {
  std::unique_ptr<macro::DeviceProbe> probe;
  std::vector<std::string> columns;
  std::vector<double> last_row;  // the last row recorded (the last converged output step)
  std::string stop;
};

/// The outputs of a macro run as it goes: rows, device rows, fields, the progress line.
class MacroRecorder {
 public:
  MacroRecorder(const MacroJob& job, const macro::Structure& structure, const fe::Simulation& sim, Sink& sink,
                const RunOptions& options);
  /// After the output step `done` converged at t; returns false when the device asks to stop.
  bool record(double t, std::size_t done, const fe::AdvanceResult& step);
  void close();
  const DeviceRecord& device() const { return device_; }
  const std::vector<std::string>& columns() const { return columns_; }

 private:
  const MacroJob& job_;
  const macro::Structure& structure_;
  const fe::Simulation& sim_;
  Sink& sink_;
  std::string tag_;
  std::vector<std::string> columns_;
  DeviceRecord device_;
  std::unique_ptr<io::FieldWriter> writer_;
  ContributionRecorder contributions_;
  Progress progress_;
  /// The response row of the converged state (the contributions' fields written with it when due).
  std::vector<double> response_row(bool fields_due) const {
    std::vector<double> row = macro::probe_values(structure_, sim_);
    contributions_.record(row, fields_due);
    return row;
  }
};

MacroRecorder::MacroRecorder(const MacroJob& job, const macro::Structure& structure, const fe::Simulation& sim,
                             Sink& sink, const RunOptions& options)
    : job_(job), structure_(structure), sim_(sim), sink_(sink), tag_("[macro " + job.scene.name + "] "),
      columns_(response_columns(structure)), contributions_(sim, sink, job.parsed.fields),
      progress_(options.quiet) {
  const macro::MacroScene& ms = job.parsed;
  columns_.insert(columns_.end(), contributions_.columns().begin(), contributions_.columns().end());
  sink.open_table("response", columns_);
  sink.add_row("response", response_row(ms.fields_at(0.0)));
  if (ms.device.kind != macro::DeviceKind::none) {
    device_.probe = std::make_unique<macro::DeviceProbe>(ms.device, structure);
    device_.columns = device_.probe->columns();
    sink.open_table("device", device_.columns);
    device_.last_row = device_.probe->values(sim);
    sink.add_row("device", device_.last_row);
  }
  if (ms.fields && structure.model.mesh.num_elements() > 0) {  // (a shell's fields are its own report)
    writer_ = sink.open_fields("fields", field_mesh(structure.model.mesh));
    if (writer_) {
      writer_->set_attribute("frame", "global Cartesian frame of the structure's mesh (x, y, z); tensors row-major");
      if (ms.fields_at(0.0)) write_fields(*writer_, sim);
    }
  }
}

bool MacroRecorder::record(double t, std::size_t done, const fe::AdvanceResult& step) {
  const macro::MacroScene& ms = job_.parsed;
  sink_.add_row("response", response_row(ms.fields_at(t)));
  if (writer_ && ms.fields_at(t)) write_fields(*writer_, sim_);
  if (device_.probe) {
    const std::vector<double> row = device_.probe->values(sim_);
    sink_.add_row("device", row);
    const double next = done < ms.times.size() ? ms.times[done] : t;
    device_.stop = device_.probe->stop_reason(row, &device_.last_row, next);
    device_.last_row = row;
    if (!device_.stop.empty()) {
      if (mpi::world_rank() == 0) std::cerr << tag_ << device_.stop << " at t = " << format_number(t) << "\n";
      return false;
    }
  }
  progress_.update(tag_ + "t = " + format_number(t) + " / " + format_number(ms.times.back()) + " (" +
                   std::to_string(step.counts.newton_iterations) + " Newton iterations in " +
                   std::to_string(step.substeps) + " sub-steps, " + std::to_string(step.counts.cutbacks) +
                   " cut-backs)");
  return true;
}

void MacroRecorder::close() {
  progress_.finish();
  if (writer_) writer_->close();
  contributions_.close();
}

/// What a macro run reports beyond its rows.
struct MacroOutcome {
  bool completed = false;
  std::string error;
  std::size_t output_steps = 0;
};

/// summary.json of a macro run: status, device, Newton and linear-solver statistics, timings.
nlohmann::json macro_summary(const MacroJob& job, const macro::Structure& structure, const fe::Simulation& sim,
                             const MacroRecorder& record, const MacroOutcome& outcome,
                             std::chrono::steady_clock::time_point wall_start) {
  const macro::MacroScene& ms = job.parsed;
  const fe::RunStats st = sim.stats();
  nlohmann::json summary = io::summary_base("macro", job.scene.file, job.scene.table);
  if (ms.spec.material) summary["material"] = ms.spec.material->describe();
  if (ms.spec.kind == macro::StructureKind::shell)  // a shell's laws are its layers'
    for (const ShellLayer& l : ms.spec.shell.section->layers())
      summary["shell_layers"].push_back({{"thickness_mm", l.thickness}, {"points", l.points}, {"material", l.law->describe()}});
  io::set_run_status(summary, outcome.completed, outcome.error);
  summary["columns"] = io::columns_json(record.columns());
  if (const DeviceRecord& device = record.device(); device.probe) {
    nlohmann::json d;
    d["kind"] = ms.device.kind == macro::DeviceKind::cpasmo    ? "cpasmo"
                : ms.device.kind == macro::DeviceKind::gripper ? "gripper"
                : ms.device.kind == macro::DeviceKind::bending ? "bending"
                                                               : "tube";
    d["file"] = "device.csv";
    d["columns"] = device.columns;
    d["stopped_before_contact"] = !device.stop.empty();
    d["stop_reason"] = device.stop;
    nlohmann::json last;  // the last row written (the last converged output step)
    for (std::size_t c = 0; c < device.columns.size() && c < device.last_row.size(); ++c)
      last[device.columns[c]] = device.last_row[c];
    d["final"] = last;
    summary["device"] = d;
  }
  summary["output_steps"] = outcome.output_steps;
  summary["steps"] = st.steps;
  summary["newton_iterations"] = st.newton_iterations;
  summary["cutbacks"] = st.cutbacks;
  summary["line_search_backtracks"] = st.line_search_backtracks;
  summary["elements"] = structure.model.mesh.num_elements();
  summary["dofs"] = sim.num_free_dofs();
  const fe::LinearSolverReport& ls = st.linear_solver;
  summary["linear_solver"] = {{"route", ls.route}, {"preconditioner", ls.preconditioner},
                              {"description", ls.description}, {"krylov_iterations", ls.krylov_iterations},
                              {"factorizations", ls.factorizations}, {"solves", ls.solves}};
  summary["mpi_ranks"] = mpi::world_size();
  summary["assembly_time_s"] = st.assembly_time;
  if (st.pattern_rebuilds > 0) {  // a contact between deformable surfaces moved its pairs
    summary["pattern_rebuilds"] = st.pattern_rebuilds;
    summary["pattern_rebuild_time_s"] = st.pattern_rebuild_time;
  }
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
  return summary;
}

/// The load path's output times, each reached by the Newton driver, until the end, a failure, a stop
/// request or the device's stop.
MacroOutcome advance_through_output_times(const macro::MacroScene& ms, fe::Simulation& sim, MacroRecorder& record) {
  MacroOutcome outcome;
  bool device_stopped = false;
  for (double t : ms.times) {
    if (stop_requested()) break;  // between output times; the Newton loops poll inside a step
    const fe::AdvanceResult step = sim.advance_to(t);
    if (!step.reached()) {
      outcome.error = step.message;
      break;
    }
    ++outcome.output_steps;
    if (!record.record(t, outcome.output_steps, step)) {
      device_stopped = true;
      break;
    }
    raise_test_signal_after(outcome.output_steps);
  }
  outcome.completed = outcome.error.empty() && (outcome.output_steps == ms.times.size() || device_stopped);
  if (!outcome.completed && stop_requested()) outcome.error = interruption_message();
  return outcome;
}

}  // namespace

MacroJob parse_macro(LoadedScene scene, const std::filesystem::path& out) {
  MacroJob job;
  job.parsed = macro::parse_macro_scene(scene.table, scene.file, macro::mesh_cache_dir(out));
  job.scene = std::move(scene);
  return job;
}

bool run_macro(MacroJob& job, Sink& given_sink, const RunOptions& given) {
  // Under mpirun every rank runs the same (replicated) Newton iteration and shares the petsc linear
  // solver; rank 0 alone hands rows, fields and the summary to the sink, and reports progress.
  const bool root = mpi::world_rank() == 0;
  RunOptions options = given;
  if (!root) options.quiet = true;
  DiscardSink discard;
  Sink& sink = root ? given_sink : discard;
  const auto wall_start = std::chrono::steady_clock::now();
  macro::MacroScene& ms = job.parsed;
  const macro::Structure structure = macro::build_structure(ms.spec);
  ms.spec.imported.mesh = fe::Mesh{};  // built into structure.model: not kept twice for the run
  fe::Simulation sim(structure.model, ms.newton);
  // Without a thread count from the user, a small mesh runs on fewer threads (thread_defaults.hpp).
  const ThreadCountScope threads(thread_count_given(options.threads)
                                     ? 0
                                     : default_thread_count(std::size_t(sim.num_free_dofs()) / mpi::world_size(),
                                                            kFreeDofsPerDefaultThread, omp_get_max_threads()));
  const std::string tag = "[macro " + job.scene.name + "] ";
  if (!options.quiet)
    std::cerr << tag << structure.model.mesh.num_hexes() << " hex8 + " << structure.model.mesh.tets.size() << " tet10, "
              << sim.num_free_dofs() << " free dofs, " << fe::to_string(sim.solver_kind()) << "\n";
  if (structure.shell && structure.shell->frame_fallbacks() > 0 && root)  // the [shell] frame's documented fall-back
    std::cerr << tag << "warning: shell.frame_axis is within 1e-3 of the normal of " << structure.shell->frame_fallbacks()
              << " triangles: their e1 is the projection of the y axis (or z) instead\n";
  MacroRecorder record(job, structure, sim, sink, options);
  const MacroOutcome outcome = advance_through_output_times(ms, sim, record);
  record.close();
  for (const auto& line : sim.stats().log)
    if (!options.quiet) std::cerr << tag << line << "\n";
  if (!root) return outcome.completed;
  sink.flush();
  sink.write_summary(macro_summary(job, structure, sim, record, outcome, wall_start));
  const fe::RunStats st = sim.stats();
  if (!outcome.completed) {
    std::cerr << "softhom macro: stopped early: " << outcome.error << "\nsofthom macro: " << outcome.output_steps + 1
              << " converged rows kept in " << sink.where("response.csv") << "\n";
    return false;
  }
  if (!options.quiet)
    std::cerr << "softhom macro: " << st.steps << " steps, " << st.newton_iterations << " Newton iterations → "
              << sink.where("") << "\n";
  return true;
}

}  // namespace softhom::jobs
