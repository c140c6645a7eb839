// Writing a calibration's results: the fitted material card, summary.json, the data-against-model
// table and the model's response along every curve.
#include "softhom/studies/calibration.hpp"

#include <cmath>
#include <sstream>

#include "softhom/io/files.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/materials/interrupt.hpp"

namespace softhom::studies {
namespace {

const std::vector<std::string>& tensor_columns() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n{"t"};
    for (const char* name : {"F", "P", "sigma"})
      for (int i = 1; i <= 3; ++i)
        for (int j = 1; j <= 3; ++j) n.push_back(name + std::to_string(i) + std::to_string(j));
    return n;
  }();
  return names;
}

}  // namespace

std::string material_toml(const CalibrationModel& model, const std::vector<double>& v, const std::string& header) {
  std::ostringstream s;
  if (!header.empty()) {
    std::istringstream h(header);
    std::string line;
    while (std::getline(h, line)) s << "# " << line << "\n";
  }
  s << "[material]\n";
  s << "law = \"" << (model.GL >= 0 ? "fiber-composite" : "gent") << "\"\n";
  s << "G = " << format_number(v[model.G]) << "\n";
  if (model.GL >= 0)
    s << "GL = " << format_number(v[model.GL]) << "\nGT = " << format_number(v[model.GT]) << "\nEf = " << format_number(v[model.Ef])
      << "\n";
  s << "Jm = " << format_number(v[model.Jm]) << "\n";
  s << "K = " << format_number(v[model.K]) << "\n";
  if (!model.fibers.empty()) {
    s << "fiber_invariant = \"" << (model.invariant == FiberInvariant::full ? "full" : "isochoric") << "\"\n";
    s << "tension_only = " << (model.tension_only ? "true" : "false") << "\n";
    s << "k1 = " << format_number(v[model.k1]) << "\n";
    s << "k2 = " << format_number(v[model.k2]) << "\n";
    if (model.kappa >= 0) s << "kappa = " << format_number(v[model.kappa]) << "\n";
    for (const CalFiber& f : model.fibers) {
      s << "\n[[material.fibers]]\nangle_deg = " << format_number(v[f.angle_parameter]) << "\n";
      if (f.plus_minus) s << "\n[[material.fibers]]\nangle_deg = " << format_number(-v[f.angle_parameter]) << "\n";
    }
  }
  if (model.viscoelastic) {
    const MaterialSpec spec = model.spec(v);
    s << "\n[material.viscoelastic]\ng_inf = " << format_number(spec.prony->g_inf) << "\nterms = [";
    for (std::size_t k = 0; k < spec.prony->terms.size(); ++k)
      s << (k ? ", " : "") << "{g = " << format_number(spec.prony->terms[k].g) << ", tau = " << format_number(spec.prony->terms[k].tau) << "}";
    s << "]\n";
  }
  return s.str();
}

nlohmann::json result_json(const CalibrationInput& in, const CalibrationResult& res) {
  using nlohmann::json;
  auto finite_or_null = [](double x) { return std::isfinite(x) ? json(x) : json(nullptr); };
  json j;
  j["success"] = res.success;
  json params = json::array();
  std::vector<std::string> free_names;
  for (const auto& p : res.parameters) {
    json q{{"name", p.name}, {"value", p.value}, {"free", p.free}};
    if (p.free) {
      free_names.push_back(p.name);
      q["initial"] = p.initial;
      q["min"] = p.min;
      q["max"] = p.max;
      q["at_bound"] = p.at_bound;
      q["std_error"] = p.std_error ? finite_or_null(*p.std_error) : json(nullptr);
      q["rel_std_error"] = p.std_error && p.value != 0.0 ? finite_or_null(*p.std_error / std::abs(p.value)) : json(nullptr);
    }
    params.push_back(q);
  }
  j["parameters"] = params;
  json corr = json::array();
  for (int a = 0; a < res.correlation.rows(); ++a) {
    json row = json::array();
    for (int b = 0; b < res.correlation.cols(); ++b) row.push_back(finite_or_null(res.correlation(a, b)));
    corr.push_back(row);
  }
  j["correlation"] = {{"parameters", free_names}, {"matrix", corr}};
  j["fit"] = {{"cost", finite_or_null(res.final_cost)},
              {"cost_definition", "0.5 * sum_c weight_c * NRMSE_c^2 over fit curves"},
              {"residual_variance", finite_or_null(res.residual_variance)},
              {"residuals", res.residuals},
              {"dof", res.dof},
              {"jtj_condition", finite_or_null(res.jtj_condition)},
              {"best_start", res.best_start},
              {"method", in.solver.dogleg ? "dogleg" : "levenberg_marquardt"}};
  json curves = json::array();
  double hold_sum = 0.0, fit_sum = 0.0;
  int hold_n = 0, fit_n = 0;
  for (std::size_t i = 0; i < res.curves.size(); ++i) {
    const CurveFit& f = res.curves[i];
    const CalCurve& c = in.curves[i];
    json q{{"index", i}, {"name", f.name}, {"role", f.holdout ? "holdout" : "fit"}, {"weight", f.weight},
           {"file", c.file.string()}, {"load", c.control.name}, {"x", c.x}, {"y", c.y}, {"points", f.points},
           {"ok", f.ok}};
    if (f.ok) {
      q["r2"] = f.r2;
      q["nrmse"] = f.nrmse;
      q["rmse"] = f.rmse;
      q["max_abs_error"] = f.max_abs_error;
      (f.holdout ? hold_sum : fit_sum) += f.nrmse;
      ++(f.holdout ? hold_n : fit_n);
    } else {
      q["error"] = f.error;
    }
    curves.push_back(q);
  }
  j["curves"] = curves;
  j["mean_nrmse_fit"] = fit_n ? json(fit_sum / fit_n) : json(nullptr);
  j["mean_nrmse_holdout"] = hold_n ? json(hold_sum / hold_n) : json(nullptr);
  json starts = json::array();
  for (const auto& s : res.starts)
    starts.push_back({{"initial", s.initial}, {"final", s.final}, {"initial_cost", finite_or_null(s.initial_cost)},
                      {"final_cost", finite_or_null(s.final_cost)}, {"iterations", s.iterations}, {"usable", s.usable},
                      {"termination", s.termination}});
  j["starts"] = starts;
  j["model_evaluations"] = res.model_evaluations;
  j["curve_evaluations"] = res.curve_evaluations;
  j["wall_time_s"] = res.wall_time_s;
  j["warnings"] = res.warnings;
  return j;
}

std::string comparison_csv(const CalibrationResult& res) {
  // The curve column is the curve's name (validated: no comma, quote or newline), the index its
  // position in [[curves]]; numbers in shortest round-trip form like every other response.csv.
  std::string out = "curve,index,x,data,model\n";
  for (std::size_t i = 0; i < res.curves.size(); ++i) {
    const CurveFit& f = res.curves[i];
    if (!f.ok) continue;
    for (std::size_t k = 0; k < f.x.size(); ++k)
      out += f.name + "," + std::to_string(i) + "," + format_number(f.x[k]) + "," + format_number(f.data[k]) + "," +
             format_number(f.model[k]) + "\n";
  }
  return out;
}

void write_calibration_files(const std::filesystem::path& dir, const CalibrationInput& in, const CalibrationResult& res) {
  std::ostringstream header;
  header << "softhom calibrate: fitted Gent + HGO" << (in.model.viscoelastic ? " + QLV" : "") << " material ("
         << (res.success ? "converged" : stop_requested() ? "interrupted: the best parameters so far, NOT a converged fit" : "NOT converged")
         << ", cost " << res.final_cost << ").\n"
         << "A `softhom point` [material] table: cat material.toml load.toml > scene.toml";
  io::write_file_atomic(dir / "material.toml", material_toml(in.model, res.values, header.str()));

  io::write_file_atomic(dir / "response.csv", comparison_csv(res));

  for (const CurveFit& f : res.curves) {
    if (f.run.steps.empty()) continue;
    std::vector<std::string> cols = tensor_columns();
    const std::size_t fam = f.run.steps.front().fiber_angle_deg.size();
    for (std::size_t k = 1; k <= fam; ++k) cols.push_back("fiber" + std::to_string(k) + "_angle_deg");
    io::CsvTable t(cols);
    for (const auto& s : f.run.steps) {
      std::vector<double> row{s.t};
      for (const Mat3* mm : {&s.F, &s.P, &s.sigma})
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j) row.push_back((*mm)(i, j));
      row.insert(row.end(), s.fiber_angle_deg.begin(), s.fiber_angle_deg.end());
      t.add_row(row);
    }
    t.write(dir / "curves" / (f.name + ".csv"));
  }
}

}  // namespace softhom::studies