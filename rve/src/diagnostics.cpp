// Failure diagnosis of the FFT engine (see diagnostics.hpp).
#include "diagnostics.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace softhom::rve::detail {

void HotSpots::see_matrix_point(std::size_t v, double m, double J, bool composite) {
  if (m < margin) {
    margin = m;
    v_margin = v;
    margin_composite = composite;
  }
  if (m < 0.1) ++near_limit;
  if (J < J_min) {
    J_min = J;
    v_J_min = v;
  }
  J_max = std::max(J_max, J);
}

void HotSpots::see_pressure(std::size_t v, double p) {
  if (std::abs(p) > p_max) {
    p_max = std::abs(p);
    v_p = v;
  }
}

void HotSpots::see_forces(const double* f0, const double* f1, const double* f2, std::size_t N) {
  double s2 = 0.0;
  for (std::size_t v = 0; v < N; ++v) {
    const double f2v = f0[v] * f0[v] + f1[v] * f1[v] + f2[v] * f2[v];
    s2 += f2v;
    if (f2v > force_max) {
      force_max = f2v;
      v_force = v;
    }
  }
  force_max = std::sqrt(force_max);
  force_rms = std::sqrt(s2 / double(N));
}

std::string voxel_name(const std::array<int, 3>& n, const std::vector<double>& phi, std::size_t v) {
  return voxel_name(n, FractionOf([&phi](std::size_t w) { return phi[w]; }), v);
}

std::string voxel_name(const std::array<int, 3>& n, const FractionOf& phi, std::size_t v) {
  std::ostringstream s;
  s << "voxel (" << v % n[0] << ", " << (v / n[0]) % n[1];
  if (n[2] > 1) s << ", " << v / (std::size_t(n[0]) * n[1]);
  s << ", fiber fraction " << phi(v) << ")";
  return s.str();
}

std::string describe_hot_spots(const HotSpots& h, const std::array<int, 3>& n, const std::vector<double>& phi,
                               bool matrix_mixed, double F11_committed) {
  return describe_hot_spots(h, n, FractionOf([&phi](std::size_t w) { return phi[w]; }), matrix_mixed, F11_committed);
}

std::string describe_hot_spots(const HotSpots& h, const std::array<int, 3>& n, const FractionOf& phi,
                               bool matrix_mixed, double F11_committed) {
  auto name = [&](std::size_t v) { return voxel_name(n, phi, v); };
  std::ostringstream s;
  s.precision(3);
  s << "last iterate: matrix limit margin " << h.margin << " (1 at F = I, 0 at the law's limit, e.g. Gent "
    << "locking Ī1 − 3 = Jm) at " << name(h.v_margin) << (h.margin_composite ? " [composite]" : "") << ", "
    << h.near_limit << " matrix points below 0.1; matrix J − 1 in [" << h.J_min - 1.0 << ", " << h.J_max - 1.0 << "]";
  if (matrix_mixed) s << "; max |p| " << h.p_max << " at " << name(h.v_p);
  s << "; largest nodal force residual at " << name(h.v_force) << ", " << h.force_max / std::max(h.force_rms, 1e-300)
    << "× its rms";
  if (!(h.J_min > 0.0))
    s << ". The matrix inverts (J ≤ 0) at " << name(h.v_J_min);
  else if (h.margin < kLockingMargin)
    s << ". The matrix is at its limit there (Gent locking): if that persists through the cut-backs, the cell has no "
      << "solution beyond F11 = " << F11_committed << " (last converged, load frame)";
  return s.str();
}

}  // namespace softhom::rve::detail
