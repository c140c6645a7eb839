#pragma once
// Regular periodic grids and their real-to-complex (half) spectra.
//
// Real fields are stored with y1 fastest: index i1 + n1 * (i2 + n2 * i3) (the PhaseImage order). The
// half spectrum of FFTW's r2c transform keeps k1 = 0 … n1/2 along the fastest axis:
// index k1 + m1 * (k2 + n2 * k3) with m1 = n1/2 + 1. A grid with n3 = 1 is a cross-section: fields do
// not vary along y3 (k3 = 0 only), but they keep all nine components (full 3D kinematics).
#include <array>
#include <cstddef>

namespace softhom::fft {

struct Grid {
  std::array<int, 3> n{1, 1, 1};
  std::array<double, 3> size{1.0, 1.0, 1.0};  ///< cell lengths L1, L2, L3

  std::size_t voxels() const { return std::size_t(n[0]) * n[1] * n[2]; }
  /// Modes of the r2c half spectrum.
  std::size_t modes() const { return std::size_t(n[0] / 2 + 1) * n[1] * n[2]; }
  int half_n1() const { return n[0] / 2 + 1; }
  double spacing(int dim) const { return size[dim] / n[dim]; }
  bool is_section() const { return n[2] == 1; }

  /// Signed integer frequency of index m along `dim` (m ≤ n/2 → m, else m − n).
  int frequency(int dim, int m) const { return (dim == 0 || 2 * m <= n[dim]) ? m : m - n[dim]; }
  /// True for the Nyquist index of an even dimension (its mode has no sign).
  bool is_nyquist(int dim, int m) const { return n[dim] % 2 == 0 && 2 * m == n[dim] && n[dim] > 1; }

  /// Multiplicity of a half-spectrum mode in the full spectrum: 1 on the k1 = 0 and k1 = n1/2 (even
  /// n1) planes, 2 elsewhere. Σ_full |x̂|² = Σ_half weight · |x̂|² for the spectrum of a real field.
  double mode_weight(std::size_t mode) const {
    const int k1 = int(mode % std::size_t(half_n1()));
    return (k1 == 0 || (n[0] % 2 == 0 && 2 * k1 == n[0])) ? 1.0 : 2.0;
  }
  /// Splits a half-spectrum index into (k1, k2, k3) array indices.
  std::array<int, 3> mode_index(std::size_t mode) const {
    const std::size_t m1 = std::size_t(half_n1());
    return {int(mode % m1), int((mode / m1) % std::size_t(n[1])), int(mode / (m1 * std::size_t(n[1])))};
  }
};

}  // namespace softhom::fft
