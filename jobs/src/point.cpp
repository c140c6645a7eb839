// softhom point: the material-point driver on a scene's [material] and [load].
#include <chrono>
#include <iostream>

#include "softhom/io/files.hpp"
#include "softhom/io/summary.hpp"
#include "softhom/jobs/jobs.hpp"
#include "softhom/jobs/run_control.hpp"
#include "softhom/materials/driver.hpp"
#include "softhom/materials/plausibility.hpp"
#include "softhom/materials/scene_keys.hpp"

namespace softhom::jobs {
namespace {

std::vector<std::string> point_columns(std::size_t fiber_families) {
  std::vector<std::string> columns{"t"};
  for (const char* name : {"F", "P", "sigma"})
    for (int i = 1; i <= 3; ++i)
      for (int j = 1; j <= 3; ++j) columns.push_back(name + std::to_string(i) + std::to_string(j));
  for (std::size_t f = 1; f <= fiber_families; ++f) columns.push_back("fiber" + std::to_string(f) + "_angle_deg");
  return columns;
}

std::vector<double> point_row(const PointState& s) {
  std::vector<double> row{s.t};
  for (const Mat3* m : {&s.F, &s.P, &s.sigma})
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) row.push_back((*m)(i, j));
  row.insert(row.end(), s.fiber_angle_deg.begin(), s.fiber_angle_deg.end());
  return row;
}

nlohmann::json point_summary(const PointJob& job, const PointRunResult& result, const std::vector<std::string>& columns,
                             std::chrono::steady_clock::time_point wall_start) {
  nlohmann::json summary = io::summary_base("point", job.scene.file, job.scene.table);
  summary["material"] = job.material->describe();
  summary["load"] = job.parsed.control.name;
  io::set_run_status(summary, result.completed, result.error);
  summary["columns"] = io::columns_json(columns);
  summary["steps"] = result.steps.empty() ? 0 : result.steps.size() - 1;
  summary["newton_iterations"] = result.total_newton_iterations;
  summary["cutbacks"] = result.cutbacks;
  nlohmann::json warnings = job.warnings;
  for (const auto& w : result.log) warnings.push_back(w);
  summary["warnings"] = warnings;
  summary["wall_time_s"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  return summary;
}

}  // namespace

PointJob parse_point(LoadedScene scene) {
  PointJob job;
  job.parsed = parse_point_scene(scene.table);
  job.material = build_material(job.parsed.material);
  job.warnings = plausibility_warnings(*job.material, MaterialRole::any, "material");
  job.scene = std::move(scene);
  return job;
}

PointRunResult run_point(const PointJob& job, Sink& sink, const RunOptions& options) {
  print_warnings("softhom point", job.warnings, options.quiet);
  const auto wall_start = std::chrono::steady_clock::now();
  const MixedControl& control = job.parsed.control;
  const double t_end = control.times.back();
  // Rows reach the sink as the steps converge (the file sink keeps them on disk), so a stopped or
  // killed run keeps them; the progress shows every tenth of the load.
  const std::vector<std::string> columns = point_columns(job.material->fiber_directions().size());
  sink.open_table("response", columns);
  std::vector<PointState> converged;
  Progress progress(options.quiet);
  int tenths_shown = -1;
  auto on_step = [&](const PointState& s) {
    sink.add_row("response", point_row(s));
    converged.push_back(s);
    const int tenths = t_end > 0.0 ? int(s.t / t_end * 10) : 10;
    if (tenths != tenths_shown || s.t == t_end) {
      progress.update("[point " + job.scene.name + "] t = " + progress_number(s.t) + " / " + progress_number(t_end));
      tenths_shown = tenths;
    }
    stop_point(converged.size() - 1);
  };
  PointRunResult result;
  try {
    result = run_material_point(*job.material, control, job.parsed.solver, on_step);
  } catch (const RunInterrupted&) {
    result.steps = std::move(converged);
    result.completed = false;
  }
  if (!result.completed && stop_requested()) result.error = interruption_message();
  progress.finish();
  for (const auto& line : result.log)
    if (!options.quiet) std::cerr << "[point " << job.scene.name << "] " << line << "\n";
  sink.flush();
  sink.write_summary(point_summary(job, result, columns, wall_start));
  return result;
}

}  // namespace softhom::jobs
