#pragma once
// The comparison of two solutions of one problem in the petsc-path tests.
#include <mpi.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "softhom/core/mpi.hpp"

namespace softhom::test {

/// max |u − reference| / max |reference|: the solvers' agreement relative to the size of the answer.
inline double relative_difference(const std::vector<double>& u, const std::vector<double>& reference) {
  double d = 0.0, scale = 1e-300;
  for (std::size_t i = 0; i < u.size(); ++i) {
    d = std::max(d, std::abs(u[i] - reference[i]));
    scale = std::max(scale, std::abs(reference[i]));
  }
  return d / scale;
}

/// Every rank must hold the same solution (replicated Newton iteration): the largest over the ranks of
/// the difference to rank 0's copy (collective).
inline double rank_spread(const std::vector<double>& u) {
  if (!mpi::active() || mpi::world_size() == 1) return 0.0;
  std::vector<double> root = u;
  MPI_Bcast(root.data(), int(root.size()), MPI_DOUBLE, 0, MPI_COMM_WORLD);
  double d = relative_difference(u, root);
  MPI_Allreduce(MPI_IN_PLACE, &d, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
  return d;
}

}  // namespace softhom::test
