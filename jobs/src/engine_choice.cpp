// The engine choice of `softhom rve` (engine_choice.hpp).
#include "softhom/jobs/engine_choice.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace softhom::jobs {

// Error models of the benchmark cell (circle, VF 0.23, α = 45°, λ = 1.5; BENCHMARKS.md):
//   FFT (rotated, composite voxels, first order): e ≈ c / n, with c set by the fiber/matrix shear
//     contrast, not by K/G (the ecoflex gap is the same at K/G = 1e2 … 1.2e5):
//     c = 6.2e-3 at contrast 5.9 (PDMS), 0.067 at 226 (ecoflex) → c ≈ 6.2e-3 (contrast / 5.9)^0.65.
//   FE (P2+bubble/P1, order 3.3): e ≈ 1e-5 (4/d)^3.3 with mesh_size = L/d; a factor 10 of
//     safety for cells with corners (rectangular fibers: lower regularity) → d = 4 (1e-4/e)^(1/3.3).
// Cost (one thread, 5 load steps): FFT 16² ≈ 0.25 s, ×≈5 per doubling of n, ×≈6 for nearly
// incompressible matrices (K/G > 1e4: more Newton and Krylov iterations); FE L/4 ≈ 1 s, ×≈3 per
// doubling of d.
EngineResolution choose_engine(const EngineRequest& request) {
  const double target = request.target_error, kg = request.matrix_bulk_to_shear, contrast = request.shear_contrast;
  EngineResolution r;
  r.fft_error_coefficient = 6.2e-3 * std::pow(std::max(contrast, 1.0) / 5.9, 0.65);
  int n = 16;
  while (r.fft_error_coefficient / n > target && n < 1024) n *= 2;
  r.predicted_fft_seconds = 0.25 * std::pow(5.0, std::log2(n / 16.0)) * (kg > 1e4 ? 6.0 : 1.0);
  double d = 4.0;
  if (target < 1e-4) d = std::ceil(4.0 * std::pow(1e-4 / target, 1.0 / 3.3));
  r.predicted_fe_seconds = 1.0 * std::pow(3.0, std::log2(d / 4.0));
  std::ostringstream os;
  if (r.predicted_fft_seconds <= r.predicted_fe_seconds) {
    r.engine = RveEngine::fft;
    r.grid = {n, int(std::lround(n * request.L2 / request.L1))};
    r.predicted_error = r.fft_error_coefficient / n;
    os << "engine auto: FFT " << n << "² for target error " << target << " (matrix K/G " << kg << ", shear contrast "
       << contrast << ")";
  } else {
    r.engine = RveEngine::fe;
    r.mesh_divisions = d;
    r.mesh_size = request.L1 / d;
    r.interface_size = request.L1 / (3.0 * d);
    r.predicted_error = 1e-5 * std::pow(4.0 / d, 3.3);
    os << "engine auto: FE, mesh_size L/" << d << " for target error " << target << " (matrix K/G " << kg
       << ", shear contrast " << contrast << ")";
  }
  r.why = os.str();
  return r;
}

}  // namespace softhom::jobs
