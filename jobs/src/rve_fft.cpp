// softhom rve, FFT engine: homogenization of a periodic fiber cell under the mixed control of
// `softhom point` (rve/fft_solver.hpp), with checkpoints for --resume and, under an MPI launcher, the
// cell distributed over the ranks (rank 0 hands every result to the sink, the others compute).
#include <chrono>
#include <cmath>
#include <iostream>
#include <optional>

#include "rve_checkpoint.hpp"
#include "rve_jobs.hpp"
#include "rve_output.hpp"
#include "rve_slab_fields.hpp"
#include "softhom/io/fields.hpp"
#include "softhom/core/mpi.hpp"
#include "softhom/io/summary.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/rve/fft_solver.hpp"

namespace softhom::jobs {
namespace {

using Clock = std::chrono::steady_clock;

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

/// The fields' grid: the cell shown in the load frame, its axes the grid axes (rve::grid_rotation).
io::VoxelGrid load_frame_grid(const rve::PhaseImage& im, double fiber_angle_deg) {
  io::VoxelGrid g = voxel_grid(im);
  const Mat3 R = rve::grid_rotation(fiber_angle_deg);
  for (int c = 0; c < 9; ++c) g.axes[c] = R(c / 3, c % 3);
  return g;
}


/// Progress lines inside long sub-steps (FftSolverOptions::on_newton_iteration).
struct InStepProgress {
  static constexpr double kAfterSeconds = 10.0;
  Progress* progress = nullptr;  // set once the run's progress exists
  std::string tag;
  Clock::time_point substep_start{}, last_line{};

  void newton_iteration(double t_new, int iteration, double residual, int krylov) {
    const Clock::time_point now = Clock::now();
    if (iteration == 0) substep_start = now;
    if (!progress || std::chrono::duration<double>(now - substep_start).count() < kAfterSeconds ||
        std::chrono::duration<double>(now - last_line).count() < kAfterSeconds)
      return;
    last_line = now;
    progress->update(tag + "step to t = " + progress_number(t_new) + ": Newton " + std::to_string(iteration) +
                     ", residual " + progress_number(residual) + ", Krylov " + std::to_string(krylov) + ", " +
                     std::to_string(long(std::chrono::duration<double>(now - substep_start).count())) +
                     " s into the sub-step");
  }
};

std::vector<double> flat_vectors(const std::vector<Eigen::Vector3d>& a) {
  std::vector<double> v;
  v.reserve(3 * a.size());
  for (const auto& x : a)
    for (int c = 0; c < 3; ++c) v.push_back(std::isfinite(x[c]) ? x[c] : 0.0);
  return v;
}

/// output.microstructure_only: microstructure.h5 + .xdmf (with a sink directory): datasets that
/// [microstructure.image] reads back exactly (dataset = "/fiber_fraction", normal_dataset =
/// "/interface_normal"), plus a binary phase-id image ("/phase", uint8, fiber where the fraction is
/// >= 1/2) for other codes; and the summary.
void write_microstructure(const RveJob& job, const studies::RveSceneSetup& setup, Sink& sink, const RunOptions& options) {
  const rve::PhaseImage& image = setup.image;
  std::vector<io::VoxelImageDataset> sets;
  io::VoxelImageDataset phase{"phase", {}, 1, true};
  phase.values.reserve(image.voxels());
  for (double f : image.fiber_fraction) phase.values.push_back(f >= 0.5 ? 1.0 : 0.0);
  sets.push_back(std::move(phase));
  sets.push_back({"fiber_fraction", image.fiber_fraction, 1, false});
  if (image.normal.size() == image.voxels()) sets.push_back({"interface_normal", flat_vectors(image.normal), 3, false});
  if (image.fiber_direction.size() == image.voxels())
    sets.push_back({"fiber_direction", flat_vectors(image.fiber_direction), 3, false});
  if (!sink.directory().empty()) io::write_voxel_image(sink.directory() / "microstructure", voxel_grid(image), sets);
  nlohmann::json summary = io::summary_base("rve", job.scene.file, job.scene.table);
  summary["files"] = {"microstructure.h5", "microstructure.xdmf"};
  summary["microstructure_only"] = true;
  io::set_run_status(summary, true, "");
  summary["grid"] = image.n;
  summary["cell_size"] = image.size;
  summary["volume_fraction_target"] = setup.target_vf;
  summary["volume_fraction_achieved"] = image.volume_fraction();
  summary["geometry"] = setup.geometry_note;
  sink.write_summary(summary);
  if (!options.quiet) std::cerr << "softhom rve: microstructure written to " << sink.where("microstructure.xdmf") << "\n";
}

/// A checkpoint that stopped runs leave (rve_checkpoint.hpp): --resume continues it; a new run into the
/// same directory would overwrite the finished part, so it is refused. Null for a sink without a directory.
std::unique_ptr<RveCheckpoint> open_checkpoint(const RveJob& job, const Sink& sink) {
  const std::filesystem::path out = sink.directory();
  if (out.empty()) {
    if (job.resume) throw InputError("--resume", "", "continues a run in an output directory: give one");
    return nullptr;
  }
  auto checkpoint = std::make_unique<RveCheckpoint>(out, job.scene.table, mpi::world_rank(), mpi::world_size());
  if (job.resume)
    checkpoint->check_resumable();
  else if (checkpoint->exists())
    throw InputError("--out", out.string(),
                     "holds the checkpoint of an unfinished run (" + checkpoint->describe() +
                         "): continue it with --resume, or remove " + (out / "checkpoint.json").string() +
                         " to start over");
  return checkpoint;
}

/// One FFT run: the solver, its outputs and its checkpoints, step by step.
class FftRun {
 public:
  FftRun(const RveJob& job, studies::RveSceneSetup& setup, Sink& sink, const RunOptions& options);
  bool run();

 private:
  void resume_from_checkpoint();
  void open_fields();
  void on_step(const rve::RveStep& s, const rve::RveFields* f);
  void write_step_fields(double t, const rve::RveFields& f);
  void save_final_checkpoint(rve::RveRunResult& result);
  nlohmann::json summary() const;
  double wall_seconds() const {
    return resumed_.wall_seconds + std::chrono::duration<double>(Clock::now() - wall_start_).count();
  }

  const RveJob& job_;
  studies::RveSceneSetup& setup_;
  const RunOptions& options_;
  const bool root_ = mpi::world_rank() == 0;
  const std::filesystem::path out_;  // the sink's directory (empty: no checkpoints)
  DiscardSink discard_;
  Sink& sink_;  // the given sink on rank 0, discard_ on the other ranks
  Clock::time_point wall_start_ = Clock::now();
  std::unique_ptr<RveCheckpoint> checkpoint_;
  InStepProgress in_step_;
  rve::FftSolverOptions solver_options_;
  std::optional<rve::FftRveSolver> solver_;
  const fft::SlabDecomposition* slabs_ = nullptr;
  double image_bytes_ = 0.0;
  RveResumePoint resumed_;
  std::string fields_stem_ = "fields";
  std::unique_ptr<io::FieldWriter> writer_;
  std::optional<RveRecorder> record_;
  rve::RveCounts totals_;
  int field_steps_ = 0;
  std::vector<std::string> checkpoint_notes_;
  std::optional<Progress> progress_;
};

FftRun::FftRun(const RveJob& job, studies::RveSceneSetup& setup, Sink& sink, const RunOptions& options)
    : job_(job), setup_(setup), options_(options), out_(sink.directory()), sink_(root_ ? sink : discard_) {
  checkpoint_ = open_checkpoint(job, sink);
  sink.prepare();
  solver_options_ = setup.solver;
  solver_options_.distributed = true;  // only when MPI is active with more than one rank
  // Progress inside a step that runs long (large cells: an output step can take an hour): a line per
  // Newton iteration once the sub-step has run 10 s, at most one per 10 s.
  solver_options_.on_newton_iteration = [this](double t_new, int iteration, double residual, int krylov) {
    in_step_.newton_iteration(t_new, iteration, residual, krylov);
  };
  solver_.emplace(setup.image, setup.matrix, setup.fiber, setup.fiber_angle_deg, setup.control.frame, solver_options_);
  slabs_ = solver_->slabs();
  image_bytes_ = phase_image_bytes_per_rank(setup.image, slabs_);  // collective
  // The solver keeps what it needs of the image (4 B per voxel, the normals of composite voxels only):
  // the scene's per-voxel arrays (fractions and normals, 32 B per voxel) are not held through the run.
  std::vector<double>().swap(setup.image.fiber_fraction);
  std::vector<Eigen::Vector3d>().swap(setup.image.normal);
  std::vector<Eigen::Vector3d>().swap(setup.image.fiber_direction);
  if (job.resume) resume_from_checkpoint();
  open_fields();
  record_.emplace(sink_, studies::rve_response_columns());
  if (job.resume) record_->take_over(resumed_.rows, resumed_.step_log);
  totals_ = resumed_.totals;  // of the whole run, for the checkpoint
  field_steps_ = resumed_.field_steps;
  progress_.emplace(options.quiet || !root_);
  in_step_.progress = &*progress_;
  in_step_.tag = "[rve " + job.scene.name + "] ";
}

void FftRun::resume_from_checkpoint() {
  // Every rank loads its own file; one that cannot must not leave the others waiting in the run.
  std::optional<InputError> failure;
  try {
    resumed_ = checkpoint_->load(*solver_);
  } catch (const InputError& e) {
    failure = e;
  }
  if (slabs_ ? slabs_->max(failure ? 1 : 0) : failure.has_value()) {
    if (failure) throw *failure;
    throw InputError("--resume", out_.string(), "another rank could not load its saved state");
  }
}

void FftRun::open_fields() {
  // A continued run does not rewrite the field steps of the run it continues: its own go to a file of
  // their own.
  if (resumed_.field_steps > 0) fields_stem_ = "fields_resumed_" + std::to_string(resumed_.step_log.size() - 1);
  if (setup_.output.fields_mode == "none" || !root_) return;
  writer_ = sink_.open_fields(fields_stem_, load_frame_grid(setup_.image, setup_.fiber_angle_deg));
  if (writer_) set_rve_field_attributes(*writer_, setup_.fiber_angle_deg, "FFT voxels");
}

void FftRun::write_step_fields(double t, const rve::RveFields& f) {
  if (setup_.output.fields_mode == "none") return;
  ++field_steps_;
  const std::vector<double> displacement = vectors_in_load_frame(f.displacement, setup_.fiber_angle_deg);
  if (slabs_) {  // collective: the other ranks send their slabs to rank 0's writer
    if (writer_) writer_->begin_step(t);
    write_slab_fields(writer_.get(), *slabs_, f, displacement);
    if (writer_) writer_->end_step();
  } else if (writer_) {
    writer_->begin_step(t);
    for (const RveFieldView& field : rve_field_views(f, displacement))
      writer_->add(field.name, *field.values, field.components, field.centering, field.unit);
    writer_->end_step();
  }
}

void FftRun::on_step(const rve::RveStep& s, const rve::RveFields* f) {
  record_->record(s, studies::rve_response_row(s));
  totals_ += s;
  if (f) write_step_fields(s.t, *f);
  progress_->update(rve_progress_line("[rve " + job_.scene.name + "] ", s, setup_.control.times.back()));
  // Every rank stops after the same step (a signal reaches the ranks at different times).
  raise_test_signal_after(record_->step_log.size() - 1);
  const bool stopping = slabs_ ? slabs_->max(stop_requested() ? 1 : 0) != 0 : stop_requested();
  if (s.t > 0.0 && checkpoint_) {  // a stop request saves the step at once
    std::string note =
        checkpoint_->save(*solver_, slabs_, s.t, *record_, totals_, wall_seconds(), field_steps_, stopping);
    if (!note.empty()) checkpoint_notes_.push_back(std::move(note));
  }
  if (stopping) throw RunInterrupted{};
}

void FftRun::save_final_checkpoint(rve::RveRunResult& result) {
  if (!checkpoint_) return;
  if (result.completed || result.stop == rve::RveStop::fatal) {
    checkpoint_->remove();  // nothing to continue: done, or a phase at its material limit
  } else if (const double t_last = record_->step_log.back().value("t", 0.0); t_last > 0.0) {
    // Failed or out of time: the last converged step, in case the throttle skipped it (collective),
    // with the totals of the failed attempts too.
    std::string note = checkpoint_->save(*solver_, slabs_, t_last, *record_, result, wall_seconds(), field_steps_, true);
    if (!note.empty()) checkpoint_notes_.push_back(std::move(note));
    if (checkpoint_->saved_t() > 0.0)
      result.log.push_back("checkpoint at t = " + format_number(checkpoint_->saved_t()) + ": continue with --resume");
  }
}

nlohmann::json FftRun::summary() const {
  const rve::PhaseImage& image = setup_.image;
  const rve::FftRveSolver& solver = *solver_;
  nlohmann::json summary = io::summary_base("rve", job_.scene.file, job_.scene.table);
  summary["grid"] = image.n;
  summary["voxels"] = image.voxels();
  summary["cell_size"] = image.size;
  summary["geometry"] = setup_.geometry_note;
  summary["volume_fraction_target"] = setup_.target_vf;
  summary["volume_fraction_achieved"] = solver.achieved_volume_fraction();
  summary["fiber_angle_deg"] = setup_.fiber_angle_deg;
  summary["matrix"] = setup_.matrix->describe();
  summary["fiber"] = setup_.fiber->describe();
  summary["load"] = setup_.control.name;
  summary["discretization"] = fft::to_string(solver_options_.discretization);
  summary["quadrature_points"] = solver.quadrature_points();
  summary["solver"] = rve::to_string(solver_options_.scheme);
  summary["reference_medium"] = rve::to_string(solver_options_.reference);
  summary["krylov_operator"] = rve::to_string(solver_options_.krylov_operator);
  summary["tangent_precision"] = rve::to_string(solver_options_.tangent_precision);
  summary["preconditioner"] = rve::to_string(solver.preconditioner());
  summary["volumetric"] = rve::to_string(solver_options_.volumetric);
  summary["indefinite_solver"] = solver_options_.indefinite_solver == rve::IndefiniteSolver::minres ? "minres" : "shift";
  summary["composite_tangent"] = solver_options_.composite_tangent == rve::CompositeTangent::exact ? "exact" : "projected";
  summary["tolerance"] = solver_options_.tolerance;
  summary["fft"] = solver.fft_description();
  summary["fft_planning_s"] = solver.planning_seconds();
  summary["ranks"] = slabs_ ? slabs_->size() : 1;
  summary["columns"] = io::columns_json(record_->rows.columns());
  // Bytes per voxel: the solver's own accounting over its arrays (by array) and the process peak RSS.
  nlohmann::json breakdown = nlohmann::json::object();
  for (const auto& [array, bytes] : solver.memory_breakdown()) breakdown[array] = bytes;
  summary["solver_memory_by_array"] = breakdown;
  summary["solver_bytes_per_voxel"] = double(solver.memory_bytes()) / double(image.voxels());
  summary["phase_image_bytes_per_rank"] = image_bytes_;  // the scene's image as a rank holds it (largest rank)
  if (setup_.output.fields_mode != "none") summary["fields_file"] = fields_stem_ + ".xdmf";
  const int writes = checkpoint_ ? checkpoint_->writes() : 0;
  summary["checkpoint"] = {{"writes", writes},
                           {"write_time_s", checkpoint_ ? checkpoint_->write_seconds() : 0.0},
                           {"last_bytes", checkpoint_ ? checkpoint_->last_bytes() : 0}};
  if (job_.resume)
    summary["resumed"] = {{"from_t", resumed_.t},
                          {"output_steps_before", resumed_.step_log.size() - 1},
                          {"wall_time_s_before", resumed_.wall_seconds}};
  return summary;
}

bool FftRun::run() {
  const MixedControl& control = setup_.control;
  const double t_end = control.times.back();
  auto want_fields = [&](double t) { return setup_.output.wants_fields(t, t_end); };
  auto on_step = [this](const rve::RveStep& s, const rve::RveFields* f) { this->on_step(s, f); };
  rve::RveRunResult result =
      run_rve_engine(*solver_, control, on_step, want_fields, *record_, job_.resume ? resumed_.t : 0.0);
  progress_->finish();
  static_cast<rve::RveCounts&>(result) += resumed_.totals;  // the whole run's totals
  save_final_checkpoint(result);
  for (auto& note : checkpoint_notes_) result.log.push_back(std::move(note));
  for (const auto& line : result.log)
    if (!options_.quiet && root_) std::cerr << "[rve " << job_.scene.name << "] " << line << "\n";
  sink_.flush();
  if (writer_) writer_->close();
  if (!root_) return result.completed;
  nlohmann::json s = summary();
  if (!finish_rve_summary(s, result, record_->step_log, solver_->memory_bytes(), sink_, wall_start_,
                          resumed_.wall_seconds, job_.warnings))
    return false;
  if (!options_.quiet)
    std::cerr << "softhom rve: " << record_->step_log.size() - 1 << " steps, " << result.newton_iterations
              << " Newton / " << result.krylov_iterations << " Krylov iterations, " << result.wall_seconds
              << " s → " << sink_.where("") << "\n";
  return true;
}

}  // namespace

bool run_fft_rve(RveJob& job, FftRveJob& fft, Sink& sink, const RunOptions& options) {
  if (job.microstructure_only) {
    sink.prepare();
    // Under an MPI launcher the image is written by rank 0; the others have nothing to do.
    if (mpi::world_rank() == 0) write_microstructure(job, fft.setup, sink, options);
    return true;
  }
  return FftRun(job, fft.setup, sink, options).run();
}

}  // namespace softhom::jobs
