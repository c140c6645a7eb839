// Distributed FFT cells (BENCHMARKS.md, "Distributed FFT cells"): on an n³ cell with one fiber, the time
// of a 9-field FFT round trip (forward + backward), the time per Krylov iteration of a Newton–CG solve
// (stencil operator, rotated), and the bytes a rank sends per Krylov iteration (the FFTW-MPI transposes
// of the 3-field displacement/force transforms plus the two stencil halo planes), on 1 rank (BatchedFFT,
// the one-process solver) or P ranks (SlabFFT).
//
//   OMP_NUM_THREADS=1 mpirun -n P bench_fft_mpi [n] [fft repetitions] [measure|estimate]
//   OMP_NUM_THREADS=1 bench_fft_mpi [n]            (one process)
//
// Times are the slowest rank's (median of the repetitions); prints one RESULT line.
#include <mpi.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "softhom/fft/slab.hpp"
#include "softhom/io/files.hpp"
#include "softhom/core/mpi.hpp"
#include "softhom/materials/laws.hpp"
#include "softhom/materials/loading.hpp"
#include "softhom/rve/fft_solver.hpp"
#include "softhom/rve/slab_image.hpp"

using namespace softhom;
using Clock = std::chrono::steady_clock;

namespace {

double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

double slowest(double t, bool mpi) {
  if (mpi) MPI_Allreduce(MPI_IN_PLACE, &t, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
  return t;
}

/// One straight fiber along y3 of radius 0.25 (VF ≈ 0.2), fractions by 3×3 sub-sampling of the section;
/// under MPI only this rank's slab image (its planes and the halo), as `softhom rve` builds it.
rve::PhaseImage fiber_cell(int n) {
  rve::PhaseImage im;
  im.n = {n, n, 1};
  im.size = {1.0, 1.0, 1.0 / n};
  const std::size_t plane = std::size_t(n) * n;
  std::vector<double> f(plane);
  std::vector<Eigen::Vector3d> nr(plane, Eigen::Vector3d::Zero());
  const int s = 3;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      int in = 0;
      for (int b = 0; b < s; ++b)
        for (int a = 0; a < s; ++a) {
          const double x = (i + (a + 0.5) / s) / n - 0.5, y = (j + (b + 0.5) / s) / n - 0.5;
          in += x * x + y * y < 0.0625;
        }
      f[i + std::size_t(n) * j] = double(in) / (s * s);
      const Eigen::Vector3d c((i + 0.5) / n - 0.5, (j + 0.5) / n - 0.5, 0.0);
      if (in > 0 && in < s * s) nr[i + std::size_t(n) * j] = c.normalized();
    }
  im.fiber_fraction = f;
  im.normal = nr;
  if (const auto planes = rve::distributed_planes({n, n, n}))
    return rve::extrude_planes(im, n, planes->begin, planes->count, rve::kSlabImageHalo);
  return rve::extrude(im, n);
}

}  // namespace

int main(int argc, char** argv) {
  mpi::Environment env(argc, argv);
  const bool with_mpi = mpi::active() && mpi::world_size() > 1;
  const int rank = mpi::world_rank(), ranks = mpi::world_size();
  const int n = argc > 1 ? std::atoi(argv[1]) : 64;
  const int reps = argc > 2 ? std::atoi(argv[2]) : 5;
  fft::Grid grid;
  grid.n = {n, n, n};
  const bool estimate = argc > 3 && std::string(argv[3]) == "estimate";
  fft::PlanOptions plan{estimate ? fft::PlanRigor::estimate : fft::PlanRigor::measure, 0, {}};

  // 1. 9-field FFT round trip.
  std::unique_ptr<fft::SlabDecomposition> slabs;
  std::unique_ptr<fft::FieldTransform> t9;
  std::size_t comm_bytes = 0;
  const auto plan_start = Clock::now();
  if (with_mpi) {
    slabs = std::make_unique<fft::SlabDecomposition>(grid, MPI_COMM_WORLD);
    t9 = std::make_unique<fft::SlabFFT>(*slabs, 9, plan);
    fft::SlabFFT t3(*slabs, 3, plan);
    // Per Krylov iteration: backward + forward of the 3-field transform, and the halos (3 displacement
    // planes up, 9 stress values per voxel of one plane down; rotated scheme).
    comm_bytes = 2 * t3.transpose_bytes() + (3 + 9) * slabs->plane_voxels() * sizeof(double);
  } else {
    t9 = std::make_unique<fft::BatchedFFT>(grid, 9, plan);
  }
  const double planning = slowest(seconds_since(plan_start), with_mpi);
  const std::size_t local = with_mpi ? slabs->local_voxels() : grid.voxels();
  for (int f = 0; f < 9; ++f)
    for (std::size_t v = 0; v < local; ++v) t9->real(f)[v] = std::sin(0.001 * double(v + f));
  std::vector<double> times;
  for (int r = 0; r < reps; ++r) {
    if (with_mpi) MPI_Barrier(MPI_COMM_WORLD);
    const auto t0 = Clock::now();
    t9->forward();
    t9->backward();
    times.push_back(slowest(seconds_since(t0), with_mpi));
  }
  std::sort(times.begin(), times.end());
  const double round_trip = times[times.size() / 2];
  t9.reset();
  std::size_t comm_max = comm_bytes;
  if (with_mpi) MPI_Allreduce(MPI_IN_PLACE, &comm_max, 1, MPI_UNSIGNED_LONG, MPI_MAX, MPI_COMM_WORLD);

  // 2. One Newton–CG step (uniaxial stress, lateral stress-free: two macro unknowns).
  const rve::PhaseImage im = fiber_cell(n);
  rve::FftSolverOptions opt;
  opt.distributed = true;
  opt.plan = plan;
  opt.tolerance = 1e-6;
  const MaterialPtr matrix = make_material(make_neo_hookean({0.5, 5.0})), fiber = make_material(make_neo_hookean({5.0, 40.0}));
  const auto build_start = Clock::now();
  rve::FftRveSolver solver(im, matrix, fiber, 0.0, Mat3::Identity(), opt);
  const double build = slowest(seconds_since(build_start), with_mpi);
  MixedControl c = uniaxial_control(PiecewiseLinear{{0.0, 1.0}, {1.0, 1.05}});
  c.times = {1.0};
  const auto solve_start = Clock::now();
  const rve::RveRunResult res = solver.run(c);
  const double solve = slowest(seconds_since(solve_start), with_mpi);
  const double krylov = slowest(res.krylov_seconds, with_mpi);
  double mem = double(io::peak_memory_bytes());
  if (with_mpi) MPI_Allreduce(MPI_IN_PLACE, &mem, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
  double image_mb = 1e-6 * double(im.fiber_fraction.size() * sizeof(double) + im.normal.size() * sizeof(Eigen::Vector3d));
  if (with_mpi) MPI_Allreduce(MPI_IN_PLACE, &image_mb, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
  if (rank == 0) {
    std::printf("RESULT n=%d ranks=%d threads=%d planning_s=%.2f fft9_roundtrip_ms=%.2f krylov_ms=%.2f "
                "comm_bytes_per_krylov_per_rank=%zu newton=%d krylov=%d solve_s=%.2f setup_s=%.2f P11=%.10g "
                "peak_rss_MB_per_rank=%.0f phase_image_MB_per_rank=%.2f completed=%d\n",
                n, ranks, std::max(1, std::atoi(std::getenv("OMP_NUM_THREADS") ? std::getenv("OMP_NUM_THREADS") : "0")),
                planning, 1e3 * round_trip, 1e3 * krylov / std::max(1, res.krylov_iterations), comm_max,
                res.newton_iterations, res.krylov_iterations, solve, build, res.steps.back().P(0, 0), mem / 1e6,
                image_mb, int(res.completed));
  }
  return 0;
}
