#pragma once
// `softhom rve` with [solver] engine = "auto" and target_error: which engine and resolution reach the
// requested relative error of the homogenized stress at the lower predicted cost. The rules are the
// error and cost models of the engine benchmark (BENCHMARKS.md, FE RVE); the choice is a pure function
// of a few numbers of the parsed scene.
#include <array>
#include <string>

namespace softhom::jobs {

enum class RveEngine { fft, fe };

/// What the choice reads from the parsed scene.
struct EngineRequest {
  double target_error = 1e-3;         ///< solver.target_error, in (0, 0.5)
  double matrix_bulk_to_shear = 1.0;  ///< K/G of the matrix (initial moduli)
  double shear_contrast = 1.0;        ///< G_fiber / G_matrix (initial moduli)
  double L1 = 1.0, L2 = 1.0;          ///< cell sides of the section
};

/// The engine, its resolution and the predictions that chose it.
struct EngineResolution {
  RveEngine engine = RveEngine::fft;
  std::array<int, 2> grid{};        ///< FFT: section grid (n, n L2/L1)
  double mesh_divisions = 4.0;      ///< FE: d with mesh_size = L1/d
  double mesh_size = 0.0;           ///< FE: L1/d
  double interface_size = 0.0;      ///< FE: L1/(3d)
  double fft_error_coefficient = 0.0;  ///< c of the FFT error model e ≈ c/n
  double predicted_error = 0.0;        ///< the chosen engine's model error at the chosen resolution
  double predicted_fft_seconds = 0.0;  ///< one thread, 5 load steps, at the grid the FFT would need
  double predicted_fe_seconds = 0.0;   ///< same, at the mesh the FE engine would need
  std::string why;                     ///< one line: the choice and the numbers it rests on
};

EngineResolution choose_engine(const EngineRequest& request);

}  // namespace softhom::jobs
