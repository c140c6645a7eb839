// softhom point: the material-point driver on a scene's [material] and [load].
#include <chrono>
#include <iostream>

#include "commands.hpp"
#include "point_output.hpp"
#include "run_control.hpp"
#include "scene_source.hpp"
#include "softhom/io/files.hpp"
#include "softhom/io/scene.hpp"
#include "softhom/io/summary.hpp"
#include "softhom/materials/driver.hpp"
#include "softhom/materials/errors.hpp"

namespace softhom::app {

PointSolverOptions parse_point_solver(const toml::table& scene) {
  PointSolverOptions o;
  if (const auto* t = scene["solver"].as_table()) {
    io::check_keys(*t, "solver", {"tolerance", "max_iterations", "max_cutbacks"});
    o.tolerance = io::get_number_or(*t, "tolerance", "solver", o.tolerance);
    o.max_iterations = int(io::get_number_or(*t, "max_iterations", "solver", o.max_iterations));
    o.max_cutbacks = int(io::get_number_or(*t, "max_cutbacks", "solver", o.max_cutbacks));
    if (!(o.tolerance > 0.0 && o.tolerance < 1.0))
      throw InputError("solver.tolerance", std::to_string(o.tolerance), "must lie in (0, 1)");
    if (o.max_iterations < 1) throw InputError("solver.max_iterations", std::to_string(o.max_iterations), "must be >= 1");
    if (o.max_cutbacks < 0) throw InputError("solver.max_cutbacks", std::to_string(o.max_cutbacks), "must be >= 0");
  }
  return o;
}

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
  io::check_keys(scene.table, "", {"material", "load", "solver", "description"});
  const auto* material_table = scene.table["material"].as_table();
  if (!material_table) throw InputError("material", "", "missing [material] table");
  const auto* load_table = scene.table["load"].as_table();
  if (!load_table) throw InputError("load", "", "missing [load] table");
  const MaterialPtr material = build_material(io::parse_material(*material_table, "material"));
  const MixedControl control = io::parse_load(*load_table, "load");
  const PointSolverOptions options = parse_point_solver(scene.table);

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
  const LoadedScene scene = load_scene_or_default(options, "point_uniaxial_ecoflex");
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
