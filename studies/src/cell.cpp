// One FFT RVE cell as a constitutive law (see cell.hpp).
#include "softhom/studies/cell.hpp"

#include <chrono>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "softhom/io/scene.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/studies/rve_scene.hpp"

namespace softhom::studies {

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

void check_finite(const Mat3& X, const char* field) {
  if (!X.allFinite()) throw InputError(field, "", "not finite");
}

// One line without '=' or '[' that names a .toml file or an existing file: no RVE scene is that (a
// scene has at least a [microstructure] table), and parsing it as TOML gives only a syntax error.
bool looks_like_file_name(const std::string& text) {
  if (text.empty() || text.find_first_of("=[\n") != std::string::npos) return false;
  std::error_code ec;
  return text.ends_with(".toml") || std::filesystem::is_regular_file(text, ec);
}

}  // namespace

Cell::Cell(const std::string& scene_toml, const std::string& source_name, const CellOptions& options)
    : cell_options_(options) {
  if (looks_like_file_name(scene_toml))
    throw InputError("scene", scene_toml,
                     "is a file name, not TOML text: use Cell::from_file (Python: softhom.Cell.from_file)");
  setup(io::parse_scene(scene_toml, source_name));
}

Cell Cell::from_file(const std::filesystem::path& scene_file, const CellOptions& options) {
  return Cell(io::load_scene(scene_file), options);
}

Cell Cell::from_toml(const std::string& scene_toml, const CellOptions& options, const std::string& source_name) {
  return Cell(scene_toml, source_name, options);
}

Cell::Cell(const toml::table& scene, const CellOptions& options) : cell_options_(options) { setup(scene); }

Cell::~Cell() = default;
Cell::Cell(Cell&&) noexcept = default;
Cell& Cell::operator=(Cell&&) noexcept = default;

void Cell::setup(const toml::table& scene) {
  if (!(cell_options_.tangent_tolerance > 0.0 && cell_options_.tangent_tolerance < 1.0))
    throw InputError("tangent_tolerance", format_number(cell_options_.tangent_tolerance), "must lie in (0, 1)");
  if (const toml::table* solver = scene["solver"].as_table())
    if (const toml::node* engine = solver->get("engine"))
      if (const auto name = engine->value<std::string>(); name && *name != "fft")
        throw InputError("solver.engine", "\"" + *name + "\"", "a Cell embeds the FFT engine (\"fft\")");
  const studies::RveSceneSetup s = studies::parse_rve_scene(scene, /*with_load=*/false);
  if (s.solver.scheme != rve::FftScheme::newton_cg)
    throw InputError("solver.scheme", to_string(s.solver.scheme),
                     "a Cell needs newton-cg (its consistent tangent is the Newton linearization)");
  options_ = s.solver;
  // The homogenized tangent is read off the stored tangent field: single-precision storage (the default of
  // a plain run, where it only preconditions Newton) would round ∂P̄/∂F̄ at about 1e-7 relative. A Cell
  // keeps double unless its scene asks for single.
  const toml::table* solver_table = scene["solver"].as_table();
  if (!solver_table || !solver_table->contains("tangent_precision"))
    options_.tangent_precision = rve::TangentPrecision::double_precision;
  solver_ = std::make_unique<rve::FftRveSolver>(s.image, s.matrix, s.fiber, s.fiber_angle_deg, Mat3::Identity(), options_);
  has_history_ = s.matrix->state_size() > 0 || s.fiber->state_size() > 0;
  initial_.solver = solver_->state();
  committed_ = initial_;
  std::ostringstream d;
  d << s.geometry_note << "; matrix " << s.matrix->describe() << "; fiber " << s.fiber->describe() << "; grid "
    << solver_->grid().n[0] << "×" << solver_->grid().n[1];
  if (solver_->grid().n[2] > 1) d << "×" << solver_->grid().n[2];
  d << ", fiber angle " << format_number(s.fiber_angle_deg) << "°";
  description_ = d.str();
}

CellResult Cell::solve(const Mat3& F, double dt, bool with_tangent) {
  return solve_mixed(F, Mat3::Zero(), std::array<bool, 9>{}, dt, with_tangent);
}

CellResult Cell::solve_mixed(const Mat3& F_target, const Mat3& P_target, const std::array<bool, 9>& stress_prescribed,
                             double dt, bool with_tangent) {
  check_finite(F_target, "F");
  check_finite(P_target, "P");
  if (!std::isfinite(dt) || dt < 0.0) throw InputError("dt", format_number(dt), "must be a finite time step >= 0 [s]");
  if (has_history_ && !(dt > 0.0)) throw InputError("dt", format_number(dt), "must be > 0: a phase has history (QLV)");
  // The solver's time runs over one step [0, T]; elastic cells take T = 1 for dt = 0 (time does not
  // enter their response, and the predictor scales the last increment by T / T_last).
  const double T = dt > 0.0 ? dt : 1.0;
  MixedControl control;
  control.name = "cell";
  control.times = {T};
  const Mat3& F0 = committed_.solver.F;
  for (int c = 0; c < 9; ++c) {
    const int i = c / 3, j = c % 3;
    const bool stress = stress_prescribed[c];
    control.kind[c] = stress ? ControlKind::stress : ControlKind::deformation;
    control.value[c] = stress ? PiecewiseLinear{{0.0, T}, {committed_.P(i, j), P_target(i, j)}}
                              : PiecewiseLinear{{0.0, T}, {F0(i, j), F_target(i, j)}};
  }
  try {
    control.validate();
  } catch (const InputError& e) {
    throw InputError("control", "", e.what());
  }
  bool all_prescribed = true;
  for (bool s : stress_prescribed) all_prescribed = all_prescribed && !s;
  if (all_prescribed && !(F_target.determinant() > 0.0))
    throw InputError("F", "det " + format_number(F_target.determinant()), "not a deformation gradient (det F <= 0)");

  CellResult out;
  const auto t0 = Clock::now();
  solver_->set_state(predictor_start(F_target, stress_prescribed, T));
  const rve::RveRunResult run = solver_->run(control);
  out.counts = run;
  out.solve_seconds = seconds_since(t0);
  if (!run.completed) {
    out.error = run.error.empty() ? std::string("the cell did not converge") : run.error;
    solver_->set_state(committed_.solver);
    return out;
  }
  out.converged = true;
  out.F = run.steps.back().F;
  out.P = run.steps.back().P;
  if (with_tangent) {
    const auto t1 = Clock::now();
    rve::RveCounts tc;
    out.tangent = solver_->homogenized_tangent(cell_options_.tangent_tolerance, &tc);
    out.tangent_krylov_iterations = tc.krylov_iterations;
    out.tangent_seconds = seconds_since(t1);
  }
  trial_.solver = solver_->state();
  trial_.P = out.P;
  trial_.time = committed_.time + dt;
  has_trial_ = true;
  return out;
}

const rve::FftRveState& Cell::predictor_start(const Mat3& F_target, const std::array<bool, 9>& stress_prescribed, double T) {
  // The solver extrapolates the last converged increment by T / dt_last. Calls of a macro code do not
  // follow one path at a steady rate (Newton iterates, finite-difference probes, a new increment of
  // another size), so the factor is taken from the macro increment instead: the projection r of the
  // prescribed part of F̄_target − F̄ on that of the last increment. Where the two point in clearly
  // different directions (cosine < 1/2) or nothing moves, the fluctuation is not extrapolated and
  // the solver's tangent predictor (first iteration linearized at the committed state) takes over.
  start_ = committed_.solver;
  const Mat3& F0 = committed_.solver.F;
  double dot = 0.0, last2 = 0.0, new2 = 0.0;
  for (int c = 0; c < 9; ++c) {
    if (stress_prescribed[c]) continue;
    const double d_new = F_target(c / 3, c % 3) - F0(c / 3, c % 3), d_last = start_.dF_last(c / 3, c % 3);
    dot += d_new * d_last;
    last2 += d_last * d_last;
    new2 += d_new * d_new;
  }
  if (start_.du_last.empty() || !(last2 > 0.0) || !(new2 > 0.0) || dot < 0.5 * std::sqrt(last2 * new2)) {
    start_.du_last.clear();
    start_.dF_last.setZero();
    start_.dt_last = 0.0;
  } else {
    start_.dt_last = T * last2 / dot;  // T / dt_last = r = dot / |ΔF_last|²
  }
  return start_;
}

void Cell::commit() {
  if (!has_trial_) throw std::logic_error("Cell::commit: no converged solve to commit");
  committed_ = trial_;
  has_trial_ = false;
}

void Cell::restore(const CellState& s) {
  solver_->set_state(s.solver);  // checks the sizes (InputError "state")
  check_finite(s.P, "state.P");
  committed_ = s;
  has_trial_ = false;
}

double Cell::achieved_volume_fraction() const { return solver_->achieved_volume_fraction(); }
std::size_t Cell::memory_bytes() const { return solver_->memory_bytes(); }

}  // namespace softhom::studies
