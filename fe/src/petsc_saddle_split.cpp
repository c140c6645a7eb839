#include "petsc_saddle_split.hpp"

#include <algorithm>
#include <cmath>

namespace softhom::fe {
namespace {

/// Element k's distinct free equations and the sums of d over the positions of each (a degenerate hex
/// has two corners on one node).
void distinct_dofs(const std::vector<int>& off, const std::vector<int>& eq, const std::vector<double>& d, int k,
                   std::vector<int>& rows, std::vector<double>& s) {
  rows.clear();
  s.clear();
  for (int q = off[k]; q < off[k + 1]; ++q) {
    if (eq[q] < 0) continue;
    const auto it = std::find(rows.begin(), rows.end(), eq[q]);
    if (it == rows.end()) {
      rows.push_back(eq[q]);
      s.push_back(d[q]);
    } else {
      s[std::size_t(it - rows.begin())] += d[q];
    }
  }
}

}  // namespace

AugmentedSplit augmented_split(const CscMatrix& K, const std::vector<int>& off, const std::vector<int>& eq,
                               const std::vector<double>& d, const std::vector<double>& c, double alpha) {
  const int np = int(c.size());
  // diag(A) = diag(K) − Σ_k c_k s_k²: the displacement block without any volumetric stiffness.
  std::vector<double> diag(K.n, 0.0);
  for (int r = 0; r < K.n; ++r) {
    const long p = K.find(r, r);
    if (p >= 0) diag[r] = K.values[p];
  }
  std::vector<int> rows;
  std::vector<double> s;
  for (int k = 0; k < np; ++k) {
    distinct_dofs(off, eq, d, k, rows, s);
    for (std::size_t i = 0; i < rows.size(); ++i) diag[rows[i]] -= c[k] * s[i] * s[i];
  }
  // A floor against a vanishing or negative diagonal entry (the geometric pressure terms of F-bar can
  // make A indefinite under a large pressure): a fraction of the mean magnitude.
  double mean = 0.0;
  for (double v : diag) mean += std::abs(v);
  mean = K.n > 0 ? mean / K.n : 1.0;
  AugmentedSplit out;
  out.kept.resize(np);
  out.schur_diag.resize(np);
  for (int k = 0; k < np; ++k) {
    distinct_dofs(off, eq, d, k, rows, s);
    double x = 0.0;
    for (std::size_t i = 0; i < rows.size(); ++i) x += s[i] * s[i] / std::max(std::abs(diag[rows[i]]), 1e-3 * mean);
    const double gamma = x > 0.0 ? std::min(alpha / x, 0.5 * c[k]) : 0.0;
    out.kept[k] = c[k] - gamma;
    out.schur_diag[k] = -1.0 - out.kept[k] * x / (1.0 + gamma * x);
  }
  return out;
}

}  // namespace softhom::fe
