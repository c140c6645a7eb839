// SlabFFT against BatchedFFT: on every rank the compact spectra of its planes k3 equal the serial
// spectrum's rows of those planes, and the backward transform the serial real slab (odd and even n1, the
// column subset of tensor fields), to 1e-12 relative (the two FFTW plans differ in the order of their
// sums only). The decomposition's rank-ordered sum is identical on every rank.
#include <gtest/gtest.h>
#include <mpi.h>

#include <cmath>

#include "softhom/fft/slab.hpp"

using namespace softhom::fft;

namespace {

void expect_slab_transform_matches(std::array<int, 3> n, int fields, int columns) {
  Grid g;
  g.n = n;
  const SlabDecomposition d(g, MPI_COMM_WORLD);
  SlabFFT slab(d, fields, {PlanRigor::estimate, 1, {}}, columns);
  BatchedFFT serial(g, fields, {PlanRigor::estimate, 1, {}}, columns);
  const std::size_t N = g.voxels(), off = d.voxel_offset(), local = d.local_voxels();
  for (int f = 0; f < fields; ++f)
    for (std::size_t v = 0; v < N; ++v) {
      const double x = std::sin(0.37 * double(v) + 1.3 * f) + 0.1 * std::cos(double(v * v % 101));
      serial.real(f)[v] = x;
      if (v >= off && v < off + local) slab.real(f)[v - off] = x;
    }
  serial.forward();
  slab.forward();
  double scale = 0.0, diff = 0.0;
  for (int f = 0; f < fields; ++f) {
    if (columns < 3 && f % 3 >= columns) continue;
    for (std::size_t k = 0; k < d.local_modes(); ++k) {
      scale = std::max(scale, std::abs(serial.spectrum(f)[d.mode_offset() + k]));
      diff = std::max(diff, std::abs(serial.spectrum(f)[d.mode_offset() + k] - slab.spectrum(f)[k]));
    }
  }
  EXPECT_LE(diff, 1e-12 * std::max(scale, 1.0));
  serial.backward();
  slab.backward();
  diff = 0.0;
  for (int f = 0; f < fields; ++f) {
    if (columns < 3 && f % 3 >= columns) continue;
    for (std::size_t v = 0; v < local; ++v) diff = std::max(diff, std::abs(serial.real(f)[off + v] - slab.real(f)[v]));
  }
  EXPECT_LE(diff, 1e-12 * double(N));
  int size = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  if (size > 1 && d.slab().count > 0) { EXPECT_GT(slab.transpose_bytes(), 0u); }
}

}  // namespace

TEST(SlabFFT, MatchesBatchedFFTOnEachSlab) {
  expect_slab_transform_matches({9, 6, 7}, 3, 3);
  expect_slab_transform_matches({8, 6, 5}, 18, 2);
}

TEST(SlabDecomposition, RankOrderedSumIsIdenticalEverywhere) {
  Grid g;
  g.n = {4, 4, 6};
  const SlabDecomposition d(g, MPI_COMM_WORLD);
  const double mine = 1.0 / (3.0 + d.rank()) + 1e-17 * d.rank();
  const double s = d.sum(mine);
  double lo = s, hi = s;
  MPI_Allreduce(MPI_IN_PLACE, &lo, 1, MPI_DOUBLE, MPI_MIN, MPI_COMM_WORLD);
  MPI_Allreduce(MPI_IN_PLACE, &hi, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
  EXPECT_EQ(lo, hi);  // bit-identical on every rank
  double expected = 0.0;
  for (int r = 0; r < d.size(); ++r) expected += 1.0 / (3.0 + r) + 1e-17 * r;
  EXPECT_EQ(s, expected);
}
