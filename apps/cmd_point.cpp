// softhom point: the material-point driver on a scene's [material] and [load].
#include <chrono>
#include <iostream>

#include "cmd_keys.hpp"
#include "commands.hpp"
#include "point_output.hpp"
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
  auto on_step = [&](const PointState& s) {
    if (!quiet && (s.t == t_end || int(s.t / t_end * 10) != int((s.t - 1e-300) / t_end * 10)))
      std::cerr << "\r[point " << scene.name << "] t = " << s.t << " / " << t_end << "   " << std::flush;
  };
  PointRun run;
  run.result = run_material_point(*material, control, options, on_step);
  if (!quiet) std::cerr << "\n";
  for (const auto& line : run.result.log)
    if (!quiet) std::cerr << "[point " << scene.name << "] " << line << "\n";

  io::CsvTable table = point_table(material->fiber_directions().size());
  for (const auto& s : run.result.steps) table.add_row(point_row(s));
  table.write(out / "response.csv");

  nlohmann::json summary = io::summary_base("point", scene.file, scene.table);
  summary["material"] = material->describe();
  summary["load"] = control.name;
  summary["completed"] = run.result.completed;
  summary["error"] = run.result.error;
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
    return 1;
  }
  if (!options.quiet)
    std::cerr << "softhom point: " << run.result.steps.size() - 1 << " steps, "
              << run.result.total_newton_iterations << " Newton iterations → " << options.out.string() << "\n";
  return 0;
}

}  // namespace softhom::app
