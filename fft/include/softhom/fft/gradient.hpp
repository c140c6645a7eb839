#pragma once
// Discrete gradients on a periodic grid, written in Fourier space, and the operators built on them.
//
// A displacement-fluctuation field u (three components) is represented by its half spectrum û. Every
// discretization here is "Fourier-diagonal": the gradient of u at quadrature point q of the voxel whose
// lower corner is x reads ∇u_q(x) = Σ_k D_q(k) ⊗ û(k) e^{ik·x}, i.e. ∂_j u_i = D_qj(k) û_i(k), with
//
//   spectral : D_j = i ξ_j (trigonometric interpolation; ξ_j = 0 on the Nyquist index of even grids so
//              that the operator maps real fields to real fields), one point per voxel. Gibbs ringing
//              at high contrast.
//   rotated  : linear hexahedron (bilinear quad on a section) with one point at the voxel centre —
//              Willot's rotated finite-difference scheme (Willot 2015). Ringing-free; hourglass modes
//              (checkerboards with zero gradient) are left out of the solution space.
//   hex      : linear hexahedron with 2×2×2 Gauss points (2×2 on a section), as in Leute et al. 2022 /
//              Ladecký et al. 2023. Ringing-free and hourglass-free; nq times the material calls.
//
// For the hexahedron, D_qj(k) = d_j(k_j) Π_{m≠j} v_m(ξ_qm, k_m) with d = (e^{ikh} − 1)/h and
// v(ξ) = (1 − ξ) + ξ e^{ikh}. On a section grid (n3 = 1) k3 = 0, hence D_q3 = 0 for every scheme: the
// fluctuation does not vary along the fiber axis while all nine components of F remain.
//
// Field layouts: a "gradient set" is 9·nq spectra, field index 9 q + 3 i + j; a displacement is three
// spectra (i = 0, 1, 2). Spectra are normalised Fourier coefficients (real field = Σ_k x̂_k e^{ik·x}).
//
// Rotated and hex are exactly local stencils on the nodal displacement (the shifts e^{ik_m h_m}); the
// Newton–Krylov operator of the FFT solver applies them in real space (stencil.hpp, StencilGradient),
// so per Krylov iteration only the 3 displacement fields go back and the 3 nodal forces forward; the
// per-mode gradient()/divergence() below remain for the residual, the spectral scheme and as the
// reference of the stencil form (tests/fft/test_stencil.cpp). On the Nyquist index e^{ikh} is taken as
// exactly −1, so that the rotated scheme's hourglass modes have D = 0 exactly (kernel of the Green
// operator) in both forms.
#include <array>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "softhom/fft/plan.hpp"

namespace softhom::fft {

using Matrix9 = Eigen::Matrix<double, 9, 9>;

enum class Discretization { spectral, rotated, hex };
const char* to_string(Discretization d);
/// "spectral" | "rotated" | "hex"; throws std::invalid_argument otherwise.
Discretization parse_discretization(const std::string& name);

struct QuadraturePoint {
  std::array<double, 3> xi{0.5, 0.5, 0.5};  ///< local coordinates in the voxel, [0, 1]³
  double weight = 1.0;                      ///< fraction of the voxel volume (Σ = 1)
};

class GradientOperator {
 public:
  GradientOperator(const Grid& grid, Discretization discretization);

  const Grid& grid() const { return grid_; }
  Discretization discretization() const { return disc_; }
  int points() const { return int(quadrature_.size()); }
  const std::vector<QuadraturePoint>& quadrature() const { return quadrature_; }

  /// D_qj at one half-spectrum mode, out[3 q + j].
  void coefficients(std::size_t mode, Complex* out) const;
  /// Σ_q w_q |D_q(k)|², the symbol of −Δ for this discretization (0 on the kernel).
  double laplacian(std::size_t mode) const;

  /// Restricts the per-mode passes below (and ReferenceGreen) to the spectrum planes k3 ∈ [begin,
  /// begin + count) of a slab (slab.hpp): their spectra hold local_modes() values per field, local mode k
  /// being the global mode mode_offset() + k (coefficients() and laplacian() take global modes).
  /// Default: the whole spectrum.
  void restrict_to_planes(int begin, int count) {
    k3_begin_ = begin;
    k3_count_ = count;
  }
  std::size_t local_modes() const { return std::size_t(grid_.half_n1()) * grid_.n[1] * std::size_t(k3_count_); }
  std::size_t mode_offset() const { return std::size_t(grid_.half_n1()) * grid_.n[1] * std::size_t(k3_begin_); }

  /// Columns j of the gradient that can be non-zero: 2 on a section grid (D_q3 = 0), else 3.
  int columns() const { return grid_.is_section() ? 2 : 3; }

  /// grad[9q + 3i + j] = D_qj u[i] (all modes, OpenMP over modes). With `all_columns` false the
  /// identically zero columns j ≥ columns() are not written (see BatchedFFT's `columns`).
  void gradient(const Complex* u, Complex* grad, bool all_columns = true) const;
  /// Fused CG direction update and gradient: p ← z + β p (p ← z when β = 0, whatever p held), then
  /// grad = ∇p on the columns j < columns() only. One pass over the spectra.
  void gradient_of_update(const Complex* z, double beta, Complex* p, Complex* grad) const;
  /// out[i] = scale Σ_q w_q Σ_j conj(D_qj) stress[9q + 3i + j] (the adjoint of gradient(); reads the
  /// columns j < columns() only).
  void divergence(const Complex* stress, Complex* out, double scale) const;
  /// divergence() fused with the weighted inner product Σ_k m_k Re(x̄_k · out_k) (m_k: mode_weight),
  /// which it returns.
  double divergence_dot(const Complex* stress, Complex* out, double scale, const Complex* x) const;
  /// One block (point q, row i) of gradient(): out[j] = D_qj u_i for the columns j < columns(), `ui` the
  /// spectrum of one displacement component. With the Krylov operator in stencil form the solver's
  /// evaluation transforms ∇ũ block by block through a 3-field spectrum instead of holding the 9·nq
  /// spectra of a gradient set (BENCHMARKS.md, "FFT memory per voxel").
  void gradient_block(const Complex* ui, int q, Complex* out) const;
  /// One block of divergence(): out_i (+)= scale w_q Σ_j conj(D_qj) stress[j] (j < columns(); `stress`
  /// the spectra of row i of point q's stress). Summed over q (accumulate after the first) and for each
  /// row i it is divergence(), for one point (rotated) to the bit.
  void divergence_block(const Complex* stress, int q, Complex* out_i, double scale, bool accumulate) const;
  /// out = K0(k)⁻¹ r(k) with K0_ik = Σ_q w_q Σ_jl conj(D_qj) C0_(3i+j)(3k+l) D_ql, the stiffness of a
  /// homogeneous reference medium with (major-symmetric, elliptic) tangent C0; 0 on the kernel.
  /// This is the Green operator of the reference problem: the preconditioner of the Newton–Krylov
  /// solver and the update of the Moulinec–Suquet scheme. `r` and `out` may alias.
  void solve_reference(const Matrix9& C0, const Complex* r, Complex* out) const;

 private:
  friend class ReferenceGreen;
  /// Calls body(mode, D, mode_weight) for the modes of this thread's share of the spectrum rows
  /// (an orphaned `omp for`, static schedule: call it inside a parallel region). D is computed per row
  /// from the separable 1D tables, without index divisions.
  template <class Body>
  void for_modes(Body&& body) const;

  Grid grid_;
  Discretization disc_;
  std::vector<QuadraturePoint> quadrature_;
  std::array<int, 3> points_per_dim_{1, 1, 1};
  int k3_begin_ = 0, k3_count_ = 0;  // spectrum planes of the passes (restrict_to_planes; all by default)
  std::array<std::vector<Complex>, 3> deriv_;   ///< d_m(k_m) per dim
  std::array<std::vector<Complex>, 3> value_;   ///< v_m(ξ_p, k_m), index p * n_m + k_m
};

/// The reference-medium Green operator K0(k)⁻¹ of GradientOperator::solve_reference, tabulated per
/// mode for one C0. The preconditioner is applied every Krylov iteration with the same C0, so the 3×3
/// assembly and inversion (≈ 800 flops per mode) are paid once per linear solve instead of once per
/// iteration.
///
/// K0 is Hermitian, and for all three discretizations real symmetric, because M_jl = Σ_q w_q conj(D_qj)
/// D_ql is real. Spectral: D_j = i ξ_j. Rotated and hex: the points are symmetric under the reflection
/// ξ → 1 − ξ through the voxel centre with equal weights (rotated: the centre itself), and since
/// d = e^{ikh} conj(−d) and v(1 − ξ) = e^{ikh} conj(v(ξ)) per direction, the reflected point q' has
/// D_q'j = −e^{i Σ_m k_m h_m} conj(D_qj): its products are the complex conjugates of q's. (A single hex
/// point's products are complex; only the pair sum is real.) The table therefore holds the 6 reals of
/// the symmetric inverse per mode, and applying it is a real matrix times a complex 3-vector.
class ReferenceGreen {
 public:
  explicit ReferenceGreen(const GradientOperator& op);
  /// Reals tabulated per mode: the upper triangle G00 G11 G22 G01 G02 G12 of the real symmetric K0⁻¹.
  static constexpr int kValuesPerMode = 6;
  /// Table in float from the next set() on (half the bytes per mode, and half its stream per Krylov
  /// iteration). A preconditioner only has to be symmetric positive definite: the rounded table is
  /// symmetric by construction, and positive definite while the condition number of K0(k) (≈ (λ0 + 2μ0)/μ0
  /// of the reference medium, ≈ 2e3 for the mean tangent of glass in ecoflex) stays far below the
  /// ≈ 5e6 that entry-wise rounding of 6e-8 can upset; CG then converges to the same solution.
  void use_single_precision(bool single) { single_ = single; }
  /// Tabulates K0⁻¹ for `C0` (major-symmetric, elliptic). Same values as solve_reference().
  void set(const Matrix9& C0);
  /// out = K0⁻¹ r / scale. `r` and `out` may alias.
  void apply(const Complex* r, Complex* out, double scale = 1.0) const;
  /// out = K0⁻¹ r / scale, returns Σ_k m_k Re(r̄_k · out_k). `r` and `out` must not alias.
  double apply_dot(const Complex* r, Complex* out, double scale = 1.0) const;
  /// (`out` / `z` null in apply_dot and cg_update: only the sum, K0⁻¹ r not stored; see direction_update.)
  /// p ← K0⁻¹ r / scale + β p and copy ← p: the CG direction update with z = K0⁻¹ r recomputed from r
  /// instead of stored (the same values as cg_update's z followed by p ← z + βp, bit for bit).
  void direction_update(const Complex* r, double beta, Complex* p, Complex* copy, double scale = 1.0) const;
  /// Fused CG update: x += α p, r −= α ap_scale Ap, z = K0⁻¹ r / scale; returns Σ_k m_k Re(r̄_k · z_k).
  /// (`ap_scale`: Ap may be handed over unnormalised, straight from an FFT buffer.)
  double cg_update(double alpha, const Complex* p, const Complex* Ap, Complex* x, Complex* r, Complex* z,
                   double scale = 1.0, double ap_scale = 1.0) const;
  std::size_t memory_bytes() const { return table_.size() * sizeof(double) + table_f_.size() * sizeof(float); }

  /// The dilatation of a displacement mode under a mean deformation F̄ (one point per voxel: spectral,
  /// rotated): η(k)·û(k) with η(k) = cof F̄ D(k), `cof` = cof F̄ in the grid frame. These two passes let
  /// a preconditioner replace the bulk part of K0⁻¹ by the inverse of a bulk stiffness that varies in
  /// real space (rve/src/fft_local_bulk.hpp).
  /// psi(k) = η·r(k) / |η|², 0 where η = 0 (the mean and the kernel of the gradient).
  void bulk_potential(const Eigen::Matrix3d& cof, const Complex* r, Complex* psi) const;
  /// With ψ(k) recomputed from r: p(k) += conj(η) (s_scale ŝ(k) − w0 ψ(k)) / |η|², and the same to
  /// copy(k) (null: none), where η ≠ 0.
  void add_bulk_correction(const Eigen::Matrix3d& cof, const Complex* r, const Complex* s_hat, double s_scale, double w0,
                           Complex* p, Complex* copy) const;

 private:
  template <class Body>
  void for_bulk_modes(const Eigen::Matrix3d& cof, Body&& body) const;
  template <class F>
  double with_table(F&& f) const {
    return single_ ? f(table_f_.data()) : f(table_.data());
  }
  const GradientOperator& op_;
  // One point per voxel: per direction m and index k, D's factors as d_m = p_m i s_m and v_m = p_m c_m with
  // p_m = e^{i k_m h_m / 2} and s_m, c_m real, so that D(k) = (Π_m p_m) i z(k), z real (the bulk passes).
  std::array<std::vector<Complex>, 3> half_shift_;
  std::array<std::vector<double>, 3> sine_, cosine_;
  bool single_ = false;
  std::vector<double> table_;  ///< per mode: G00 G11 G22 G01 G02 G12
  std::vector<float> table_f_;  ///< the same in float (use_single_precision)
};

}  // namespace softhom::fft
