// FFTW-MPI slabs: the decomposition, its reductions and halos, and the batched transforms (slab.hpp).
#include "softhom/fft/slab.hpp"

#include <fftw3-mpi.h>
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <mutex>
#include <new>
#include <sstream>
#include <stdexcept>

#include "plan_rigor.hpp"

namespace softhom::fft {
namespace {

std::mutex& slab_planner_mutex() {
  static std::mutex m;
  return m;
}

// fftw_init_threads() is idempotent (BatchedFFT calls it too); fftw_mpi_init() must follow MPI_Init and
// precede every MPI plan.
void init_fftw_mpi_once() {
  static std::once_flag flag;
  std::call_once(flag, [] {
    fftw_init_threads();
    fftw_mpi_init();
  });
}

}  // namespace

SlabDecomposition::SlabDecomposition(const Grid& grid, MPI_Comm comm) : grid_(grid), comm_(comm) {
  MPI_Comm_rank(comm, &rank_);
  MPI_Comm_size(comm, &size_);
  if (grid.is_section() && size_ > 1)
    throw std::invalid_argument("a section grid (n3 = 1) is solved on one rank, not on " + std::to_string(size_));
  if (grid.n[2] < size_)
    throw std::invalid_argument("n3 = " + std::to_string(grid.n[2]) + " planes cannot be split over " +
                                std::to_string(size_) + " ranks (at least one plane i3 per rank)");
  init_fftw_mpi_once();
  ptrdiff_t local_n = 0, local_start = 0;
  fftw_mpi_local_size_3d(grid.n[2], grid.n[1], grid.half_n1(), comm, &local_n, &local_start);
  long mine[2] = {long(local_start), long(local_n)};
  std::vector<long> all(2 * std::size_t(size_));
  MPI_Allgather(mine, 2, MPI_LONG, all.data(), 2, MPI_LONG, comm);
  slabs_.resize(size_);
  for (int r = 0; r < size_; ++r) slabs_[r] = {int(all[2 * r]), int(all[2 * r + 1])};
  if (slab().count > 0) {
    // Ring of the ranks that hold planes (the default block ⌈n3/P⌉ can leave the last ranks empty).
    auto holder = [&](int r) { return slabs_[(r % size_ + size_) % size_].count > 0; };
    int n = rank_ + 1;
    while (!holder(n)) ++n;
    next_ = n % size_;
    int p = rank_ - 1 + size_;
    while (!holder(p)) --p;
    prev_ = p % size_;
  }
}

int SlabDecomposition::max_planes() const {
  int m = 0;
  for (const Slab& s : slabs_) m = std::max(m, s.count);
  return m;
}

double SlabDecomposition::sum(double local) const {
  sum(&local, 1);
  return local;
}

void SlabDecomposition::sum(double* values, int count) const {
  gather_.resize(std::size_t(count) * size_);
  MPI_Allgather(values, count, MPI_DOUBLE, gather_.data(), count, MPI_DOUBLE, comm_);
  for (int c = 0; c < count; ++c) {
    double s = gather_[c];
    for (int r = 1; r < size_; ++r) s += gather_[std::size_t(r) * count + c];
    values[c] = s;
  }
}

int SlabDecomposition::max(int local) const {
  int m = local;
  MPI_Allreduce(&local, &m, 1, MPI_INT, MPI_MAX, comm_);
  return m;
}

void SlabDecomposition::all_gather(const double* mine, int count, double* all) const {
  MPI_Allgather(mine, count, MPI_DOUBLE, all, count, MPI_DOUBLE, comm_);
}

void SlabDecomposition::min_location(double& value, std::size_t& where) const {
  double mine[2] = {value, double(where)};  // voxel indices < 2^53
  gather_.resize(2 * std::size_t(size_));
  MPI_Allgather(mine, 2, MPI_DOUBLE, gather_.data(), 2, MPI_DOUBLE, comm_);
  for (int r = 0; r < size_; ++r)
    if (r == 0 || gather_[2 * r] < value) {
      value = gather_[2 * r];
      where = std::size_t(gather_[2 * r + 1]);
    }
}

void SlabDecomposition::fill_upper_halo(double* base, std::size_t stride, int fields) const {
  const int count = slab().count;
  if (count == 0) return;  // holds nothing, is nobody's neighbour
  const std::size_t plane = plane_voxels();
  send_.resize(plane * fields);
  recv_.resize(plane * fields);
  for (int f = 0; f < fields; ++f) std::copy(base + f * stride, base + f * stride + plane, send_.data() + f * plane);
  MPI_Sendrecv(send_.data(), int(send_.size()), MPI_DOUBLE, prev_, 71, recv_.data(), int(recv_.size()), MPI_DOUBLE, next_,
               71, comm_, MPI_STATUS_IGNORE);
  for (int f = 0; f < fields; ++f)
    std::copy(recv_.data() + f * plane, recv_.data() + (f + 1) * plane, base + f * stride + plane * count);
}

void SlabDecomposition::fill_lower_halo(double* base, std::size_t values) const {
  const int count = slab().count;
  if (count == 0) return;
  MPI_Sendrecv(base + values * (count - 1), int(values), MPI_DOUBLE, next_, 72, base - values, int(values), MPI_DOUBLE,
               prev_, 72, comm_, MPI_STATUS_IGNORE);
}

void SlabDecomposition::shift_up(const double* send, double* recv, std::size_t values) const {
  if (slab().count == 0) return;
  MPI_Sendrecv(send, int(values), MPI_DOUBLE, next_, 73, recv, int(values), MPI_DOUBLE, prev_, 73, comm_,
               MPI_STATUS_IGNORE);
}

// ---------------------------------------------------------------------------------------------------

SlabFFT::SlabFFT(const SlabDecomposition& slabs, int fields, const PlanOptions& options, int columns, int halo_planes,
                 std::size_t spare_doubles)
    : slabs_(slabs), fields_(fields), rigor_(options.rigor) {
  if (columns < 1 || columns > 3 || (columns < 3 && fields % 9 != 0))
    throw std::invalid_argument("SlabFFT: columns must be 1..3, and < 3 only for 3x3 tensor fields");
  const auto start = std::chrono::steady_clock::now();
  threads_ = options.threads > 0 ? options.threads : omp_get_max_threads();
  for (int f = 0; f < fields; ++f)
    if (columns == 3 || f % 3 < columns) transformed_.push_back(f);
  const Grid& g = slabs.grid();
  real_stride_ = slabs.local_voxels() + std::size_t(halo_planes) * slabs.plane_voxels();
  const std::size_t nr = real_stride_ * fields + spare_doubles, nc = slabs.local_modes() * fields;
  real_ = fftw_alloc_real(std::max<std::size_t>(nr, 1));
  spectrum_ = reinterpret_cast<Complex*>(fftw_alloc_complex(std::max<std::size_t>(nc, 1)));
  const ptrdiff_t H = ptrdiff_t(transformed_.size());
  const ptrdiff_t nreal[3] = {g.n[2], g.n[1], g.n[0]}, ncomplex[3] = {g.n[2], g.n[1], g.half_n1()};
  ptrdiff_t local_n = 0, local_start = 0;
  const ptrdiff_t alloc = fftw_mpi_local_size_many(3, ncomplex, H, FFTW_MPI_DEFAULT_BLOCK, slabs.comm(), &local_n,
                                                   &local_start);
  if (local_n != slabs.slab().count || local_start != slabs.slab().begin)
    throw std::logic_error("SlabFFT: FFTW-MPI slab differs from the decomposition");
  work_doubles_ = 2 * std::size_t(std::max<ptrdiff_t>(alloc, 1));
  work_ = fftw_alloc_real(work_doubles_);
  if (!real_ || !spectrum_ || !work_) throw std::bad_alloc();
  set_buffers(real_, real_stride_, spectrum_, slabs.local_modes());
  set_rows(std::size_t(g.n[0]), std::size_t(g.n[0]));
  const unsigned flags = detail::fftw_flags(options.rigor);
  {
    std::lock_guard<std::mutex> lock(slab_planner_mutex());
    // Wisdom: rank 0 reads it and hands it to all (planning is collective and must agree), then
    // collects what the ranks learnt.
    if (!options.wisdom_file.empty()) {
      if (slabs.rank() == 0) fftw_import_wisdom_from_filename(options.wisdom_file.c_str());
      fftw_mpi_broadcast_wisdom(slabs.comm());
    }
    fftw_plan_with_nthreads(threads_);
    forward_plan_ = fftw_mpi_plan_many_dft_r2c(3, nreal, H, FFTW_MPI_DEFAULT_BLOCK, FFTW_MPI_DEFAULT_BLOCK, work_,
                                               reinterpret_cast<fftw_complex*>(work_), slabs.comm(), flags);
    backward_plan_ = fftw_mpi_plan_many_dft_c2r(3, nreal, H, FFTW_MPI_DEFAULT_BLOCK, FFTW_MPI_DEFAULT_BLOCK,
                                                reinterpret_cast<fftw_complex*>(work_), work_, slabs.comm(), flags);
    if (!options.wisdom_file.empty()) {
      fftw_mpi_gather_wisdom(slabs.comm());
      if (slabs.rank() == 0) fftw_export_wisdom_to_filename(options.wisdom_file.c_str());
    }
  }
  if (!forward_plan_ || !backward_plan_) throw std::runtime_error("fftw-mpi: could not create plans");
  std::fill(real_, real_ + nr, 0.0);
  std::fill(spectrum_, spectrum_ + nc, Complex(0.0));
  std::fill(work_, work_ + work_doubles_, 0.0);
  planning_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

SlabFFT::~SlabFFT() {
  {
    std::lock_guard<std::mutex> lock(slab_planner_mutex());
    if (forward_plan_) fftw_destroy_plan(static_cast<fftw_plan>(forward_plan_));
    if (backward_plan_) fftw_destroy_plan(static_cast<fftw_plan>(backward_plan_));
  }
  fftw_free(real_);
  fftw_free(spectrum_);
  fftw_free(work_);
}

void SlabFFT::forward() {
  const Grid& g = slabs_.grid();
  const std::size_t n1 = g.n[0], m1 = g.half_n1(), padded = 2 * m1, H = transformed_.size();
  const long rows = long(g.n[1]) * slabs_.slab().count;
  const std::size_t modes = slabs_.local_modes();
  // Compact field-major → interleaved padded (the padding values are never read by r2c).
#pragma omp parallel for schedule(static)
  for (long row = 0; row < rows; ++row) {
    double* out = work_ + std::size_t(row) * padded * H;
    for (std::size_t t = 0; t < H; ++t) {
      const double* in = real_ + std::size_t(transformed_[t]) * real_stride_ + std::size_t(row) * n1;
      for (std::size_t i1 = 0; i1 < n1; ++i1) out[i1 * H + t] = in[i1];
    }
  }
  fftw_execute(static_cast<fftw_plan>(forward_plan_));
  const Complex* w = reinterpret_cast<const Complex*>(work_);
#pragma omp parallel for schedule(static)
  for (long row = 0; row < rows; ++row)
    for (std::size_t t = 0; t < H; ++t) {
      Complex* out = spectrum_ + std::size_t(transformed_[t]) * modes + std::size_t(row) * m1;
      const Complex* in = w + std::size_t(row) * m1 * H + t;
      for (std::size_t k1 = 0; k1 < m1; ++k1) out[k1] = in[k1 * H];
    }
}

void SlabFFT::backward() {
  const Grid& g = slabs_.grid();
  const std::size_t n1 = g.n[0], m1 = g.half_n1(), padded = 2 * m1, H = transformed_.size();
  const long rows = long(g.n[1]) * slabs_.slab().count;
  const std::size_t modes = slabs_.local_modes();
  Complex* w = reinterpret_cast<Complex*>(work_);
#pragma omp parallel for schedule(static)
  for (long row = 0; row < rows; ++row)
    for (std::size_t t = 0; t < H; ++t) {
      const Complex* in = spectrum_ + std::size_t(transformed_[t]) * modes + std::size_t(row) * m1;
      Complex* out = w + std::size_t(row) * m1 * H + t;
      for (std::size_t k1 = 0; k1 < m1; ++k1) out[k1 * H] = in[k1];
    }
  fftw_execute(static_cast<fftw_plan>(backward_plan_));
#pragma omp parallel for schedule(static)
  for (long row = 0; row < rows; ++row) {
    const double* in = work_ + std::size_t(row) * padded * H;
    for (std::size_t t = 0; t < H; ++t) {
      double* out = real_ + std::size_t(transformed_[t]) * real_stride_ + std::size_t(row) * n1;
      for (std::size_t i1 = 0; i1 < n1; ++i1) out[i1] = in[i1 * H + t];
    }
  }
}

std::size_t SlabFFT::transpose_bytes() const {
  // FFTW-MPI (spectrum not transposed): the planes k3 of this rank are transposed to a distribution over
  // k2 (block ⌈n2/P⌉) for the transform along k3, and back: twice the part of the local spectrum that
  // belongs to other ranks' k2 blocks.
  const Grid& g = slabs_.grid();
  const int P = slabs_.size(), r = slabs_.rank(), b2 = (g.n[1] + P - 1) / P;
  const int own2 = std::clamp(g.n[1] - r * b2, 0, b2);
  return 2 * std::size_t(slabs_.slab().count) * std::size_t(g.n[1] - own2) * std::size_t(g.half_n1()) *
         transformed_.size() * sizeof(Complex);
}

std::size_t SlabFFT::buffer_bytes() const {
  return (real_stride_ * fields_) * sizeof(double) + slabs_.local_modes() * fields_ * sizeof(Complex) +
         work_doubles_ * sizeof(double);
}

std::string SlabFFT::describe() const {
  const Grid& g = slabs_.grid();
  std::ostringstream os;
  os << "fftw3-mpi r2c " << transformed_fields() << " x " << g.n[0] << "x" << g.n[1] << "x" << g.n[2] << ", "
     << slabs_.size() << " ranks (slabs of " << slabs_.max_planes() << " planes i3), " << threads_
     << " threads/rank, " << to_string(rigor_);
  return os.str();
}

}  // namespace softhom::fft
