// softhom rve: FFT homogenization of a periodic fiber cell under the mixed control of `softhom point`.
//
// Scene tables: [microstructure] (generated section or imported HDF5 phase image, grid, fiber angle),
// [phases.matrix] / [phases.fiber] (material tables as in `softhom point`), [load] (same syntax as
// `softhom point`), [solver] (discretization, scheme, tolerances, FFTW), [output] (fields).
#include <chrono>
#include <cmath>
#include <iostream>
#include <optional>
#include <set>

#include "cmd_keys.hpp"
#include "cmd_rve_fe.hpp"
#include "commands.hpp"
#include "scene_source.hpp"
#include "softhom/io/fields.hpp"
#include "softhom/io/files.hpp"
#include "softhom/io/scene.hpp"
#include "softhom/io/summary.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/materials/library.hpp"
#include "softhom/rve/fft_solver.hpp"
#include "softhom/rve/geometry.hpp"
#include "softhom/studies/rve_scene.hpp"

#include "rve_checkpoint.hpp"
#include "rve_output.hpp"
#include "rve_slab_fields.hpp"
#include "softhom/core/mpi.hpp"

namespace softhom::app {
namespace {

/// Bytes of the phase image as the ranks hold it (fractions, normals, directions), the largest rank's.
double phase_image_bytes_per_rank(const rve::PhaseImage& im, const fft::SlabDecomposition* slabs) {
  double b = double(im.fiber_fraction.size() * sizeof(double) +
                    (im.normal.size() + im.fiber_direction.size()) * sizeof(Eigen::Vector3d));
  if (slabs) MPI_Allreduce(MPI_IN_PLACE, &b, 1, MPI_DOUBLE, MPI_MAX, slabs->comm());
  return b;
}

io::VoxelGrid voxel_grid(const rve::PhaseImage& im) {
  io::VoxelGrid g;
  g.cells = im.n;
  for (int d = 0; d < 3; ++d) g.spacing[d] = im.size[d] / im.n[d];
  return g;
}

/// Progress lines inside long sub-steps (FftSolverOptions::on_newton_iteration).
struct InStepProgress {
  using Clock = std::chrono::steady_clock;
  static constexpr double kAfterSeconds = 10.0;
  Progress* progress = nullptr;  // set once the command's progress exists
  std::string tag;
  Clock::time_point substep_start{}, last_line{};

  void newton_iteration(double t_new, int iteration, double residual, int krylov) {
    const Clock::time_point now = Clock::now();
    if (iteration == 0) substep_start = now;
    if (!progress || std::chrono::duration<double>(now - substep_start).count() < kAfterSeconds ||
        std::chrono::duration<double>(now - last_line).count() < kAfterSeconds)
      return;
    last_line = now;
    progress->update(tag + "step to t = " + format_number(t_new) + ": Newton " + std::to_string(iteration) +
                     ", residual " + progress_number(residual) + ", Krylov " + std::to_string(krylov) + ", " +
                     std::to_string(long(std::chrono::duration<double>(now - substep_start).count())) +
                     " s into the sub-step");
  }
};

}  // namespace

int run_rve(const CommandOptions& options) {
  return run_rve_scene(options, load_scene_or_default(options, default_scene_name("rve")));
}

int run_rve_scene(const CommandOptions& options, LoadedScene scene) {
  const auto wall_start = std::chrono::steady_clock::now();
  // Engine choice ([solver] engine = "fft" | "fe"); the FE engine has its own [solver] keys.
  if (auto* solver_table = scene.table["solver"].as_table()) {
    static const keys::Choices<std::string> engines{{{"fft", "fft"}, {"fe", "fe"}, {"auto", "auto"}}, {}};
    const toml::node* engine_node = solver_table->get("engine");
    std::string engine = engine_node ? keys::read_choice(*engine_node, "solver.engine", engines) : "fft";
    if (engine == "auto") {  // resolution and engine from solver.target_error (BENCHMARKS.md)
      std::string why;
      engine = choose_engine(scene.table, why);
      if (!options.quiet) std::cerr << "softhom rve: " << why << "\n";
    }
    if (engine == "fe") {
      if (options.resume)
        throw InputError("--resume", "", "continues runs of the FFT engine only (solver.engine = \"fe\" writes no checkpoint)");
      return run_rve_fe(options, scene);
    }
  }
  // [load] is parsed only when the run needs it (unknown tables are refused by the scene parser).
  const bool wants_microstructure_only = studies::parse_rve_output(scene.table, nullptr).microstructure_only;
  if (wants_microstructure_only && options.resume)
    throw InputError("--resume", "", "output.microstructure_only runs no load path, there is nothing to continue");
  // A run that stopped before the end of its load path left a checkpoint (rve_checkpoint.hpp): --resume
  // continues it; a new run into the same --out would overwrite the finished part, so it is refused.
  RveCheckpoint checkpoint(options.out, scene.table, mpi::world_rank(), mpi::world_size());
  if (!wants_microstructure_only) {
    if (options.resume)
      checkpoint.check_resumable();
    else if (checkpoint.exists())
      throw InputError("--out", options.out.string(),
                       "holds the checkpoint of an unfinished run (" + checkpoint.describe() +
                           "): continue it with --resume, or remove " + (options.out / "checkpoint.json").string() +
                           " to start over");
  }
  // A 3D cell under an MPI launcher: each rank builds and holds only its slab of the phase image.
  studies::RveSceneSetup setup =
      studies::parse_rve_scene(scene.table, !wants_microstructure_only, options.out, !wants_microstructure_only);
  const rve::PhaseImage& image = setup.image;
  const MaterialPtr& matrix = setup.matrix;
  const MaterialPtr& fiber = setup.fiber;
  const double target_vf = setup.target_vf;
  const std::string& geometry_note = setup.geometry_note;
  const double alpha = setup.fiber_angle_deg;

  // [output]
  const studies::RveOutputSettings& output = setup.output;
  const std::string& fields_mode = output.fields_mode;
  const bool microstructure_only = output.microstructure_only;
  std::filesystem::create_directories(options.out);

  // Under an MPI launcher the FFT cell is distributed over the ranks (3D grids); rank 0 writes every file
  // and the progress, the other ranks compute and send their slabs of the fields.
  const bool root = mpi::world_rank() == 0;
  if (microstructure_only && !root) return 0;
  if (microstructure_only) {
    // microstructure.h5 + .xdmf: datasets at the root that [microstructure.image] reads back exactly
    // (dataset = "/fiber_fraction", normal_dataset = "/interface_normal"), plus a binary phase-id image
    // ("/phase", uint8, fiber where the fraction is >= 1/2) for other codes.
    std::vector<io::VoxelImageDataset> sets;
    io::VoxelImageDataset phase{"phase", {}, 1, true};
    phase.values.reserve(image.voxels());
    for (double f : image.fiber_fraction) phase.values.push_back(f >= 0.5 ? 1.0 : 0.0);
    sets.push_back(std::move(phase));
    sets.push_back({"fiber_fraction", image.fiber_fraction, 1, false});
    auto flat = [](const std::vector<Eigen::Vector3d>& a) {
      std::vector<double> v;
      v.reserve(3 * a.size());
      for (const auto& x : a)
        for (int c = 0; c < 3; ++c) v.push_back(std::isfinite(x[c]) ? x[c] : 0.0);
      return v;
    };
    if (image.normal.size() == image.voxels()) sets.push_back({"interface_normal", flat(image.normal), 3, false});
    if (image.fiber_direction.size() == image.voxels()) sets.push_back({"fiber_direction", flat(image.fiber_direction), 3, false});
    io::write_voxel_image(options.out / "microstructure", voxel_grid(image), sets);
    nlohmann::json summary = io::summary_base("rve", scene.file, scene.table);
    summary["files"] = {"microstructure.h5", "microstructure.xdmf"};
    summary["microstructure_only"] = true;
    io::set_run_status(summary, true, "");
    summary["grid"] = image.n;
    summary["cell_size"] = image.size;
    summary["volume_fraction_target"] = target_vf;
    summary["volume_fraction_achieved"] = image.volume_fraction();
    summary["geometry"] = geometry_note;
    io::write_summary(options.out, summary);
    if (!options.quiet) std::cerr << "softhom rve: microstructure written to " << (options.out / "microstructure.xdmf").string() << "\n";
    return 0;
  }

  const MixedControl& control = setup.control;
  rve::FftSolverOptions solver_options = setup.solver;
  solver_options.distributed = true;  // only when MPI is active with more than one rank
  // Progress inside a step that runs long (large cells: an output step can take an hour): a line per
  // Newton iteration once the sub-step has run 10 s, at most one per 10 s.
  InStepProgress in_step;
  solver_options.on_newton_iteration = [&in_step](double t_new, int iteration, double residual, int krylov) {
    in_step.newton_iteration(t_new, iteration, residual, krylov);
  };

  rve::FftRveSolver solver(image, matrix, fiber, alpha, control.frame, solver_options);
  const fft::SlabDecomposition* slabs = solver.slabs();
  const double image_bytes = phase_image_bytes_per_rank(image, slabs);  // collective
  // The solver keeps what it needs of the image (4 B per voxel, the normals of composite voxels only):
  // the scene's per-voxel arrays (fractions and normals, 32 B per voxel) are not held through the run.
  std::vector<double>().swap(setup.image.fiber_fraction);
  std::vector<Eigen::Vector3d>().swap(setup.image.normal);
  std::vector<Eigen::Vector3d>().swap(setup.image.fiber_direction);
  RveResumePoint resumed;
  if (options.resume) {
    // Every rank loads its own file; one that cannot must not leave the others waiting in the run.
    std::optional<InputError> failure;
    try {
      resumed = checkpoint.load(solver);
    } catch (const InputError& e) {
      failure = e;
    }
    if (slabs ? slabs->max(failure ? 1 : 0) : failure.has_value()) {
      if (failure) throw *failure;
      throw InputError("--resume", options.out.string(), "another rank could not load its saved state");
    }
  }
  const double t_end = control.times.back();
  std::unique_ptr<io::FieldWriter> writer;
  // A continued run does not rewrite the field steps of the run it continues: its own go to a file of
  // their own.
  const std::string fields_stem = resumed.field_steps > 0
                                      ? "fields_resumed_" + std::to_string(resumed.step_log.size() - 1)
                                      : std::string("fields");
  if (fields_mode != "none" && root) {
    writer = std::make_unique<io::FieldWriter>(options.out / fields_stem, voxel_grid(image));
    set_rve_field_attributes(*writer, alpha, "FFT voxels");
  }
  auto want_fields = [&](double t) { return output.wants_fields(t, t_end); };
  RveRecorder record(options.out, studies::rve_response_columns());
  if (!root) record.csv = io::ProgressiveCsv({}, studies::rve_response_columns());  // kept in memory only
  if (options.resume) record.take_over(resumed.rows, resumed.step_log);
  rve::RveCounts totals = resumed.totals;  // of the whole run, for the checkpoint
  int field_steps = resumed.field_steps;
  std::vector<std::string> checkpoint_notes;
  auto wall_seconds = [&] {
    return resumed.wall_seconds + std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  };
  Progress progress(options.quiet || !root);
  in_step.progress = &progress;
  in_step.tag = "[rve " + scene.name + "] ";
  auto on_step = [&](const rve::RveStep& s, const rve::RveFields* f) {
    record.record(s, studies::rve_response_row(s));
    totals += s;
    if (f && fields_mode != "none") ++field_steps;
    if (f && slabs && fields_mode != "none") {
      if (writer) writer->begin_step(s.t);
      write_slab_fields(writer.get(), *slabs, *f);
      if (writer) writer->end_step();
    } else if (f && writer) {
      writer->begin_step(s.t);
      for (const RveFieldView& field : rve_field_views(*f))
        writer->add(field.name, *field.values, field.components, field.centering, field.unit);
      writer->end_step();
    }
    progress.update(rve_progress_line("[rve " + scene.name + "] ", s, t_end));
    // Every rank stops after the same step (a signal reaches the ranks at different times).
    raise_test_signal_after(record.step_log.size() - 1);
    const bool stopping = slabs ? slabs->max(stop_requested() ? 1 : 0) != 0 : stop_requested();
    if (s.t > 0.0) {  // a stop request saves the step at once
      std::string note = checkpoint.save(solver, slabs, s.t, record, totals, wall_seconds(), field_steps, stopping);
      if (!note.empty()) checkpoint_notes.push_back(std::move(note));
    }
    if (stopping) throw RunInterrupted{};
  };
  rve::RveRunResult result =
      run_rve_engine(solver, control, on_step, want_fields, record, options.resume ? resumed.t : 0.0);
  progress.finish();
  static_cast<rve::RveCounts&>(result) += resumed.totals;  // the whole run's totals
  if (result.completed || result.stop == rve::RveStop::fatal) {
    checkpoint.remove();  // nothing to continue: done, or a phase at its material limit
  } else if (const double t_last = record.step_log.back().value("t", 0.0); t_last > 0.0) {
    // Failed or out of time: the last converged step, in case the throttle skipped it (collective),
    // with the totals of the failed attempts too.
    std::string note = checkpoint.save(solver, slabs, t_last, record, result, wall_seconds(), field_steps, true);
    if (!note.empty()) checkpoint_notes.push_back(std::move(note));
    if (checkpoint.saved_t() > 0.0)
      result.log.push_back("checkpoint at t = " + format_number(checkpoint.saved_t()) + ": continue with --resume");
  }
  for (auto& note : checkpoint_notes) result.log.push_back(std::move(note));
  for (const auto& line : result.log)
    if (!options.quiet && root) std::cerr << "[rve " << scene.name << "] " << line << "\n";
  record.csv.flush();
  if (writer) writer->close();
  if (!root) return result.completed ? 0 : run_exit_code(false);
  const nlohmann::json& step_log = record.step_log;

  nlohmann::json summary = io::summary_base("rve", scene.file, scene.table);
  summary["grid"] = image.n;
  summary["voxels"] = image.voxels();
  summary["cell_size"] = image.size;
  summary["geometry"] = geometry_note;
  summary["volume_fraction_target"] = target_vf;
  summary["volume_fraction_achieved"] = solver.achieved_volume_fraction();
  summary["fiber_angle_deg"] = alpha;
  summary["matrix"] = matrix->describe();
  summary["fiber"] = fiber->describe();
  summary["load"] = control.name;
  summary["discretization"] = fft::to_string(solver_options.discretization);
  summary["quadrature_points"] = solver.quadrature_points();
  summary["solver"] = rve::to_string(solver_options.scheme);
  summary["reference_medium"] = rve::to_string(solver_options.reference);
  summary["krylov_operator"] = rve::to_string(solver_options.krylov_operator);
  summary["tangent_precision"] = rve::to_string(solver_options.tangent_precision);
  summary["preconditioner"] = rve::to_string(solver.preconditioner());
  summary["volumetric"] = rve::to_string(solver_options.volumetric);
  summary["indefinite_solver"] = solver_options.indefinite_solver == rve::IndefiniteSolver::minres ? "minres" : "shift";
  summary["composite_tangent"] = solver_options.composite_tangent == rve::CompositeTangent::exact ? "exact" : "projected";
  summary["tolerance"] = solver_options.tolerance;
  summary["fft"] = solver.fft_description();
  summary["fft_planning_s"] = solver.planning_seconds();
  summary["ranks"] = slabs ? slabs->size() : 1;
  summary["columns"] = io::columns_json(record.csv.table().columns());
  // Bytes per voxel: the solver's own accounting over its arrays (by array) and the process peak RSS.
  nlohmann::json breakdown = nlohmann::json::object();
  for (const auto& [array, bytes] : solver.memory_breakdown()) breakdown[array] = bytes;
  summary["solver_memory_by_array"] = breakdown;
  summary["solver_bytes_per_voxel"] = double(solver.memory_bytes()) / double(image.voxels());
  summary["phase_image_bytes_per_rank"] = image_bytes;  // the scene's image as a rank holds it (largest rank)
  if (fields_mode != "none") summary["fields_file"] = fields_stem + ".xdmf";
  summary["checkpoint"] = {{"writes", checkpoint.writes()},
                           {"write_time_s", checkpoint.write_seconds()},
                           {"last_bytes", checkpoint.last_bytes()}};
  if (options.resume)
    summary["resumed"] = {{"from_t", resumed.t},
                          {"output_steps_before", resumed.step_log.size() - 1},
                          {"wall_time_s_before", resumed.wall_seconds}};
  if (!finish_rve_summary(summary, result, step_log, solver.memory_bytes(), options.out, wall_start,
                          resumed.wall_seconds))
    return run_exit_code(false);
  if (!options.quiet)
    std::cerr << "softhom rve: " << step_log.size() - 1 << " steps, " << result.newton_iterations
              << " Newton / " << result.krylov_iterations << " Krylov iterations, " << result.wall_seconds
              << " s → " << options.out.string() << "\n";
  return 0;
}

}  // namespace softhom::app
