// The launch rule of softhom/core/mpi.hpp under mpirun: every rank sees MPI active, its own rank and the
// same size, and a reduction over ranks gives the closed-form sum.
#include <gtest/gtest.h>
#include <mpi.h>

#include <cstdlib>

#include "softhom/core/mpi.hpp"

using namespace softhom;

TEST(MpiRanks, LaunchedByMpirunIsActive) {
  EXPECT_TRUE(mpi::launched_by_mpi_launcher());
  ASSERT_TRUE(mpi::active());
  const int n = mpi::world_size();
  const int r = mpi::world_rank();
  EXPECT_GE(n, 1);
  EXPECT_GE(r, 0);
  EXPECT_LT(r, n);
  int sum = r;
  MPI_Allreduce(MPI_IN_PLACE, &sum, 1, MPI_INT, MPI_SUM, MPI_COMM_WORLD);
  EXPECT_EQ(sum, n * (n - 1) / 2);
  EXPECT_FALSE(mpi::processor_name().empty());
}
