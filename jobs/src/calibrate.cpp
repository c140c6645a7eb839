// softhom calibrate: fits the homogeneous Gent + HGO (+ QLV) model to curves (RVE runs, campaign
// stores, experiments) with the material-point driver under each curve's own mixed control.
// Writes OUT/material.toml (a `softhom point` [material] table), OUT/summary.json, OUT/response.csv
// (curve name, index, x, data, model), OUT/curves/<name>.csv, OUT/material.feb + OUT/material.inp (FEBio
// and Abaqus cards, docs/material-cards.md) and, when python3 + matplotlib are available,
// OUT/fit.png (studies/plot_calibration.py).
#include <algorithm>
#include <cstdlib>
#include <iostream>
#include <optional>
#include <sstream>
#include <unistd.h>

#include "softhom/io/scene.hpp"
#include "softhom/jobs/jobs.hpp"
#include "softhom/jobs/run_control.hpp"
#include "softhom/io/summary.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/studies/calibration.hpp"
#include "softhom/studies/material_cards.hpp"

namespace softhom::jobs {
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
  candidates.push_back(fs::path(__FILE__).parent_path().parent_path().parent_path() / "studies" / "plot_calibration.py");
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

/// The fit on stderr: free parameters, per-curve R² / NRMSE, the cards' stress differences, warnings.
void report_fit(const studies::CalibrationResult& result, const studies::CardComparison* cards) {
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
  if (cards) {
    double febio_max = 0.0, abaqus_max = 0.0;
    for (const auto& d : cards->febio) febio_max = std::max(febio_max, d.ok ? d.max_rel : 0.0);
    for (const auto& d : cards->abaqus) abaqus_max = std::max(abaqus_max, d.ok ? d.max_rel : 0.0);
    s << "  cards: material.feb (max rel. stress difference " << febio_max << "), material.inp (Yeoh matrix, "
      << abaqus_max << ")\n";
    for (const auto& w : cards->warnings) s << "  warning: " << w << "\n";
  }
  std::cerr << s.str() << "[calibrate] " << result.model_evaluations << " model evaluations, " << result.wall_time_s
            << " s\n";
}

/// fit.png from the files in `out` (studies/plot_calibration.py with a python3 that has matplotlib).
/// SOFTHOM_PLOT_CALIBRATION=off skips it (batch runs that need no figure: the figure costs more than a
/// small fit).
void plot_fit(const std::filesystem::path& out, bool quiet) {
  if (const char* env = std::getenv("SOFTHOM_PLOT_CALIBRATION"); env && std::string(env) == "off") return;
  const std::filesystem::path script = find_plot_script();
  if (script.empty()) {
    std::cerr << "softhom calibrate: warning: studies/plot_calibration.py not found (set SOFTHOM_PLOT_CALIBRATION): no fit.png\n";
  } else if (const std::string python = find_python(); python.empty()) {
    std::cerr << "softhom calibrate: warning: python3 with matplotlib not available: no fit.png\n";
  } else {
    const std::string cmd =
        python + " " + shell_quote(script.string()) + " " + shell_quote(out.string()) + (quiet ? " >/dev/null" : "");
    if (std::system(cmd.c_str()) != 0) std::cerr << "softhom calibrate: warning: plotting failed (" << cmd << ")\n";
  }
}

}  // namespace

CalibrationJob parse_calibration(LoadedScene scene, const std::filesystem::path& base) {
  const std::filesystem::path dir =
      !base.empty() ? base : !scene.file.empty() ? std::filesystem::absolute(scene.file).parent_path() : ".";
  CalibrationJob job;
  job.input = studies::parse_calibration(scene.table, dir);
  job.scene = std::move(scene);
  return job;
}

CalibrationOutcome run_calibration(const CalibrationJob& job, Sink& sink, const RunOptions& options, bool cli_files) {
  const studies::CalibrationInput& input = job.input;
  std::size_t n_free = input.model.free_indices().size(), n_fit = 0;
  for (const auto& c : input.curves) n_fit += c.holdout ? 0 : 1;
  if (!options.quiet)
    std::cerr << "[calibrate] " << n_free << " free parameters, " << n_fit << " fit + " << input.curves.size() - n_fit
              << " holdout curves, " << input.solver.starts << " starts\n";
  auto progress = [&](const std::string& line) {
    if (!options.quiet) std::cerr << "[calibrate] " << line << "\n";
  };
  CalibrationOutcome outcome;
  outcome.result = studies::calibrate(input, progress);
  const studies::CalibrationResult& result = outcome.result;
  outcome.summary = io::summary_base("calibrate", job.scene.file, job.scene.table);
  const nlohmann::json fields = studies::result_json(input, result);  // named: items() must not outlive it
  for (const auto& [k, v] : fields.items()) outcome.summary[k] = v;
  if (stop_requested()) io::set_run_status(outcome.summary, false, interruption_message());
  outcome.material_toml = studies::material_toml(input.model, result.values);
  outcome.comparison_csv = studies::comparison_csv(result);
  const std::filesystem::path out = sink.directory();
  std::optional<studies::CardComparison> cards;
  if (!out.empty()) {
    sink.prepare();
    studies::write_calibration_files(out, input, result);
    // FEBio and Abaqus cards of the same material (docs/material-cards.md); their stress differences on
    // the calibration load paths go into the cards' comments.
    // (Not after a stop request: their comparison runs would stop at once, and their comments mislead.)
    if (cli_files && !stop_requested()) cards = studies::write_material_cards(out, input, result);
  }
  sink.write_summary(outcome.summary);
  if (!options.quiet) report_fit(result, cards ? &*cards : nullptr);
  if (cli_files && input.plot && !out.empty() && !stop_requested()) plot_fit(out, options.quiet);
  if (stop_requested())
    std::cerr << "softhom calibrate: " << interruption_message() << "; material.toml holds "
              << (result.best_start >= 0 ? "the best parameters so far, not a converged fit\n" : "the initial values\n");
  else if (!result.success)
    std::cerr << "softhom calibrate: no start converged; material.toml holds the initial values\n";
  else if (!options.quiet && !out.empty()) std::cerr << "softhom calibrate: " << (out / "material.toml").string() << "\n";
  return outcome;
}

}  // namespace softhom::jobs
