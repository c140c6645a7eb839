// main() of the MPI test suites (tests/mpi_*/): run under `mpirun -n N`; every rank runs every test, rank 0
// prints, and the suite fails when any rank fails.
#include <gtest/gtest.h>
#include <mpi.h>

#include "softhom/core/mpi.hpp"

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  softhom::mpi::Environment environment(argc, argv);
  if (softhom::mpi::world_rank() != 0) {
    auto& listeners = ::testing::UnitTest::GetInstance()->listeners();
    delete listeners.Release(listeners.default_result_printer());
  }
  int failed = RUN_ALL_TESTS() != 0 ? 1 : 0;
  if (softhom::mpi::active()) MPI_Allreduce(MPI_IN_PLACE, &failed, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  return failed;
}
