// softhom point: the material-point driver on a scene's [material] and [load].
#include <chrono>
#include <iostream>

#include "cmd_keys.hpp"
#include "commands.hpp"
#include "point_output.hpp"
#include "run_control.hpp"
#include "scene_source.hpp"
#include "softhom/io/files.hpp"
#include "softhom/io/scene.hpp"
#include "softhom/io/summary.hpp"
#include "softhom/materials/driver.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/materials/scene_keys.hpp"

namespace softhom::app {

io::CsvTable point_table(std::size_t fiber_families) {
  std::vector<std::string> columns{"t"};
  for (const char* name : {"F", "P", "sigma"})
    for (int i = 1; i <= 3; ++i)
      for (int j = 1; j <= 3; ++j) columns.push_back(name + std::to_string(i) + std::to_string(j));
  for (std::size_t f = 1; f <= fiber_families; ++f) columns.push_back("fiber" + std::to_string(f) + "_angle_deg");
  return io::CsvTable(columns);
}

std::vector<double> point_row(const PointState& s) {
  std::vector<double> row{s.t};
  for (const Mat3* m : {&s.F, &s.P, &s.sigma})
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) row.push_back((*m)(i, j));
  row.insert(row.end(), s.fiber_angle_deg.begin(), s.fiber_angle_deg.end());
  return row;
}

PointRun run_point_scene(const LoadedScene& scene, const std::filesystem::path& out, bool quiet) {
  const auto wall_start = std::chrono::steady_clock::now();
  const PointScene parsed = parse_point_scene(scene.table);
  const MaterialPtr material = build_material(parsed.material);
  const MixedControl& control = parsed.control;
  const PointSolverOptions& options = parsed.solver;

  const double t_end = control.times.back();
  // Rows reach response.csv as the steps converge (io::ProgressiveCsv), so a stopped or killed run
  // keeps them; the progress shows every tenth of the load.
  io::ProgressiveCsv csv(out / "response.csv", point_table(material->fiber_directions().size()).columns());
  std::vector<PointState> converged;
  Progress progress(quiet);
  int tenths_shown = -1;
  auto on_step = [&](const PointState& s) {
    csv.add_row(point_row(s));
    converged.push_back(s);
    const int tenths = t_end > 0.0 ? int(s.t / t_end * 10) : 10;
    if (tenths != tenths_shown || s.t == t_end) {
      progress.update("[point " + scene.name + "] t = " + format_number(s.t) + " / " + format_number(t_end));
      tenths_shown = tenths;
    }
    stop_point(converged.size() - 1);
  };
  PointRun run;
  try {
    run.result = run_material_point(*material, control, options, on_step);
  } catch (const RunInterrupted&) {
    run.result.steps = std::move(converged);
    run.result.completed = false;
  }
  if (!run.result.completed && stop_requested()) run.result.error = interruption_message();
  progress.finish();
  for (const auto& line : run.result.log)
    if (!quiet) std::cerr << "[point " << scene.name << "] " << line << "\n";
  csv.flush();

  nlohmann::json summary = io::summary_base("point", scene.file, scene.table);
  summary["material"] = material->describe();
  summary["load"] = control.name;
  io::set_run_status(summary, run.result.completed, run.result.error);
  summary["columns"] = io::columns_json(csv.table().columns());
  summary["steps"] = run.result.steps.empty() ? 0 : run.result.steps.size() - 1;
  summary["newton_iterations"] = run.result.total_newton_iterations;
  summary["cutbacks"] = run.result.cutbacks;
  summary["warnings"] = run.result.log;
  summary["wall_time_s"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  io::write_summary(out, summary);
  return run;
}

int run_point(const CommandOptions& options) {
  const LoadedScene scene = load_scene_or_default(options, default_scene_name("point"));
  const PointRun run = run_point_scene(scene, options.out, options.quiet);
  if (!run.result.completed) {
    std::cerr << "softhom point: stopped early: " << run.result.error << "\n"
              << "softhom point: " << run.result.steps.size() << " converged rows kept in "
              << (options.out / "response.csv").string() << "\n";
    return run_exit_code(false);
  }
  if (!options.quiet)
    std::cerr << "softhom point: " << run.result.steps.size() - 1 << " steps, "
              << run.result.total_newton_iterations << " Newton iterations → " << options.out.string() << "\n";
  return 0;
}

}  // namespace softhom::app
