#pragma once
// The two engines' runs of `softhom rve` (rve.cpp dispatches to them).
#include "softhom/jobs/jobs.hpp"

namespace softhom::jobs {

bool run_fft_rve(RveJob& job, FftRveJob& fft, Sink& sink, const RunOptions& options);
bool run_fe_rve(const RveJob& job, const FeRveJob& fe, Sink& sink, const RunOptions& options);

}  // namespace softhom::jobs
