#pragma once
// The comparison of two solutions of one problem in the petsc-path tests.
#include <algorithm>
#include <cmath>
#include <vector>

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

}  // namespace softhom::test
