#pragma once
// Output pieces shared by the two RVE engines' jobs (rve_fft.cpp, rve_fe.cpp), so that both write the
// same [output] semantics and the same summary.json step log.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <filesystem>
#include <iostream>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>
#include <toml++/toml.h>

#include "softhom/io/fields.hpp"
#include "softhom/io/files.hpp"
#include "softhom/io/scene.hpp"
#include "softhom/io/summary.hpp"
#include "softhom/jobs/run_control.hpp"
#include "softhom/jobs/sink.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/rve/fft_solver.hpp"
#include "softhom/studies/rve_scene.hpp"

namespace softhom::jobs {

/// The [output] table of an RVE scene, declared with the scene's other keys (studies/rve_scene.hpp).
using studies::RveOutputSettings;
using studies::parse_rve_output;

/// The counters of rve::RveCounts under their summary.json names (run totals, checkpoints).
inline constexpr std::pair<const char*, int rve::RveCounts::*> rve_count_fields[] = {
    {"newton_iterations", &rve::RveCounts::newton_iterations},
    {"krylov_iterations", &rve::RveCounts::krylov_iterations},
    {"substeps", &rve::RveCounts::substeps},
    {"cutbacks", &rve::RveCounts::cutbacks},
    {"shifted_solves", &rve::RveCounts::shifted_solves},
    {"minres_solves", &rve::RveCounts::minres_solves},
    {"discarded_krylov_iterations", &rve::RveCounts::discarded_krylov_iterations},
    {"continuation_iterations", &rve::RveCounts::continuation_iterations}};

inline nlohmann::json rve_counts_json(const rve::RveCounts& c) {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& [name, member] : rve_count_fields) j[name] = c.*member;
  return j;
}

inline rve::RveCounts rve_counts_from_json(const nlohmann::json& j) {
  rve::RveCounts c;
  for (const auto& [name, member] : rve_count_fields) c.*member = j.value(name, 0);
  return c;
}

/// One entry of summary.json "steps".
inline nlohmann::json rve_step_log_entry(const rve::RveStep& s) {
  return {{"t", s.t},
          {"newton_iterations", s.newton_iterations},
          {"krylov_iterations", s.krylov_iterations},
          {"substeps", s.substeps},
          {"cutbacks", s.cutbacks},
          {"shifted_solves", s.shifted_solves},
          {"minres_solves", s.minres_solves},
          {"continuation_iterations", s.continuation_iterations},
          {"residuals", s.residuals},
          {"wall_time_s", s.wall_seconds}};
}

/// The result of a run whose step callback threw RunInterrupted: the converged steps recorded so far,
/// their iteration totals, and the interruption as the error.
inline rve::RveRunResult interrupted_rve_result(std::vector<rve::RveStep> steps, double wall_seconds) {
  rve::RveRunResult r;
  r.steps = std::move(steps);
  r.completed = false;
  r.error = interruption_message();
  for (const auto& s : r.steps) {
    r.newton_iterations += s.newton_iterations;
    r.krylov_iterations += s.krylov_iterations;
    r.cutbacks += s.cutbacks;
  }
  r.wall_seconds = wall_seconds;
  return r;
}

/// The step callback's own record of a run: the rows (to the sink as they converge, and kept for the
/// checkpoints), the summary step log, and the converged steps (kept for an interrupted run, whose
/// solver result is lost in the unwinding).
struct RveRecorder {
  Sink& sink;
  io::CsvTable rows;
  nlohmann::json step_log = nlohmann::json::array();
  std::vector<rve::RveStep> steps;

  RveRecorder(Sink& s, const std::vector<std::string>& columns) : sink(s), rows(columns) {
    sink.open_table("response", columns);
  }
  void record(const rve::RveStep& s, const std::vector<double>& row) {
    add_row(row);
    step_log.push_back(rve_step_log_entry(s));
    steps.push_back(s);
  }
  /// The rows and step log of the run a continued run takes over (`steps` holds this run's only).
  void take_over(const std::vector<std::vector<double>>& earlier_rows, const nlohmann::json& log) {
    for (const auto& row : earlier_rows) add_row(row);
    step_log = log;
  }

 private:
  void add_row(const std::vector<double>& row) {
    rows.add_row(row);
    sink.add_row("response", row);
  }
};

/// Runs an RVE engine (FFT or FE) with the command's step callback; a RunInterrupted thrown by the
/// callback (stop_point) becomes the result of the steps converged so far, marked interrupted.
/// `t_start` > 0: a continued run (FFT engine, its state loaded from a checkpoint).
template <class Solver, class OnStep, class WantFields>
rve::RveRunResult run_rve_engine(Solver& solver, const MixedControl& control, OnStep&& on_step, WantFields&& want_fields,
                                 RveRecorder& record, double t_start = 0.0) {
  const auto start = std::chrono::steady_clock::now();
  rve::RveRunResult result;
  try {
    if constexpr (requires { solver.run(control, on_step, want_fields, t_start); })
      result = solver.run(control, on_step, want_fields, t_start);
    else
      result = solver.run(control, on_step, want_fields);
  } catch (const RunInterrupted&) {
    result = interrupted_rve_result(std::move(record.steps),
                                    std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  }
  if (!result.completed && stop_requested()) result.error = interruption_message();
  return result;
}

/// One progress line of an RVE step.
inline std::string rve_progress_line(const std::string& tag, const rve::RveStep& s, double t_end) {
  return tag + "t = " + progress_number(s.t) + " / " + progress_number(t_end) + "  P11 = " + progress_number(s.P(0, 0)) +
         "  Newton " + std::to_string(s.newton_iterations) + ", Krylov " + std::to_string(s.krylov_iterations);
}

/// Vectors (3 per node: displacements, coordinates) from grid-frame into load-frame components: the
/// fields files show the cell in the load frame (docs/outputs.md).
inline std::vector<double> vectors_in_load_frame(const std::vector<double>& grid_frame, double fiber_angle_deg) {
  const Mat3 R = rve::grid_rotation(fiber_angle_deg);
  std::vector<double> out(grid_frame.size());
  for (std::size_t p = 0; p + 2 < grid_frame.size(); p += 3) {
    Eigen::Map<Vec3> to(&out[p]);
    to = R * Eigen::Map<const Vec3>(&grid_frame[p]);
  }
  return out;
}

/// Root attributes of an RVE fields.h5 beyond the ones every field file has (fields.hpp): where the
/// cells sit and in which frame the tensors are given.
inline void set_rve_field_attributes(io::FieldWriter& w, double fiber_angle_deg, const std::string& engine) {
  const std::string a = format_number(fiber_angle_deg);
  w.set_attribute("frame",
                  "load frame (e1 load direction, e2 in-plane transverse, e3 plate normal): tensor and vector "
                  "components, the node coordinates and the displacement; the cell (" + engine +
                  ") is the fiber-aligned grid turned into the load frame, grid axes g1 = (cos a, -sin a, 0), "
                  "g2 = (0, 0, -1), g3 = fiber = (sin a, cos a, 0) in load-frame coordinates, a = fiber_angle_deg = " +
                  a);
  w.set_attribute("fiber_angle_deg", a);
}

/// The run-result keys of summary.json common to both engines; hands the summary to the sink and,
/// when the run stopped early, says so on stderr. Returns whether the run completed.
inline bool finish_rve_summary(nlohmann::json& summary, const rve::RveRunResult& result, const nlohmann::json& step_log,
                               std::size_t solver_memory_bytes, Sink& sink,
                               std::chrono::steady_clock::time_point wall_start, double earlier_wall_seconds = 0.0,
                               const std::vector<std::string>& input_warnings = {}) {
  io::set_run_status(summary, result.completed, result.error);
  summary["steps"] = step_log;
  summary["newton_iterations"] = result.newton_iterations;
  summary["krylov_iterations"] = result.krylov_iterations;
  summary["cutbacks"] = result.cutbacks;
  nlohmann::json warnings = input_warnings;  // plausibility of the phases first, then the run's notes
  for (const auto& w : result.log) warnings.push_back(w);
  summary["warnings"] = warnings;
  summary["solver_memory_bytes"] = solver_memory_bytes;
  summary["peak_memory_bytes"] = io::peak_memory_bytes();
  summary["peak_memory_bytes_per_voxel"] = nullptr;  // voxel engines only
  if (summary.contains("voxels") && summary["voxels"].is_number() && summary["voxels"].get<double>() > 0.0)
    summary["peak_memory_bytes_per_voxel"] = double(io::peak_memory_bytes()) / summary["voxels"].get<double>();
  summary["solve_time_s"] = result.wall_seconds;
  summary["wall_time_s"] =
      earlier_wall_seconds + std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  sink.write_summary(summary);
  if (!result.completed)
    std::cerr << "softhom rve: stopped early: " << result.error << "\nsofthom rve: " << step_log.size()
              << " converged rows kept in " << sink.where("response.csv") << "\n";
  return result.completed;
}

}  // namespace softhom::jobs
