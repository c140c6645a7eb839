#pragma once
// FFTW planner flags and names of PlanRigor, shared by the one-process and the slab (FFTW-MPI) plans.
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

inline const char* rigor_name(PlanRigor r) {
  switch (r) {
    case PlanRigor::estimate: return "estimate";
    case PlanRigor::measure: return "measure";
    case PlanRigor::patient: return "patient";
  }
  return "?";
}

}  // namespace softhom::fft::detail
