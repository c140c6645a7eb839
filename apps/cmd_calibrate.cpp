// softhom calibrate: fits the homogeneous Gent + HGO (+ QLV) model to curves (RVE runs, campaign
// stores, experiments) with the material-point driver under each curve's own mixed control.
// Writes OUT/material.toml (a `softhom point` [material] table), OUT/summary.json, OUT/response.csv
// (curve name, index, x, data, model), OUT/curves/<name>.csv, OUT/material.feb + OUT/material.inp (FEBio
// and Abaqus cards, docs/material-cards.md) and, when python3 + matplotlib are available,
// OUT/fit.png (studies/plot_calibration.py).
#include <algorithm>
#include <cstdlib>
#include <iostream>
#include <sstream>
#include <unistd.h>

#include "commands.hpp"
#include "softhom/io/scene.hpp"
#include "softhom/io/summary.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/studies/calibration.hpp"
#include "softhom/studies/material_cards.hpp"

namespace softhom::app {
namespace {

std::string shell_quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

/// studies/plot_calibration.py: $SOFTHOM_PLOT_CALIBRATION, next to this source file (a build from the
/// source tree), relative to the executable, or relative to the working directory.
std::filesystem::path find_plot_script() {
  namespace fs = std::filesystem;
  std::vector<fs::path> candidates;
  if (const char* env = std::getenv("SOFTHOM_PLOT_CALIBRATION")) candidates.emplace_back(env);
  candidates.push_back(fs::path(__FILE__).parent_path().parent_path() / "studies" / "plot_calibration.py");
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    candidates.push_back(exe.parent_path() / ".." / ".." / "studies" / "plot_calibration.py");
    candidates.push_back(exe.parent_path() / ".." / "share" / "softhom" / "plot_calibration.py");
  }
  candidates.push_back(fs::current_path(ec) / "studies" / "plot_calibration.py");
  for (const auto& c : candidates)
    if (fs::exists(c, ec)) return c;
  return {};
}

/// A Python with matplotlib: $SOFTHOM_PYTHON, python3 on PATH, or the system /usr/bin/python3 (a
/// pyenv/venv python3 on PATH often lacks the Debian python3-matplotlib).
std::string find_python() {
  std::vector<std::string> candidates;
  if (const char* env = std::getenv("SOFTHOM_PYTHON")) candidates.emplace_back(env);
  candidates.emplace_back("python3");
  candidates.emplace_back("/usr/bin/python3");
  for (const auto& p : candidates) {
    const std::string cmd = shell_quote(p) + " -c 'import matplotlib' >/dev/null 2>&1";
    if (std::system(cmd.c_str()) == 0) return shell_quote(p);
  }
  return {};
}

}  // namespace

int run_calibrate(const CommandOptions& options) {
  if (options.scene.empty())
    throw InputError("scene", "", "calibrate needs a calibration file: softhom calibrate CALIBRATION.toml --out DIR "
                                  "(example: studies/calibrations/example_point.toml)");
  const toml::table table = io::load_scene(options.scene);
  const studies::CalibrationInput input =
      studies::parse_calibration(table, std::filesystem::absolute(options.scene).parent_path());

  std::size_t n_free = input.model.free_indices().size(), n_fit = 0;
  for (const auto& c : input.curves) n_fit += c.holdout ? 0 : 1;
  if (!options.quiet)
    std::cerr << "[calibrate] " << n_free << " free parameters, " << n_fit << " fit + " << input.curves.size() - n_fit
              << " holdout curves, " << input.solver.starts << " starts\n";
  auto progress = [&](const std::string& line) {
    if (!options.quiet) std::cerr << "[calibrate] " << line << "\n";
  };
  const studies::CalibrationResult result = studies::calibrate(input, progress);

  std::filesystem::create_directories(options.out);
  studies::write_calibration_files(options.out, input, result);
  // FEBio and Abaqus cards of the same material (docs/material-cards.md); their stress differences on
  // the calibration load paths go into the cards' comments.
  const studies::CardComparison cards = studies::write_material_cards(options.out, input, result);
  nlohmann::json summary = io::summary_base("calibrate", options.scene, table);
  const nlohmann::json fields = studies::result_json(input, result);  // named: items() must not outlive it
  for (const auto& [k, v] : fields.items()) summary[k] = v;
  io::write_summary(options.out, summary);

  if (!options.quiet) {
    std::ostringstream s;
    s.precision(6);
    for (const auto& p : result.parameters) {
      if (!p.free) continue;
      s << "  " << p.name << " = " << p.value;
      if (p.std_error) s << " ± " << *p.std_error;
      if (p.at_bound) s << "  (at bound)";
      s << "\n";
    }
    for (const auto& c : result.curves) {
      s << "  " << (c.holdout ? "holdout " : "fit     ") << c.name << ": ";
      if (c.ok) s << "R² = " << c.r2 << ", NRMSE = " << c.nrmse << "\n";
      else s << "not evaluable: " << c.error << "\n";
    }
    for (const auto& w : result.warnings) s << "  warning: " << w << "\n";
    double febio_max = 0.0, abaqus_max = 0.0;
    for (const auto& d : cards.febio) febio_max = std::max(febio_max, d.ok ? d.max_rel : 0.0);
    for (const auto& d : cards.abaqus) abaqus_max = std::max(abaqus_max, d.ok ? d.max_rel : 0.0);
    s << "  cards: material.feb (max rel. stress difference " << febio_max << "), material.inp (Yeoh matrix, "
      << abaqus_max << ")\n";
    for (const auto& w : cards.warnings) s << "  warning: " << w << "\n";
    std::cerr << s.str() << "[calibrate] " << result.model_evaluations << " model evaluations, " << result.wall_time_s
              << " s\n";
  }

  if (input.plot) {
    const std::filesystem::path script = find_plot_script();
    if (script.empty()) {
      std::cerr << "softhom calibrate: warning: studies/plot_calibration.py not found (set SOFTHOM_PLOT_CALIBRATION): no fit.png\n";
    } else if (const std::string python = find_python(); python.empty()) {
      std::cerr << "softhom calibrate: warning: python3 with matplotlib not available: no fit.png\n";
    } else {
      const std::string cmd = python + " " + shell_quote(script.string()) + " " + shell_quote(options.out.string()) +
                              (options.quiet ? " >/dev/null" : "");
      if (std::system(cmd.c_str()) != 0) std::cerr << "softhom calibrate: warning: plotting failed (" << cmd << ")\n";
    }
  }

  if (!result.success) {
    std::cerr << "softhom calibrate: no start converged; material.toml holds the initial values\n";
    return 1;
  }
  if (!options.quiet) std::cerr << "softhom calibrate: " << (options.out / "material.toml").string() << "\n";
  return 0;
}

}  // namespace softhom::app
