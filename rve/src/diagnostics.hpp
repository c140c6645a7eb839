#pragma once
// Failure diagnosis of the FFT engine: the hot spots of the last iterate of a failed sub-step (the
// smallest matrix limit margin, the J extremes, the largest mixed pressure, where the nodal force
// residual concentrates) and the sentence that names them, e.g. Gent locking or an inverted matrix.
#include <array>
#include <cstddef>
#include <functional>
#include <string>
#include <vector>

namespace softhom::rve::detail {

/// A matrix point this close to its limit (Material::limit_margin) is called locked in the diagnosis.
constexpr double kLockingMargin = 0.02;

/// Extremes over the matrix points of an iterate (pure matrix points and the matrix side of
/// composite points) and over its nodal forces.
struct HotSpots {
  double margin = 1.0, J_min = 1.0, J_max = 1.0, p_max = 0.0, force_max = 0.0, force_rms = 0.0;
  std::size_t v_margin = 0, v_J_min = 0, v_force = 0, v_p = 0;
  bool margin_composite = false;
  int near_limit = 0;  // matrix points with margin < 0.1
  /// A matrix point of voxel v: its limit margin (Gent: 1 − (Ī1 − 3)/Jm) and J.
  void see_matrix_point(std::size_t v, double m, double J, bool composite);
  /// The mixed (u, p) pressure of a pure matrix point of voxel v.
  void see_pressure(std::size_t v, double p);
  /// Nodal force fields (three components, N voxels each): the largest and the rms magnitude.
  void see_forces(const double* f0, const double* f1, const double* f2, std::size_t N);
};

/// "voxel (i1, i2[, i3], fiber fraction φ)".
std::string voxel_name(const std::array<int, 3>& n, const std::vector<double>& phi, std::size_t v);
/// Fiber fraction of a voxel of the whole grid (a distributed cell holds its slab only).
using FractionOf = std::function<double(std::size_t)>;
std::string voxel_name(const std::array<int, 3>& n, const FractionOf& phi, std::size_t v);

/// The hot spots as a sentence for the failure message; names a reached domain limit (Gent locking)
/// with the last converged F11 (load frame), or an inverted matrix.
std::string describe_hot_spots(const HotSpots& h, const std::array<int, 3>& n, const std::vector<double>& phi,
                               bool matrix_mixed, double F11_committed);
std::string describe_hot_spots(const HotSpots& h, const std::array<int, 3>& n, const FractionOf& phi,
                               bool matrix_mixed, double F11_committed);

}  // namespace softhom::rve::detail
