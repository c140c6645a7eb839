// FFTW plans: made once per (grid, field count), multithreaded, optionally from cached wisdom.
#include "softhom/fft/plan.hpp"

#include <fftw3.h>
#include <omp.h>

#include <chrono>
#include <mutex>
#include <new>
#include <sstream>

namespace softhom::fft {
namespace {

// FFTW's planner is not thread-safe; every plan creation/destruction goes through this mutex.
std::mutex& planner_mutex() {
  static std::mutex m;
  return m;
}

void init_threads_once() {
  static std::once_flag flag;
  std::call_once(flag, [] { fftw_init_threads(); });
}

unsigned flags_of(PlanRigor r) {
  switch (r) {
    case PlanRigor::estimate: return FFTW_ESTIMATE;
    case PlanRigor::measure: return FFTW_MEASURE;
    case PlanRigor::patient: return FFTW_PATIENT;
  }
  return FFTW_MEASURE;
}

const char* name_of(PlanRigor r) {
  switch (r) {
    case PlanRigor::estimate: return "estimate";
    case PlanRigor::measure: return "measure";
    case PlanRigor::patient: return "patient";
  }
  return "?";
}

}  // namespace

BatchedFFT::BatchedFFT(const Grid& grid, int fields, const PlanOptions& options)
    : grid_(grid), fields_(fields), rigor_(options.rigor) {
  const auto start = std::chrono::steady_clock::now();
  threads_ = options.threads > 0 ? options.threads : omp_get_max_threads();
  const std::size_t nr = grid.voxels() * std::size_t(fields), nc = grid.modes() * std::size_t(fields);
  real_ = fftw_alloc_real(nr);
  spectrum_ = reinterpret_cast<Complex*>(fftw_alloc_complex(nc));
  if (!real_ || !spectrum_) throw std::bad_alloc();

  // FFTW is row-major with the last index fastest: dims (n3, n2, n1) match our i1-fastest layout.
  int dims[3] = {grid.n[2], grid.n[1], grid.n[0]};
  const int nv = int(grid.voxels()), nm = int(grid.modes());
  const unsigned flags = flags_of(options.rigor);
  {
    std::lock_guard<std::mutex> lock(planner_mutex());
    init_threads_once();
    if (!options.wisdom_file.empty()) fftw_import_wisdom_from_filename(options.wisdom_file.c_str());
    fftw_plan_with_nthreads(threads_);
    forward_plan_ = fftw_plan_many_dft_r2c(3, dims, fields, real_, nullptr, 1, nv,
                                           reinterpret_cast<fftw_complex*>(spectrum_), nullptr, 1, nm, flags);
    backward_plan_ = fftw_plan_many_dft_c2r(3, dims, fields, reinterpret_cast<fftw_complex*>(spectrum_), nullptr,
                                            1, nm, real_, nullptr, 1, nv, flags);
    if (!options.wisdom_file.empty()) fftw_export_wisdom_to_filename(options.wisdom_file.c_str());
  }
  if (!forward_plan_ || !backward_plan_) throw std::runtime_error("fftw: could not create plans");
  // MEASURE scribbles over the buffers: leave them in a defined state.
  for (std::size_t i = 0; i < nr; ++i) real_[i] = 0.0;
  for (std::size_t i = 0; i < nc; ++i) spectrum_[i] = 0.0;
  planning_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

BatchedFFT::~BatchedFFT() {
  {
    std::lock_guard<std::mutex> lock(planner_mutex());
    if (forward_plan_) fftw_destroy_plan(static_cast<fftw_plan>(forward_plan_));
    if (backward_plan_) fftw_destroy_plan(static_cast<fftw_plan>(backward_plan_));
  }
  fftw_free(real_);
  fftw_free(spectrum_);
}

void BatchedFFT::forward() { fftw_execute(static_cast<fftw_plan>(forward_plan_)); }
void BatchedFFT::backward() { fftw_execute(static_cast<fftw_plan>(backward_plan_)); }

std::string BatchedFFT::describe() const {
  std::ostringstream os;
  os << "fftw3 r2c " << fields_ << " x " << grid_.n[0] << "x" << grid_.n[1] << "x" << grid_.n[2] << ", "
     << threads_ << " threads, " << name_of(rigor_);
  return os.str();
}

}  // namespace softhom::fft
