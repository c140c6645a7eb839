// The phase image of a distributed FFT cell built and held per slab (rve/slab_image.hpp): each rank's
// slab image is exactly the whole image restricted to its planes and halo, holds ⌈n3/P⌉ + 2 planes at
// most, and the distributed solve on slab images is the one-process solve on the whole image (same
// Newton and Krylov counts, P̄ to 1e-10 relative: the distribution changes only the order of sums, see
// test_distributed_fft_cell.cpp), with the achieved volume fraction reduced over the ranks.
#include <gtest/gtest.h>
#include <mpi.h>

#include <algorithm>
#include <cmath>

#include "softhom/fft/slab.hpp"
#include "softhom/materials/laws.hpp"
#include "softhom/materials/loading.hpp"
#include "softhom/rve/fft_solver.hpp"
#include "softhom/rve/slab_image.hpp"

using namespace softhom;
using namespace softhom::rve;

namespace {

int world_ranks() {
  int n = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &n);
  return n;
}

/// A section of one circular fiber (the generator of `softhom rve`).
PhaseImage circle_section(int n1, int n2) {
  FiberCellSpec spec;
  spec.volume_fraction = 0.23;
  spec.radius = 0.2;
  return voxelize_section(generate_section(spec), n1, n2);
}

/// A fiber whose axis is inclined in the y1–y3 plane, fractions by 4³ sub-sampling and no normals: the
/// solver estimates −∇φ, whose i3 differences read the slab's halo planes.
PhaseImage inclined_fiber_without_normals(std::array<int, 3> n) {
  PhaseImage im;
  im.n = n;
  im.size = {1.0, double(n[1]) / n[0], double(n[2]) / n[0]};
  im.fiber_fraction.assign(im.voxels(), 0.0);
  const double h = 1.0 / n[0], r = 0.22, tilt = 0.5;
  const Eigen::Vector3d a(std::sin(tilt), 0.0, std::cos(tilt)), c(0.5, 0.5 * im.size[1], 0.5 * im.size[2]);
  const int s = 4;
  for (int k = 0; k < n[2]; ++k)
    for (int j = 0; j < n[1]; ++j)
      for (int i = 0; i < n[0]; ++i) {
        int inside = 0;
        for (int ck = 0; ck < s; ++ck)
          for (int cj = 0; cj < s; ++cj)
            for (int ci = 0; ci < s; ++ci) {
              Eigen::Vector3d d = Eigen::Vector3d((i + (ci + 0.5) / s) * h, (j + (cj + 0.5) / s) * h, (k + (ck + 0.5) / s) * h) - c;
              d[0] -= std::round(d[0]);  // nearest periodic image along y1 (L1 = 1)
              inside += (d - d.dot(a) * a).norm() < r;
            }
        im.fiber_fraction[i + std::size_t(n[0]) * (j + std::size_t(n[1]) * k)] = double(inside) / (s * s * s);
      }
  return im;
}

struct Solve {
  std::vector<RveStep> steps;
  double vf = 0.0;
  std::size_t phase_bytes = 0;  // the solver's "phase_image" array
};

Solve solve(const PhaseImage& im, bool distributed) {
  FftSolverOptions opt;
  opt.distributed = distributed;
  opt.plan.rigor = fft::PlanRigor::estimate;
  opt.plan.threads = 1;
  opt.tolerance = 1e-8;
  const MaterialPtr matrix = make_material(make_neo_hookean({0.5, 5.0})), fiber = make_material(make_neo_hookean({5.0, 40.0}));
  FftRveSolver solver(im, matrix, fiber, 30.0, Mat3::Identity(), opt);
  MixedControl c = uniaxial_control(PiecewiseLinear{{0.0, 1.0}, {1.0, 1.1}});
  c.times = {0.5, 1.0};
  const RveRunResult res = solver.run(c);
  EXPECT_TRUE(res.completed) << res.error;
  Solve out{res.steps, solver.achieved_volume_fraction(), 0};
  for (const auto& [array, bytes] : solver.memory_breakdown())
    if (array == "phase_image") out.phase_bytes = bytes;
  return out;
}

void expect_same(const Solve& serial, const Solve& dist) {
  ASSERT_EQ(serial.steps.size(), dist.steps.size());
  for (std::size_t k = 1; k < serial.steps.size(); ++k) {
    EXPECT_EQ(serial.steps[k].newton_iterations, dist.steps[k].newton_iterations) << "step " << k;
    EXPECT_EQ(serial.steps[k].krylov_iterations, dist.steps[k].krylov_iterations) << "step " << k;
    const double scale = serial.steps[k].P.cwiseAbs().maxCoeff();
    EXPECT_LE((serial.steps[k].P - dist.steps[k].P).cwiseAbs().maxCoeff() / scale, 1e-10) << "step " << k;
  }
  // Σ φ over the ranks' planes: the same voxels summed in another grouping, 1e-14 relative.
  EXPECT_NEAR(dist.vf, serial.vf, 1e-14 * serial.vf);
}

}  // namespace

// Each rank voxelizes its own planes: equal to the whole image cut to them, and about 1/P of it.
TEST(SlabPhaseImage, ExtrudedPlanesAreTheWholeImageRestricted) {
  const std::array<int, 3> n{12, 10, 9};
  const PhaseImage section = circle_section(n[0], n[1]), whole = extrude(section, n[2]);
  const auto planes = distributed_planes(n);
  ASSERT_EQ(bool(planes), world_ranks() > 1);
  if (!planes) return;
  const PhaseImage slab = extrude_planes(section, n[2], planes->begin, planes->count, kSlabImageHalo);
  const PhaseImage cut = slab_of(whole, planes->begin, planes->count, kSlabImageHalo);
  EXPECT_EQ(slab.fiber_fraction, cut.fiber_fraction);
  ASSERT_EQ(slab.normal.size(), cut.normal.size());
  for (std::size_t v = 0; v < slab.normal.size(); ++v) EXPECT_EQ(slab.normal[v], cut.normal[v]) << v;
  // Held planes: its own (FFTW-MPI's block ⌈n3/P⌉ at most) and one halo plane each side.
  const std::size_t plane = std::size_t(n[0]) * n[1];
  const int block = (n[2] + world_ranks() - 1) / world_ranks();
  EXPECT_LE(planes->count, block);
  EXPECT_EQ(slab.held_voxels(), plane * std::size_t(planes->count + (planes->count > 0 ? 2 : 0)));
  EXPECT_EQ(slab.fiber_fraction.size(), slab.held_voxels());
  // Every held plane is the plane it stands for (periodic halo).
  for (int k = planes->begin - 1; k <= planes->begin + planes->count && planes->count > 0; ++k)
    for (int j = 0; j < n[1]; ++j)
      for (int i = 0; i < n[0]; ++i)
        EXPECT_EQ(slab.fiber_fraction[slab.index_of(i, j, k)], whole.fiber_fraction[whole.index_of(i, j, k)]);
  // Σ φ over the ranks' own planes is the whole image's (each plane owned once).
  double sum = slab.owned_fiber_sum();
  MPI_Allreduce(MPI_IN_PLACE, &sum, 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
  EXPECT_NEAR(sum, whole.owned_fiber_sum(), 1e-12 * whole.owned_fiber_sum());
}

// The distributed solver on slab images is the one-process solver on the whole image, and holds the
// phase arrays of its planes only (the solver's accounting: count/n3 of the one-process bytes).
TEST(SlabPhaseImage, DistributedSolveOnSlabImagesEqualsSerial) {
  const std::array<int, 3> n{10, 8, 7};
  const PhaseImage section = circle_section(n[0], n[1]), whole = extrude(section, n[2]);
  const auto planes = distributed_planes(n);
  const PhaseImage mine = planes ? extrude_planes(section, n[2], planes->begin, planes->count, kSlabImageHalo) : whole;
  const Solve serial = solve(whole, false), dist = solve(mine, true);
  expect_same(serial, dist);
  const int count = planes ? planes->count : n[2];
  EXPECT_EQ(dist.phase_bytes * std::size_t(n[2]), serial.phase_bytes * std::size_t(count));
}

// Normals estimated from −∇φ (an image without normals, inclined fiber: φ varies along i3) read the
// neighbours' planes from the slab's halo: equal to the one-process solve.
TEST(SlabPhaseImage, EstimatedNormalsReadTheHaloPlanes) {
  const PhaseImage whole = inclined_fiber_without_normals({10, 8, 7});
  const PhaseImage mine = rank_image(whole);
  EXPECT_EQ(mine.is_slab(), world_ranks() > 1);
  expect_same(solve(whole, false), solve(mine, true));
}

// A slab image of other planes than the rank's, or on one process, is refused (a programming error).
TEST(SlabPhaseImage, RefusesAForeignSlab) {
  const std::array<int, 3> n{10, 8, 7};
  const PhaseImage section = circle_section(n[0], n[1]);
  FftSolverOptions opt;
  opt.plan.rigor = fft::PlanRigor::estimate;
  const MaterialPtr m = make_material(make_neo_hookean({0.5, 5.0}));
  // Planes [0, 7) as a slab: the whole cell, but a slab image needs the distributed solver's own slab.
  const PhaseImage all_planes = extrude_planes(section, n[2], 0, n[2], kSlabImageHalo);
  opt.distributed = false;
  EXPECT_THROW(FftRveSolver(all_planes, m, m, 0.0, Mat3::Identity(), opt), std::invalid_argument);
  if (world_ranks() > 1) {
    opt.distributed = true;
    EXPECT_THROW(FftRveSolver(all_planes, m, m, 0.0, Mat3::Identity(), opt), std::invalid_argument);
  }
}
