#pragma once
// Storage accounting of the FFT RVE solver: every array whose size grows with the grid, by name.
//
// One list serves three purposes: FftRveSolver::memory_bytes() (the sum over the arrays as they are
// allocated), FftRveSolver::memory_breakdown() (bytes per array, written to summary.json) and the
// size check before construction (planned_bytes(): the same list filled from the problem size, so the
// refusal of too-big grids follows the storage as it is). Arrays a scene does not need (history of
// elastic phases, pressures of compressible phases, jump vectors without composite voxels, tangents of
// the fixed-point scheme) are absent or of size zero. Not counted: the seven work vectors of a MINRES
// solve (indefinite tangents near an equilibrium, FftSolverOptions::indefinite_solver), allocated for
// that solve only (+7 spectral vectors while it runs).
#include <cstddef>
#include <string>
#include <utility>
#include <vector>

namespace softhom::rve::detail {

/// (array, bytes) in allocation order.
using StorageList = std::vector<std::pair<std::string, std::size_t>>;

inline std::size_t storage_total(const StorageList& l) {
  std::size_t b = 0;
  for (const auto& e : l) b += e.second;
  return b;
}

/// Sizes that decide the solver's storage (counted from the arrays, or planned from the problem).
struct StorageSizes {
  std::size_t voxels = 0, modes = 0, points = 0;
  std::size_t fft_fields = 0;          ///< real fields of the evaluation (9 · points per voxel)
  std::size_t fft_spectra = 0;         ///< their spectra (0 with the stencil operator: 3 at a time in fft3's)
  std::size_t fft3_fields = 0;         ///< 3 with the stencil Krylov operator, else 0
  std::size_t stream_scratch_values = 0;  ///< slice stores of the streamed passes (doubles; 0: not streamed)
  bool fft3_in_place = false;          ///< their real fields inside the spectra (padded rows, one process)
  std::size_t tangent_values = 0;      ///< stored tangent entries (padded)
  std::size_t tangent_value_bytes = 8; ///< 8 double, 4 float
  std::size_t compact_values = 0;      ///< compact tangent records (floats, 14 per point, padded)
  std::size_t composite_tangent_values = 0;  ///< full tangents of the composite points with compact ones (floats)
  std::size_t green_values = 0;        ///< reference Green operator table (6 per mode, ReferenceGreen)
  std::size_t green_value_bytes = 8;   ///< 8 double, 4 float (with float tangents)
  std::size_t jacobi_values = 0;       ///< Jacobi–Green scaling, 3 per node (floats; 0 with the Green preconditioner)
  std::size_t local_bulk_voxels = 0;   ///< green-local-bulk: a weight per voxel (float) and a one-field transform
  bool local_bulk_in_place = false;    ///< that transform's real field inside its spectrum (one process)
  std::size_t history_values = 0;      ///< internal variables, one copy (both phases)
  std::size_t laminate_values = 0;     ///< jump vectors of the composite points, one copy
  std::size_t composite_voxels = 0;    ///< composite voxels (interface normal and fiber fraction each)
  std::size_t mixed_points = 0;        ///< points carried by the mixed (u, p) iteration arrays (0: none)
  std::size_t mixed_slope_points = 0;  ///< of them, points whose pressure slopes are stored (0 with compact tangents)
  std::size_t mean_dilatation_values = 0;  ///< voxel coupling of the mean-dilatation tangent (doubles; 0: pointwise)
  std::size_t spectral_vectors = 0;    ///< 3-component half spectra (unknowns, state and Krylov vectors)
};

/// Bytes of the mixed (u, p) arrays per point: one linearization's offset (1 double; the one of the last
/// evaluation, the accepted one being recomputed after a rejected line-search trial), the pressure of the
/// last evaluation, the committed one and its increment (float) and P_full − P̂ as a multiple of the
/// slopes (1 float); + the linearization's 9 float slopes where they are stored
/// (kMixedSlopeBytesPerPoint), not with compact tangents (recomputed from their records' F).
constexpr std::size_t kMixedBytesPerPoint = 8 + 3 * 4 + 4;
constexpr std::size_t kMixedSlopeBytesPerPoint = 9 * 4;

inline StorageList storage_list(const StorageSizes& s) {
  const std::size_t field = 8 * s.voxels + 16 * s.modes;  // one real field and its half spectrum
  StorageList l;
  if (s.fft_fields) l.emplace_back("fft_buffers", s.fft_fields * 8 * s.voxels + s.fft_spectra * 16 * s.modes);
  if (s.fft3_fields) l.emplace_back("fft3_buffers", s.fft3_fields * (s.fft3_in_place ? 16 * s.modes : field));
  if (s.stream_scratch_values) l.emplace_back("stream_scratch", 8 * s.stream_scratch_values);
  if (s.tangent_values) l.emplace_back("tangents", s.tangent_values * s.tangent_value_bytes);
  if (s.compact_values) l.emplace_back("compact_tangents", s.compact_values * 4);
  l.emplace_back("reference_green", s.green_values * s.green_value_bytes);
  if (s.jacobi_values) l.emplace_back("jacobi_scaling", s.jacobi_values * 4);
  if (s.local_bulk_voxels)
    l.emplace_back("local_bulk", 4 * s.local_bulk_voxels + (s.local_bulk_in_place ? 16 * s.modes : field));
  if (s.history_values) l.emplace_back("history", 2 * 8 * s.history_values);
  l.emplace_back("phase_image", s.voxels * 4);  // phase or composite index
  if (s.composite_voxels)
    l.emplace_back("composites", 2 * 8 * s.laminate_values + (24 + 8) * s.composite_voxels + 4 * s.composite_tangent_values);
  if (s.mixed_points)
    l.emplace_back("mixed_pressure", kMixedBytesPerPoint * s.mixed_points + kMixedSlopeBytesPerPoint * s.mixed_slope_points);
  if (s.mean_dilatation_values) l.emplace_back("mean_dilatation", 8 * s.mean_dilatation_values);
  l.emplace_back("spectral_vectors", s.spectral_vectors * 3 * 16 * s.modes);
  l.emplace_back("last_increment", 3 * 8 * s.modes);  // ũ's last converged increment, complex float
  return l;
}

}  // namespace softhom::rve::detail
