#pragma once
// Calibration of the homogeneous Gent + HGO (+ QLV Prony) model (spec §2–§4) to stress curves — from
// RVE runs, a campaign store or experiments — by bounded nonlinear least squares (Ceres, Levenberg–
// Marquardt or dogleg trust region) with several starts. Every model evaluation runs the material-point
// driver (run_material_point) with the curve's own mixed control, so an RVE curve and the fitted model
// see exactly the same load.
//
// Input (`softhom calibrate CALIBRATION.toml`):
//   [model]  law = "gent" (optional) or "fiber-composite" (with its GL, GT, Ef, and fibers);
//            G, Jm, K, k1, k2: a number (fixed) or {value, min, max} (free)
//            or {value, fixed = true}; fiber_invariant, tension_only as in a scene's [material];
//            [[model.fibers]] angle_deg = number | {value, min, max}, plus_minus = false (true: two
//            families at +θ and −θ sharing one angle parameter); all families share k1, k2 and the
//            optional fiber dispersion kappa (Gasser–Ogden–Holzapfel κ in [0, 1/3]; absent = 0).
//            [model.viscoelastic] g_inf, tau (one term, g = 1 − g_inf)  or  terms = [{g, tau}, ...]
//            (g_inf = 1 − Σ g derived).
//   [[curves]] name, file = "data.csv" (relative to the calibration file) | run = "DIR" (a `softhom
//            point`/`rve` output directory: DIR/response.csv, and the [load] from DIR/summary.json
//            unless a [curves.load] is given) | campaign = "DIR" (a `softhom sweep` store: DIR or
//            DIR/campaign.h5) with case = "ID" (its response table; the case scene's [load] unless
//            [curves.load] is given), load_rotation_deg = β (turns the load frame by β about e3: an
//            RVE case with fibers at α is the model with fibers at α0 loaded at β = α − α0),
//            x = "t" | "F11" | ... (model quantity, a response.csv
//            column name), y = "P11" | ..., x_column / y_column (CSV columns, default x / y),
//            weight = 1, role = "fit" | "holdout", [curves.load] as a `softhom point` [load] table.
//   [solver] method = "levenberg-marquardt" | "dogleg", starts, seed, max_iterations,
//            function_tolerance, parameter_tolerance, gradient_tolerance, fd_step,
//            point_tolerance, point_max_iterations, point_max_cutbacks.
//   [output] plot = true.
//
// Residual of curve c at data row i: sqrt(w_c / N_c) (model(x_i) − y_i) / range(y_c), so that the cost
// is ½ Σ_c w_c NRMSE_c²: curves of different magnitude and length weigh equally unless weighted.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <toml++/toml.h>

#include "softhom/core/keys.hpp"
#include "softhom/materials/driver.hpp"
#include "softhom/materials/library.hpp"
#include "softhom/materials/loading.hpp"

namespace softhom::studies {

/// One model parameter: fixed, or free within [min, max]. Free parameters with min > 0 are fitted in
/// log space (u = ln p), the others linearly (u = p / scale), so that every unknown is O(1).
struct CalParameter {
  std::string name;  ///< TOML path inside [model]: "G", "fibers[0].angle_deg", "viscoelastic.tau", ...
  double value = 0.0;
  double min = 0.0, max = 0.0;
  bool free = false;
  bool log_scale = false;
  double scale = 1.0;  ///< linear parameters: u = value / scale
};

struct CalFiber {
  int angle_parameter = -1;  ///< index into CalibrationModel::parameters
  bool plus_minus = false;   ///< two families at +θ and −θ
};

struct CalibrationModel {
  std::vector<CalParameter> parameters;
  int G = -1, Jm = -1, K = -1, k1 = -1, k2 = -1;  ///< indices into parameters (k1, k2: -1 without fibers)
  int kappa = -1;  ///< GOH fiber dispersion shared by all families; -1: aligned fibers (κ = 0)
  /// law = "fiber-composite": its added shear moduli GL, GT (shared by all families); -1 for Gent + HGO.
  int GL = -1, GT = -1, Ef = -1;
  std::vector<CalFiber> fibers;
  FiberInvariant invariant = FiberInvariant::full;
  bool tension_only = true;
  bool viscoelastic = false;
  int g_inf = -1;                ///< one-term form: g = 1 − g_inf
  std::vector<int> prony_g, prony_tau;  ///< per term (prony_g empty in the one-term form)

  /// Material description for the given values of all parameters (validated: throws InputError when
  /// the values are not admissible, e.g. Σ g ≥ 1).
  MaterialSpec spec(const std::vector<double>& values) const;
  std::vector<double> values() const;
  std::vector<int> free_indices() const;
};

/// Names of the model quantities a curve can use as x or y (the response.csv columns of `softhom point`).
double model_quantity(const PointState& s, const std::string& name, int* ok = nullptr);
bool is_model_quantity(const std::string& name, std::size_t fiber_families);

struct CalCurve {
  std::string name;
  std::filesystem::path file;
  std::string x = "t", y = "P11";
  double weight = 1.0;
  bool holdout = false;
  MixedControl control;
  std::vector<double> x_data, y_data;  ///< data rows (x strictly monotone)
  double y_range = 1.0;                ///< max − min of y_data (normaliser)
};

struct CalSolverOptions {
  bool dogleg = false;
  int starts = 4;
  std::uint64_t seed = 1;
  int max_iterations = 100;
  double function_tolerance = 1e-14;
  double parameter_tolerance = 1e-12;
  double gradient_tolerance = 1e-16;
  double fd_step = 1e-5;  ///< central-difference step in the scaled unknowns u
  /// Driver options. Tolerance 1e-9, not the driver's 1e-10: its test is relative to max(G, |P|), and
  /// at a small trial G (random starts near min) with K = 2000 the round-off of the volumetric stress
  /// (≈ eps·K ≈ 2e-13 MPa) exceeds 1e-10·G, so Newton would stall and the start be lost. 1e-9 relative
  /// stress noise is still 1e5 below the 1e-4 recovery target.
  PointSolverOptions point{1e-9, 25, 12};
};

struct CalibrationInput {
  CalibrationModel model;
  std::vector<CalCurve> curves;
  CalSolverOptions solver;
  bool plot = true;
  std::string description;
};

/// Parses a calibration table; relative CSV paths are resolved against `base_dir`. Every bad field
/// throws InputError naming its TOML path ("curves[1].y", "model.G.min", ...).
CalibrationInput parse_calibration(const toml::table& table, const std::filesystem::path& base_dir);
/// The declared tables of a calibration file, for `softhom keys calibrate` and docs/keys.md.
std::vector<keys::TableDoc> calibration_tables();

/// Minimal CSV reader for response.csv-like files (header row of names, numeric rows, '#' comments).
struct CsvData {
  std::vector<std::string> columns;
  std::vector<std::vector<double>> rows;
  int column(const std::string& name) const;  ///< -1 when absent
};
CsvData read_csv(const std::filesystem::path& path);

/// Model response of one curve at one parameter set.
struct CurveEvaluation {
  bool ok = false;
  std::string error;
  std::vector<double> model;  ///< y_model at the curve's x_data (when ok)
  PointRunResult run;         ///< the driver run (kept only when requested)
};

/// Runs the driver for one curve with all parameter values `values` and samples y at the data's x.
/// Never throws for a failed evaluation (locking, non-convergence, inadmissible values): ok = false.
CurveEvaluation evaluate_curve(const CalibrationModel& model, const CalCurve& curve,
                               const std::vector<double>& values, const PointSolverOptions& point,
                               bool keep_run = false);

struct CurveFit {
  std::string name;
  bool holdout = false;
  double weight = 1.0;
  std::size_t points = 0;
  bool ok = false;
  std::string error;
  double r2 = 0.0, nrmse = 0.0, rmse = 0.0, max_abs_error = 0.0;
  std::vector<double> x, data, model;
  PointRunResult run;  ///< model response at the optimum (full driver output)
};

struct StartReport {
  std::vector<double> initial;  ///< free parameters (physical units)
  std::vector<double> final;
  double initial_cost = 0.0, final_cost = 0.0;
  int iterations = 0;
  bool usable = false;
  std::string termination;
};

struct ParameterReport {
  std::string name;
  double value = 0.0, initial = 0.0, min = 0.0, max = 0.0;
  bool free = false;
  bool at_bound = false;
  std::optional<double> std_error;  ///< free parameters; empty when not identifiable
};

struct CalibrationResult {
  bool success = false;
  std::vector<double> values;  ///< all parameters at the optimum
  std::vector<ParameterReport> parameters;
  Eigen::MatrixXd correlation;  ///< free x free
  double final_cost = 0.0;
  double residual_variance = 0.0;  ///< s² = 2 cost / (m − n)
  double jtj_condition = 0.0;
  int residuals = 0, dof = 0;
  int best_start = -1;
  std::vector<StartReport> starts;
  std::vector<CurveFit> curves;
  long model_evaluations = 0;  ///< driver runs of the whole fit set (one per cost or FD evaluation)
  long curve_evaluations = 0;  ///< single-curve driver runs (fit + holdout)
  double wall_time_s = 0.0;
  std::vector<std::string> warnings;
};

using CalibrationProgress = std::function<void(const std::string&)>;

/// Multi-start bounded least squares. Never throws for failed model evaluations; a start whose
/// initial point cannot be evaluated is reported as not usable.
CalibrationResult calibrate(const CalibrationInput& input, const CalibrationProgress& progress = {});

/// DIR/material.toml content: a `[material]` table as read by `softhom point` / `softhom macro`.
std::string material_toml(const CalibrationModel& model, const std::vector<double>& values,
                          const std::string& header_comment = "");
/// summary.json fields of the calibration (parameters, standard errors, correlations, curves, starts).
nlohmann::json result_json(const CalibrationInput& input, const CalibrationResult& result);
/// DIR/response.csv text: curve (the curve's name), index (its position in [[curves]]), x, data, model.
std::string comparison_csv(const CalibrationResult& result);
/// Writes DIR/material.toml, DIR/response.csv (comparison_csv), DIR/curves/<name>.csv (full
/// model response at the optimum, response.csv layout). summary.json is written by the caller (it adds
/// the run metadata).
void write_calibration_files(const std::filesystem::path& dir, const CalibrationInput& input,
                             const CalibrationResult& result);

}  // namespace softhom::studies
