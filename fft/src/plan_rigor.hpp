#pragma once
// FFTW planner flags of PlanRigor, shared by the one-process and the slab (FFTW-MPI) plans.
#include <fftw3.h>

#include "softhom/fft/plan.hpp"

namespace softhom::fft::detail {

inline unsigned fftw_flags(PlanRigor r) {
  switch (r) {
    case PlanRigor::estimate: return FFTW_ESTIMATE;
    case PlanRigor::measure: return FFTW_MEASURE;
    case PlanRigor::patient: return FFTW_PATIENT;
  }
  return FFTW_MEASURE;
}

}  // namespace softhom::fft::detail
