#pragma once
// The [solver] keys of the FFT RVE engine, declared next to FftSolverOptions (softhom/core/keys.hpp).
#include "softhom/core/keys.hpp"
#include "softhom/rve/fft_solver.hpp"

namespace softhom::rve {

/// Every key of [solver] for engine = "fft" (also engine and target_error, which the rve job's engine choice
/// consumes before the FFT options are read). fftw_wisdom is stored as written in plan.wisdom_file; the caller
/// resolves it against the output directory (studies::resolve_run_file).
const keys::KeyTable<FftSolverOptions>& fft_solver_keys();

}  // namespace softhom::rve
