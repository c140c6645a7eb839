// FFTW plans: made once per (grid, field count), multithreaded, optionally from cached wisdom.
#include "softhom/fft/plan.hpp"

#include <fftw3.h>
#include <omp.h>

#include <chrono>
#include <mutex>
#include <new>
#include <sstream>
#include <stdexcept>

#include "plan_rigor.hpp"

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

}  // namespace

BatchedFFT::BatchedFFT(const Grid& grid, int fields, const PlanOptions& options, int columns, bool in_place)
    : grid_(grid), fields_(fields), columns_(columns), in_place_(in_place), rigor_(options.rigor) {
  if (columns < 1 || columns > 3 || (columns < 3 && fields % 9 != 0))
    throw std::invalid_argument("BatchedFFT: columns must be 1..3, and < 3 only for 3x3 tensor fields");
  if (in_place && columns != 3) throw std::invalid_argument("BatchedFFT: in-place transforms need columns = 3");
  const auto start = std::chrono::steady_clock::now();
  threads_ = options.threads > 0 ? options.threads : omp_get_max_threads();
  const std::size_t nr = in_place ? 0 : grid.voxels() * std::size_t(fields), nc = grid.modes() * std::size_t(fields);
  spectrum_ = reinterpret_cast<Complex*>(fftw_alloc_complex(nc));
  real_ = in_place ? reinterpret_cast<double*>(spectrum_) : fftw_alloc_real(nr);
  if (!real_ || !spectrum_) throw std::bad_alloc();
  const std::size_t pitch = in_place ? 2 * std::size_t(grid.half_n1()) : std::size_t(grid.n[0]);
  set_buffers(real_, in_place ? 2 * grid.modes() : grid.voxels(), spectrum_, grid.modes());
  set_rows(std::size_t(grid.n[0]), pitch);

  // FFTW is row-major with the last index fastest: dims (n3, n2, n1) match our i1-fastest layout.
  int dims[3] = {grid.n[2], grid.n[1], grid.n[0]};
  const int nv = int(grid.voxels()), nm = int(grid.modes());
  const unsigned flags = detail::fftw_flags(options.rigor);
  {
    std::lock_guard<std::mutex> lock(planner_mutex());
    init_threads_once();
    if (!options.wisdom_file.empty()) fftw_import_wisdom_from_filename(options.wisdom_file.c_str());
    fftw_plan_with_nthreads(threads_);
    if (in_place) {
      // FFTW's in-place layout: real rows padded to 2 (n1/2 + 1) values, fields one spectrum apart.
      int real_embed[3] = {grid.n[2], grid.n[1], 2 * grid.half_n1()};
      int half_embed[3] = {grid.n[2], grid.n[1], grid.half_n1()};
      auto* c = reinterpret_cast<fftw_complex*>(spectrum_);
      forward_plan_ = fftw_plan_many_dft_r2c(3, dims, fields, real_, real_embed, 1, 2 * nm, c, half_embed, 1, nm, flags);
      backward_plan_ = fftw_plan_many_dft_c2r(3, dims, fields, c, half_embed, 1, nm, real_, real_embed, 1, 2 * nm, flags);
    } else if (columns == 3) {
      forward_plan_ = fftw_plan_many_dft_r2c(3, dims, fields, real_, nullptr, 1, nv,
                                             reinterpret_cast<fftw_complex*>(spectrum_), nullptr, 1, nm, flags);
      backward_plan_ = fftw_plan_many_dft_c2r(3, dims, fields, reinterpret_cast<fftw_complex*>(spectrum_), nullptr,
                                              1, nm, real_, nullptr, 1, nv, flags);
    } else {
      // Guru interface: the transformed fields form a (tensor t, row i, column j < columns) loop nest.
      const int m1 = grid.half_n1();
      fftw_iodim fwd[3] = {{grid.n[2], grid.n[1] * grid.n[0], m1 * grid.n[1]},
                           {grid.n[1], grid.n[0], m1},
                           {grid.n[0], 1, 1}};
      fftw_iodim bwd[3] = {{grid.n[2], m1 * grid.n[1], grid.n[1] * grid.n[0]},
                           {grid.n[1], m1, grid.n[0]},
                           {grid.n[0], 1, 1}};
      fftw_iodim many_f[3] = {{fields / 9, 9 * nv, 9 * nm}, {3, 3 * nv, 3 * nm}, {columns, nv, nm}};
      fftw_iodim many_b[3] = {{fields / 9, 9 * nm, 9 * nv}, {3, 3 * nm, 3 * nv}, {columns, nm, nv}};
      forward_plan_ = fftw_plan_guru_dft_r2c(3, fwd, 3, many_f, real_, reinterpret_cast<fftw_complex*>(spectrum_), flags);
      backward_plan_ =
          fftw_plan_guru_dft_c2r(3, bwd, 3, many_b, reinterpret_cast<fftw_complex*>(spectrum_), real_, flags);
    }
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
  if (!in_place_) fftw_free(real_);
  fftw_free(spectrum_);
}

void BatchedFFT::forward() { fftw_execute(static_cast<fftw_plan>(forward_plan_)); }
void BatchedFFT::backward() { fftw_execute(static_cast<fftw_plan>(backward_plan_)); }

std::string BatchedFFT::describe() const {
  std::ostringstream os;
  os << "fftw3 r2c " << transformed_fields() << " x " << grid_.n[0] << "x" << grid_.n[1] << "x" << grid_.n[2] << ", "
     << threads_ << " threads, " << to_string(rigor_);
  return os.str();
}

}  // namespace softhom::fft
