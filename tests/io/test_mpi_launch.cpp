// Without an MPI launcher softhom never initialises MPI: the one-process answers hold.
#include <gtest/gtest.h>

#include <cstdlib>

#include "softhom/core/mpi.hpp"

using namespace softhom;

TEST(MpiLaunch, PlainStartIsOneProcessWithoutMpi) {
  // ctest starts this binary directly (never under mpirun): no launcher variables are set.
  if (mpi::launched_by_mpi_launcher()) GTEST_SKIP() << "started under an MPI launcher";
  EXPECT_FALSE(mpi::active());
  EXPECT_EQ(mpi::world_rank(), 0);
  EXPECT_EQ(mpi::world_size(), 1);
  EXPECT_FALSE(mpi::processor_name().empty());
}
