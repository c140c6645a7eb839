#pragma once
// One FFT RVE cell as a constitutive law of a macroscopic code (FE²): macro F̄ (or mixed control) and a
// committed cell state in, P̄, the homogenized consistent tangent ∂P̄/∂F̄ and the trial state out.
//
// A Cell is built from the tables of an RVE scene file ([microstructure], [phases.matrix],
// [phases.fiber], [solver]; [load] and [output] are accepted and ignored), so a cell that runs under
// `softhom rve` is embedded unchanged. It owns one FftRveSolver (grid, FFT plans, tangent storage:
// FftRveSolver::memory_bytes()) and two states: the committed one (the start of every solve) and the
// trial one of the last converged solve.
//
// Commit / rollback. solve() never changes the committed state: a macro Newton iteration calls solve()
// at each new F̄ of the same increment, every call starting from the committed state (warm-started by
// the extrapolation of its last converged increment, scaled to the new macro increment). commit() makes the last converged trial the
// committed state (the macro increment is accepted); not calling it, or restore(state), rolls back.
// An FE² code with many quadrature points keeps one CellState per point (copy state() out after
// commit(), restore(point_state) before the point's solve()) and may share one Cell between them.
//
// Frames and units. F̄, P̄ and C̄ are in the frame of the scene's material tables (the global frame: the
// fiber axis is a = (sin α, cos α, 0) for microstructure.fiber_angle_deg = α), row-major component
// index 3 i + j; P̄ and C̄ in MPa, C̄(a, b) = ∂P̄_a/∂F̄_b. dt in s (the QLV relaxation times' unit).
//
// Thread-safety. A Cell is not thread-safe (its solver runs OpenMP over voxels itself); use one Cell
// per thread for concurrent cells. CellState is a plain value (copyable, movable).
#include <array>
#include <cstddef>
#include <filesystem>
#include <memory>
#include <string>

#include <toml++/toml.h>

#include "softhom/materials/tensor.hpp"
#include "softhom/rve/fft_solver.hpp"

namespace softhom::studies {

/// Everything the next solve of a cell depends on: the solver state (F̄, the fluctuation spectrum, the
/// history of every material point, the laminate jump vectors, the last increment for the predictor)
/// and the macro stress of that state (the start of stress ramps under mixed control).
struct CellState {
  rve::FftRveState solver;
  Mat3 P = Mat3::Zero();  ///< P̄ of this state [MPa]
  double time = 0.0;      ///< accumulated dt of the committed solves [s]
};

/// Options of the facade beyond the scene's [solver] table.
struct CellOptions {
  /// Relative tolerance of each of the 9 linear solves of the tangent (preconditioned norm). Measured
  /// on pdms/glass sections (BENCHMARKS.md, "Homogenized tangent"): 1e-6 gives C̄ within ≈ 1e-7 of the
  /// 1e-10 tangent (relative, Frobenius), ample for a quadratically converging macro Newton; 1e-10
  /// costs ≈ 1.8× the Krylov iterations.
  double tangent_tolerance = 1e-6;
};

/// What solve() returns. On failure (converged = false) the trial state is unchanged and `error` says
/// why (the macro code should cut back its increment); F, P, tangent are then not meaningful.
struct CellResult {
  bool converged = false;
  std::string error;
  Mat3 F = Mat3::Identity();  ///< F̄ (free components under mixed control as solved)
  Mat3 P = Mat3::Zero();      ///< P̄ = ⟨P⟩ [MPa]
  /// ∂P̄/∂F̄ with every macro component prescribed (also under mixed control: condense the free rows
  /// to get the mixed-control sensitivity); zero when not requested. When the solve needed cut-backs
  /// (counts.cutbacks > 0) a cell with history gives the tangent of the last sub-step's Δt; elastic
  /// cells are unaffected (their tangent depends on the converged state only).
  Mat9 tangent = Mat9::Zero();
  rve::RveCounts counts;                 ///< Newton/Krylov iterations, sub-steps, cut-backs of the solve
  int tangent_krylov_iterations = 0;
  double solve_seconds = 0.0, tangent_seconds = 0.0;
};

class Cell {
 public:
  /// From an RVE scene file (the file `softhom rve` would run), read through the checked opener;
  /// imported images (microstructure.image.file) are read relative to the scene file's directory.
  static Cell from_file(const std::filesystem::path& scene_file, const CellOptions& options = {});
  /// From the text of an RVE scene (TOML); `source_name` names it in TOML syntax errors.
  static Cell from_toml(const std::string& scene_toml, const CellOptions& options = {},
                        const std::string& source_name = "cell");

  /// From the text of an RVE scene (TOML); `source_name` names it in TOML syntax errors. Every bad key
  /// is an InputError naming the TOML path ("phases.matrix.G = -1: ...", "solver.tolerance = ...");
  /// solver.engine must be "fft" (or absent). Imported images (microstructure.image.file) are read
  /// relative to the working directory. Text that is a file name rather than TOML is refused with an
  /// InputError pointing to from_file.
  explicit Cell(const std::string& scene_toml, const std::string& source_name = "cell", const CellOptions& options = {});
  /// From a parsed scene table.
  explicit Cell(const toml::table& scene, const CellOptions& options = {});
  ~Cell();
  Cell(const Cell&) = delete;
  Cell& operator=(const Cell&) = delete;
  Cell(Cell&&) noexcept;
  Cell& operator=(Cell&&) noexcept;

  /// Solves the cell at the fully prescribed F̄ (det F̄ > 0) after a time step dt ≥ 0 [s] from the
  /// committed state (dt > 0 required when a phase has history; elastic cells ignore it). With
  /// `with_tangent` also ∂P̄/∂F̄ (9 linear solves, rve::FftRveSolver::homogenized_tangent()). Throws
  /// InputError for bad arguments ("F", "dt"); a cell that does not converge is a result with
  /// converged = false, not an exception.
  CellResult solve(const Mat3& F, double dt, bool with_tangent = true);
  /// Mixed control: components c = 3 i + j with stress_prescribed[c] take P̄_ij = P_target(i, j) (their
  /// F_target entry is ignored), the others F̄_ij = F_target(i, j). Refuses (InputError "control") a
  /// control leaving both F̄_ij and F̄_ji free (a rigid rotation). Loads are ramped linearly from the
  /// committed state over the step (cut-backs halve it).
  CellResult solve_mixed(const Mat3& F_target, const Mat3& P_target, const std::array<bool, 9>& stress_prescribed,
                         double dt, bool with_tangent = true);

  /// Makes the trial state of the last converged solve the committed state. Throws std::logic_error
  /// when there is none (no converged solve since construction, the last commit or restore).
  void commit();
  /// The committed state (a copy: keep it per quadrature point).
  const CellState& state() const { return committed_; }
  /// The trial state of the last converged solve (equal to state() when there is none).
  const CellState& trial_state() const { return has_trial_ ? trial_ : committed_; }
  /// Makes `s` the committed state (a state of a cell with the same scene) and drops the trial.
  /// Throws InputError("state...") when its sizes do not fit this cell.
  void restore(const CellState& s);
  /// The undeformed state (F̄ = I, initial history): what a new quadrature point starts from.
  const CellState& initial_state() const { return initial_; }

  /// Whether a phase has history (QLV): then solve() needs dt > 0 and states carry it.
  bool has_history() const { return has_history_; }
  double achieved_volume_fraction() const;
  std::size_t memory_bytes() const;
  const rve::FftSolverOptions& solver_options() const { return options_; }
  const rve::FftRveSolver& solver() const { return *solver_; }
  std::string describe() const { return description_; }

 private:
  void setup(const toml::table& scene);
  const rve::FftRveState& predictor_start(const Mat3& F_target, const std::array<bool, 9>& stress_prescribed, double T);
  std::unique_ptr<rve::FftRveSolver> solver_;
  rve::FftSolverOptions options_;
  CellOptions cell_options_;
  CellState initial_, committed_, trial_;
  rve::FftRveState start_;  // the committed state with the predictor's extrapolation factor of a solve
  bool has_trial_ = false, has_history_ = false;
  std::string description_;
};

}  // namespace softhom::studies
