// The FFT solver's state and the declarations of its parts (private to rve/src). The member functions
// live with the work they do: construction, storage accounting and the public interface in
// fft_solver.cpp; material points, residuals and the streamed evaluation in fft_evaluation.cpp; the
// Newton operator, the preconditioners and the Krylov solves in fft_krylov.cpp; the sub-step Newton
// loop, its failure diagnosis and the fixed-point scheme in fft_newton.cpp; field output in
// fft_fields.cpp. Short per-point helpers stay here, inline, where every part can inline them.
#pragma once

#include "softhom/rve/fft_solver.hpp"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>

#include <Eigen/Dense>

#include "softhom/core/krylov.hpp"
#include "softhom/fft/field_buffer.hpp"
#include "softhom/fft/stencil.hpp"
#include "softhom/materials/interrupt.hpp"
#include "softhom/materials/errors.hpp"
#include "compact_tangents.hpp"
#include "diagnostics.hpp"
#include "fft_distribution.hpp"
#include "fft_mean_dilatation.hpp"
#include "fft_pressure_iteration.hpp"
#include "fft_storage.hpp"
#include "step_driver.hpp"

namespace softhom::rve {

using fft::Complex;

namespace detail {

/// 9×9 operator of X ↦ R X Rᵀ on row-major flattened tensors.
inline Mat9 rotation_operator(const Mat3& R) {
  Mat9 T;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k)
        for (int l = 0; l < 3; ++l) T(3 * i + j, 3 * k + l) = R(i, k) * R(j, l);
  return T;
}

/// Packed upper triangle (45 values, row by row) of the symmetrized 9×9 tangent. The tangent of a
/// hyperelastic law (and its laminate condensation and mixed-pressure correction) is major-symmetric,
/// and CG needs a symmetric operator anyway; packing cuts the tangent stream of every Krylov iteration
/// from 648 to 360 bytes per point.
inline void pack_symmetric(const Mat9& A, double* S) {
  int idx = 0;
  for (int a = 0; a < 9; ++a) {
    S[idx++] = A(a, a);
    for (int b = a + 1; b < 9; ++b) S[idx++] = 0.5 * (A(a, b) + A(b, a));
  }
}

/// y = S x for a packed symmetric S (pack_symmetric).
inline void symmetric_product(const double* __restrict S, const double* __restrict x, double* __restrict y) {
  double out[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
  int idx = 0;
  for (int a = 0; a < 9; ++a) {
    double acc = S[idx++] * x[a];
    for (int b = a + 1; b < 9; ++b, ++idx) {
      acc += S[idx] * x[b];
      out[b] += S[idx] * x[a];
    }
    out[a] += acc;
  }
  for (int a = 0; a < 9; ++a) y[a] = out[a];
}

/// Running sums of one evaluation pass (per thread, then reduced): the phase sums of both engines, the
/// volume means of P and of the tangent, and the tangent's mean over each phase's pure voxels.
struct PassSums : PhaseSums {
  Vec9 P = Vec9::Zero();
  Mat9 A = Mat9::Zero();
  Mat9 phase_A[2] = {Mat9::Zero(), Mat9::Zero()};  // Σ w A over the pure voxels of each phase
  double phase_A_w[2] = {0.0, 0.0};
  void add(const PassSums& o) {
    add_phases(o);
    P += o.P;
    A += o.A;
    for (int x = 0; x < 2; ++x) {
      phase_A[x] += o.phase_A[x];
      phase_A_w[x] += o.phase_A_w[x];
    }
  }
};

/// A Krylov vector: fluctuation spectrum (3 fields) and the free macro components (load frame).
struct KVec {
  std::vector<Complex> u;
  Vec9 f = Vec9::Zero();
};

}  // namespace detail

struct FftRveSolver::Impl {
  using Clock = std::chrono::steady_clock;
  using KVec = detail::KVec;
  using PassSums = detail::PassSums;
  static constexpr double kPhaseEps = 1e-12;  // fractions closer than this to 0/1 are pure voxels

  FftSolverOptions opt;
  fft::Grid grid;
  fft::GradientOperator op;
  fft::ReferenceGreen green{op};  // K0⁻¹ tabulated per mode for the current C0 (set_reference())
  // Distributed solve (fft_distribution.hpp): this rank's slab; null on one process. N, NM, NP are then
  // the local voxels, modes and points (voxel v is the global voxel v0 + v), Ntot the global voxels.
  std::unique_ptr<fft::SlabDecomposition> dist;
  int nq;
  std::size_t N, NM, NP;
  std::size_t Ntot = 0, v0 = 0;
  std::unique_ptr<fft::FieldTransform> fft;
  // Stencil form of the Krylov operator (KrylovOperator::stencil, rotated/hex): the real-space
  // gradient/adjoint and a 3-field transform for the displacement and the nodal forces. The stencil
  // pass keeps its per-voxel values in fft's real buffer (free during a linear solve).
  std::unique_ptr<fft::StencilGradient> stencil;
  std::unique_ptr<fft::FieldTransform> fft3;
  // Streamed evaluation (streams_evaluation()): the residual pass, the Krylov operator and the
  // pointwise passes run through StencilGradient::streamed_pass()/gradient_pass() on fft3's real
  // buffer; fft is not allocated (no 9-field buffer). stream_scratch: the passes' slice stores.
  bool streamed = false;
  std::vector<double> stream_scratch;
  Mat3 R;            // grid axes in the load frame
  Mat9 T_load;       // X_grid ↦ X_load
  Vec3 a0_load;      // fiber axis in the load frame
  MaterialPtr mat[2];  // grid frame: 0 matrix, 1 fiber
  int state_size[2] = {0, 0};
  double G_min = 1.0, G_max = 1.0, K_max = 1.0, lambda_ref = 1.0, mu_ref = 1.0;

  // Phase of each voxel in 4 bytes: kMatrixVoxel, kFiberVoxel, or the index of a composite voxel, whose
  // fiber fraction and interface normal are kept per composite voxel (a few percent of the grid) only.
  static constexpr int kMatrixVoxel = -1, kFiberVoxel = -2;
  std::vector<int> comp_id;         // per voxel
  std::vector<double> comp_phi;     // fiber fraction per composite voxel
  std::vector<Vec3> comp_normal;    // per composite voxel (grid frame)
  std::vector<double> lam_a, lam_a_trial;     // laminate jump vector per composite point (3 each)
  std::vector<double> hist_old[2], hist_new[2];
  std::vector<double> tangent;      // packed symmetric tangent per material point p = v nq + q (45 each)
  std::vector<float> tangent_f;     // the same in float (stencil operator, TangentPrecision::single_precision)
  std::unique_ptr<detail::CompactTangents> compact;  // instead of tangent_f where the laws allow (compact_tangents.hpp)
  double krylov_seconds = 0.0;      // time in the linear solves (operator, preconditioner, vector ops)
  KVec cg_r, cg_z, cg_p, cg_Ap;     // CG work vectors, kept between solves (no allocation per solve)
  std::vector<float> jacobi_s;      // Preconditioner::jacobi_green: the real-space scaling S (3 per node)
  // Preconditioner::green_local_bulk (fft_local_bulk.hpp): the weight w = J̄/(k(x) + 4μ0/3) per voxel,
  // its sum, w0 of the homogeneous medium, cof F̄ (grid frame) of the last reference, and a one-field
  // transform for ψ → w (ψ + c), whose spectrum holds ŵψ from a CG update to the next direction.
  bool local_bulk = false;
  std::unique_ptr<fft::FieldTransform> bulk_fft;
  std::vector<float> bulk_w;
  double bulk_w_sum = 0.0, bulk_w0 = 0.0;
  Mat3 bulk_cof = Mat3::Identity();
  // VolumetricKinematics::mean_dilatation: points evaluated at F̄_q, `tangent` holds K_q, the voxel
  // coupling of the Newton operator lives here (fft_mean_dilatation.hpp).
  bool mean_dilatation = false;
  detail::MeanDilatationCoupling md_coupling;
  // Mixed (u, p) Newton iteration of the nearly incompressible phases (fft_pressure_iteration.hpp).
  detail::PressureIteration pressures;
  double achieved_vf = 0.0;

  // Unknowns (current and committed).
  std::vector<Complex> u, u_committed;
  Mat3 Fbar = Mat3::Identity(), Fbar_committed = Mat3::Identity();  // load frame

  // Scratch.
  PassSums sums;
  // Last converged increment (extrapolation predictor) in float: it only places the first iterate of
  // the next step, which Newton corrects (6e-8 relative of the increment), at half the storage.
  std::vector<std::complex<float>> du_last;
  Mat3 dF_last = Mat3::Zero();
  double dt_last = 0.0;
  bool extrapolate = true;
  double merit = 0.0;  // absolute residual norm of the last residual_norm() call (line search)
  // Mixed iteration: the absolute norm of the last evaluation's true residual (Div P_full), where
  // `merit` is that of Div P̂ (evaluate_residual()).
  double true_merit = 0.0;
  Mat9 C0 = Mat9::Identity();
  // Medium of the Levenberg–Marquardt / continuation shift (see shift_medium()), and the shift the
  // Green table is tabulated for (K0 of C0 + green_shift · C_shift).
  Mat9 C_shift = Mat9::Identity();
  double green_shift = 0.0;

  Impl(const PhaseImage& image, MaterialPtr matrix, MaterialPtr fiber, double angle, const Mat3& frame,
       const FftSolverOptions& o);
  // The constructor's steps, in its order.
  /// The grid frame, the fiber axis, both materials in the grid frame and the moduli they give.
  void set_up_phases(const PhaseImage& image, const MaterialPtr& matrix, const MaterialPtr& fiber, double angle,
                     const Mat3& frame);
  /// Mean dilatation, the automatic preconditioner's choice, the local bulk and the mixed phases.
  void choose_formulation();
  /// The checked fiber fractions of this rank's voxels: pure and composite voxels, their normals.
  void read_fractions(const PhaseImage& image);
  void allocate_history();
  /// The FFT plans and buffers of the chosen operator (9-field buffer or streamed stencil passes).
  void create_transforms();
  /// Tangents, pressures, ũ and the CG work vectors (so that memory_bytes() is what a run holds).
  void allocate_solver_storage();

  /// VolumetricKinematics::mean_dilatation needs several points per voxel (hex) and the stencil
  /// operator of the Newton–CG scheme (its batches hold whole voxels, where the voxel coupling is added).
  static bool check_mean_dilatation(const FftSolverOptions& o, const fft::GradientOperator& op);

  /// Preconditioner::automatic: the local bulk where it applies and the bulk moduli spread much further
  /// than the shear moduli (the spread it takes out against the one it leaves), else green.
  static Preconditioner automatic_preconditioner(const FftSolverOptions& o, const fft::GradientOperator& op, double G0,
                                                 double G1, double K0, double K1);
  /// Preconditioner::green_local_bulk needs one point per voxel and the stencil operator of the
  /// Newton–CG scheme (its fused CG passes carry the correction).
  static bool check_local_bulk(const FftSolverOptions& o, const fft::GradientOperator& op);

  /// Fiber fraction of local voxel v (0 or 1 for pure voxels).
  double fraction(std::size_t v) const {
    const int c = comp_id[v];
    return c >= 0 ? comp_phi[std::size_t(c)] : c == kFiberVoxel ? 1.0 : 0.0;
  }
  detail::FractionOf local_fraction() const {
    return [this](std::size_t v) { return fraction(v); };
  }
  /// Phase of pure voxel v (0 matrix, 1 fiber).
  int pure_phase(std::size_t v) const { return comp_id[v] == kFiberVoxel ? 1 : 0; }
  /// F = F̄ + ∇ũ at point q of voxel v, ∇ũ in fft's real buffer (the columns j ≥ op.columns() of a section are 0).
  Mat3 point_F(const Mat3& Fbar_grid, std::size_t v, int q) const {
    const double* base = fft->real(9 * q) + v;
    const int ncol = op.columns();
    Mat3 F;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) F(i, j) = Fbar_grid(i, j) + (j < ncol ? base[std::size_t(3 * i + j) * N] : 0.0);
    return F;
  }
  /// The streamed evaluation (no 9-field buffer, fft::StencilGradient::streamed_pass) applies to the
  /// default solve of elastic phases, on one process or on slabs: the stencil operator (decided by the caller) with
  /// one point per voxel (rotated), a Green preconditioner (Jacobi–Green reads per-voxel values), no
  /// history (the field output re-evaluates the laws at the converged F, which a history-dependent law
  /// cannot repeat) and slices of whole batches of 8 voxels (section rows n1, planes n1·n2).
  bool streams_evaluation() const;
  /// The streamed passes' scratch for the team of the next parallel region.
  void ensure_stream_scratch() {
    const std::size_t need = stencil->stream_scratch_values(omp_get_max_threads());
    if (stream_scratch.size() < need) stream_scratch.resize(need);
  }
  /// The one-process 3-field transform works in place unless the jacobi-green preconditioner reads its
  /// real fields voxel by voxel (dense).
  bool fft3_in_place() const { return !dist && opt.preconditioner != Preconditioner::jacobi_green; }

  /// "[n1, n2]" (sections) or "[n1, n2, n3]", as the scene writes the grid.
  static std::string grid_text(const std::array<int, 3>& n) {
    return "[" + std::to_string(n[0]) + ", " + std::to_string(n[1]) + (n[2] > 1 ? ", " + std::to_string(n[2]) : "") + "]";
  }

  /// Storage of the solver as allocated (memory_breakdown()): sizes counted from the arrays. The
  /// step's residual and Newton step (locals of step()), ũ's last increment (allocated at the first
  /// commit) and the Green table (at the first solve) are counted as they will exist during a run.
  detail::StorageSizes storage_sizes() const;
  /// 3-component half spectra (double): ũ, committed ũ, the step's residual (which is also CG's r) and
  /// Newton step, and the CG work vectors (p, and z and Ap unless the stencil operator: z recomputed, Ap
  /// in fft3's buffer; Jacobi–Green: r, z, p of its own); the fixed point keeps ũ, its copy, the residual
  /// and the update. (+ ũ's last increment in float.)
  static std::size_t spectral_vectors(bool newton, bool with_stencil, bool jacobi) {
    if (!newton) return 4;
    return 4 + (with_stencil ? (jacobi ? 3 : 1) : 3);
  }
  std::size_t spectral_vectors() const {
    return spectral_vectors(opt.scheme == FftScheme::newton_cg, bool(stencil), jacobi_green());
  }
  /// The same sizes planned from the problem size before anything is allocated (composite voxels
  /// counted as none: their arrays are small).
  detail::StorageSizes planned_sizes() const;
  /// Bytes the solver will allocate for this grid and these options (planned_sizes()), saturating for
  /// absurd grids (they must still be refused).
  std::size_t planned_bytes() const;

  /// Compact tangents (FftSolverOptions::compact_tangent) when both phases' laws have them, the
  /// preconditioner does not read the stored tangents (jacobi_green) and the stored tangent is the law's
  /// (with mean dilatation it is K_q of the voxel's energy, not a law's linearization). With
  /// single-precision stencil tangents.
  bool compact_tangents_apply() const;
  /// Compact record of pure point p of phase x at F (after its evaluation and PressureIteration::correct()):
  /// the mixed iteration's q ∂cof/∂F, q = p − W_V′(J) (correct()'s value), is part of the tangent.
  void store_compact(int x, std::size_t p, const Mat3& F, double q);

  Mat3 to_grid(const Mat3& X_load) const { return R.transpose() * X_load * R; }
  Mat3 to_load(const Mat3& X_grid) const { return R * X_grid * R.transpose(); }

  // ---------------------------------------------------------------------------------------------
  // Material points.

  /// Laminate rule for a composite point (laminate.hpp). `a` (in/out) is the jump vector, warm-started.
  MaterialStatus laminate(const Mat3& F, double f, const Vec3& n, Vec3& a, std::size_t p, double dt, Mat3& P,
                          Mat9* A, Mat3 Px[2], Mat3 Fx[2]) const;

  /// A composite point's tangent for FftSolverOptions::composite_tangent = projected: left as it is when
  /// its symmetric part is positive definite (a Cholesky test, no eigen-decomposition), else that
  /// symmetric part with its negative eigenvalues set to 0. Applied where the point is evaluated, so the
  /// stored tangent and the mean tangent that chooses the reference medium are the same projected one.
  static void project_semidefinite(Mat9& A);
  /// Puts back the linearization of the last accepted iterate (ũ, F̄ in the grid frame) after a rejected
  /// line-search trial overwrote it (all or, after a material failure, part of it): recomputed at every
  /// pure point of a mixed phase as PressureIteration::correct() computed it there, not stored a second
  /// time (44 B per point).
  void relinearize_pressures(const Mat3& Fbar_grid);

  /// Packed symmetric tangent of point p into `tangent` (layout: see the constructor).
  void store_tangent(std::size_t p, const Mat9& A);

  /// Point q of voxel v at F: its phase's law (with the mixed iteration's pressure) or the laminate /
  /// Voigt rule of a composite voxel. P, the tangent into *A when asked (not stored), the phase sums and
  /// margins into `local`. Shared by the evaluation passes (stored gradient or streamed).
  MaterialStatus evaluate_point(std::size_t v, int q, const Mat3& F, double dt, Mat3& P, Mat9* A, PassSums& local);

  /// Evaluates every material point at F = F̄ + ∇ũ (gradient already in fft->real), writes P into the
  /// real buffer in place, stores tangents when asked; fills `sums`. Returns the first failure.
  MaterialStatus evaluate_points(const Mat3& Fbar_grid, double dt, bool with_tangent);

  /// F_q = F̄ + ∇ũ_q of voxel v (gradient in fft->real) into `md`, and its J̄, α_q; false if inverted.
  bool prepare_mean_dilatation(std::size_t v, const Mat3& Fbar_grid, detail::MeanDilatationVoxel& md) const;
  /// The laws' P̄_q, A_q (in out.P, out.K) at F̄_q of voxel v → the stresses of the discrete energy
  /// into the real buffer, K_q into the tangent store and the voxel coupling (fft_mean_dilatation.hpp).
  void finish_mean_dilatation(std::size_t v, const detail::MeanDilatationVoxel& md, detail::MeanDilatationResponse& out,
                              bool with_tangent, PassSums& local);

  /// ∇ũ into the real buffer. Stencil operator: block (q, i) by block through fft3 (fft has no spectrum).
  void gradient_to_real(const std::vector<Complex>& uh);
  /// Real field `field` of grid transform t (dense or padded rows, FieldTransform::real_row_pitch()) to
  /// and from a dense voxel field.
  void copy_from_real(fft::FieldTransform& t, int field, double* to) const;
  void copy_to_real(const double* from, fft::FieldTransform& t, int field) const;
  /// Three component spectra (3·NM) to real space; returns the transform holding them and the field
  /// step between the components (fft: fields 0, 3, 6, which are transformed for any number of columns;
  /// fft3: 0, 1, 2).
  std::pair<fft::FieldTransform*, int> vector_to_real(const std::vector<Complex>& uh);

  /// Residual of the current state: r_u = Dᴴ P̂ and the macro stress error. Expects P in the real
  /// buffer (after evaluate_points).
  void residual(const std::array<bool, 9>& free, const Vec9& P_target, KVec& r);

  /// Residual of the evaluated iterate: `r` is the true residual (Div P_full: right-hand side and
  /// convergence test), the return value its relative norm; `merit` is set from Div P̂ (line search).
  /// Leaves P_full in the real buffer and its mean in sums.P.
  double evaluate_residual(const std::array<bool, 9>& free, const Vec9& P_target, KVec& r);
  // ---------------------------------------------------------------------------------------------
  // Streamed evaluation (streams_evaluation()): ∇ũ, the laws and the nodal forces in one real-space
  // pass over fft3's buffer (fft::StencilGradient::streamed_pass), no 9-field buffer. The same
  // iterates as the stored path to round-off (the divergence summed in another order).

  /// ũ's real nodal displacement into fft3's real buffer (in place of its spectrum; on a slab with its
  /// upper halo plane).
  void displacement_to_real(const std::vector<Complex>& uh);
  /// The streamed passes' hand-over of the last plane's stresses to the next slab (only called on a slab).
  auto slab_shift_up() const {
    return [this](const double* send, double* recv, std::size_t values) { dist->shift_up(send, recv, values); };
  }
  /// F = F̄ + ∇ũ of lane l of a stencil batch (its columns j ≥ dims are 0).
  static Mat3 lane_F(const Mat3& Fbar_grid, const double* grad, int l) {
    constexpr int B = fft::StencilGradient::kBatch;
    Mat3 F;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) F(i, j) = Fbar_grid(i, j) + grad[(3 * i + j) * B + l];
    return F;
  }
  /// Σ_k m_k |a_k − b_scale b_k|² / |ξ_k|² over the three components (this rank's modes; b null: 0).
  double spectral_norm2(const Complex* a, const Complex* b, double b_scale) const;
  /// The macro part of the residual from sums.P: the stress error on the free components.
  void macro_residual(const std::array<bool, 9>& free, const Vec9& P_target, KVec& r) const {
    const Vec9 Pl = T_load * sums.P;
    for (int c = 0; c < 9; ++c) r.f[c] = free[c] ? Pl[c] - P_target[c] : 0.0;
  }

  /// evaluate_points() + evaluate_residual() in one streamed pass: every point at F = F̄ + ∇ũ, its
  /// tangent stored when asked, the sums, and r = Dᴴ P_full with its relative norm in `err`; the merit
  /// (line search) of P̂ = P_full − (P_full − P̂) from one more divergence-only pass of the mixed
  /// correction (which the stored path gets from its second divergence of the 9 fields).
  MaterialStatus evaluate_streamed(const Mat3& Fbar_grid, double dt, bool with_tangent, const std::array<bool, 9>& free,
                                   const Vec9& P_target, KVec& r, double& err);
  /// The residual after evaluate_streamed()'s pass (fft3 holds P_full): r = Dᴴ P_full and its relative
  /// norm; with the mixed correction (volume mean `correction` of P_full − P̂) also the merit of P̂.
  void streamed_residual(const std::array<bool, 9>& free, const Vec9& P_target, const Vec9& correction, KVec& r,
                         double& err);

  /// The undeformed state's points (phase sums, reference medium; tangents for Newton). Streamed: with
  /// its residual in a CG work vector, which the first solve overwrites.
  MaterialStatus evaluate_start();

  /// The iterate (ũ, F̄) evaluated: its points (tangents stored when asked) and, when they all succeed,
  /// the residual r and its relative norm `err` (merit set). Streamed or through the 9-field buffer.
  MaterialStatus evaluate_iterate(double dt, bool with_tangent, const std::array<bool, 9>& free, const Vec9& P_target,
                                  KVec& r, double& err);

  /// Stress scale of the relative residual: the macro stress on prescribed-F components and the
  /// stress targets (not the free components, whose error is part of the residual), floored.
  double stress_scale(const std::array<bool, 9>& free, const Vec9& P_target) const;

  /// Relative residual norm (see FftSolverOptions::tolerance).
  double residual_norm(const KVec& r, const std::array<bool, 9>& free, const Vec9& P_target);

  // ---------------------------------------------------------------------------------------------
  // Distribution (fft_distribution.hpp): no-ops on one process.

  double global_sum(double local) const { return dist ? dist->sum(local) : local; }
  /// A stop request (signal), the same answer on every rank.
  bool stop_now() const { return dist ? dist->max(stop_requested() ? 1 : 0) != 0 : stop_requested(); }
  /// The per-voxel values of the stencil passes: fft's real buffer, after one lower halo plane on a slab.
  double* stencil_store() { return fft->real(0) + stencil->halo_store_values(); }
  void fill_displacement_halo() {
    if (dist) dist->fill_upper_halo(fft3->real(0), fft3->real_stride(), 3);
  }
  void fill_store_halo() {
    if (dist) dist->fill_lower_halo(stencil_store(), stencil->halo_store_values());
  }

  // ---------------------------------------------------------------------------------------------
  // Krylov pieces.

  static void axpy(double alpha, const KVec& x, KVec& y);

  /// δP = (A + shift C_shift)(δF̄ + ∇δũ) at every point, in place in the real buffer (which holds ∇δũ on
  /// the transformed columns); returns the volume mean of δP (grid frame). The one pass over the
  /// stored tangents of a Krylov iteration: fused, no allocation, static schedule (the same voxel
  /// partition as evaluate_points(), which writes the tangents, so each thread reads what it wrote).
  Vec9 tangent_product(const Vec9& dFbar, double shift);

  /// Stencil form of tangent_product() and the adjoint: the nodal displacement δũ in fft3's real buffer
  /// (with its halo) becomes the nodal forces f = Bᵀ (A + shift C_shift) (δF̄ + B δũ) there, and ⟨δũ, f⟩ (this
  /// rank's sum) goes to *dot when given. Streamed: one pass (StencilGradient::streamed_pass); else the
  /// gradient pass keeps its per-voxel values in fft's real buffer for the gather pass. Returns the
  /// volume mean of δP (grid frame).
  /// δP = A : δF of the stored tangents of the batch of points p0 … p0 + count − 1 (dF, dP [9][8] as in
  /// fft::StencilGradient::gradient_pass): compact records, with the composite points' full tangents, or
  /// the packed 9×9 tangents in float or double.
  void tangent_product_batch(std::size_t p0, int count, const double* dF, double* dP) const;
  Vec9 stencil_tangent_product(const Vec9& dFbar, double shift, double* dot = nullptr);

  /// y = K x with the stored tangents; x.f holds load-frame macro components (any mask applied by caller).
  void apply(const KVec& x, const std::array<bool, 9>& free, KVec& y, double shift = 0.0);

  /// The CG direction update fused with the operator: p ← z + β p, Ap = K p; returns ⟨p, Ap⟩.
  /// With the stencil operator Ap.u is not written: the unnormalised spectrum N·Ap.u is left in fft3's
  /// spectrum buffer, which the CG update reads with the factor 1/N (no extra pass). ⟨p, Ap⟩ is then
  /// taken on the real fields, which equals the half-spectrum sum because the CG vectors are spectra of
  /// real fields (b comes from r2c transforms, and D, K0⁻¹ map k and −k to complex conjugates).
  /// `r_for_z` (stencil operator): z.u is not stored, p ← K0⁻¹ r + βp from the residual.
  double apply_direction(const KVec& z, double beta, KVec& p, const std::array<bool, 9>& free, KVec& Ap,
                         double shift, const KVec* r_for_z = nullptr);

  /// Macro block of the preconditioner: z_f = Minv r_f on the free components.
  static void precondition_macro(const Vec9& rf, const Eigen::MatrixXd& macro_inverse, const std::vector<int>& free_idx,
                                 Vec9& zf);

  /// z = M⁻¹ r: reference-medium Green operator per mode (tabulated by set_reference()), macro block inverse.
  void precondition(const KVec& r, const Eigen::MatrixXd& macro_inverse, const std::vector<int>& free_idx, KVec& z) {
    green.apply(r.u.data(), z.u.data());
    precondition_macro(r.f, macro_inverse, free_idx, z.f);
  }

  /// Indices of the stress-controlled (free) macro components.
  static std::vector<int> free_indices(const std::array<bool, 9>& free);

  /// Inverse of the free-free block of the (shifted) reference medium C0 + shift · C_shift, load frame.
  Eigen::MatrixXd macro_block_inverse(const std::vector<int>& free_idx, double shift = 0.0) const;

  /// Chooses the reference medium C0 for the next linear solve(s) and tabulates its Green operator.
  /// `shift_without_bulk`: the Levenberg–Marquardt shift of the next solves is that of
  /// shift_medium(C0), else of C0.
  void set_reference(bool shift_without_bulk = false);
  /// The Green table for the medium C0 + shift · C_shift (re-tabulated only when the shift changes).
  void tabulate_green(double shift);
  /// The medium of the Levenberg–Marquardt shift: C0 with its largest stiffness brought down to the
  /// next one. With a nearly incompressible phase C0's largest eigenvalue is the bulk stiffness (K/G up
  /// to 1.2e5) and its eigenvector the dilatation; negative curvature of the tangent (a pressure p times
  /// ∂cof/∂F, far from equilibrium) lives in isochoric modes, at the shear stiffness. A shift of the
  /// whole C0 would also damp the dilatation, which the Newton step must correct (a linear step leaves
  /// J − 1 = O(∇u²), a pressure spike K (J − 1)): with shift 10 the iteration then removes the spike
  /// about 15 % per step. Without the bulk stiffness the shifted step corrects J − 1 at once.
  static Mat9 shift_medium(const Mat9& C);
  /// Preconditioner::green_local_bulk (fft_local_bulk.hpp): C0 (chosen as usual) becomes the isotropic
  /// medium (k0, μ0) of its projection, pulled back at F̄; the weights w(x) come from the stored tangents.
  void set_local_bulk_reference();
  /// The local-bulk part of z = M⁻¹ r for CG's r (spectral): ψ = η·r/|η|² to real space, θ = w (ψ + c)
  /// with c = −Σ wψ / Σ w, and back into bulk_fft's spectrum (unnormalised, read by the next direction's
  /// add_bulk_correction()). Returns ⟨r, z_bulk⟩ = (Σ ψθ − w0 Σ ψ²)/N (Parseval, global).
  double local_bulk_prepare(const Complex* r);
  /// The correction applies to unshifted solves only (the Green table is that of C0 itself).
  bool local_bulk_in(double shift) const { return local_bulk && shift == 0.0; }

  bool jacobi_green() const {
    return opt.preconditioner == Preconditioner::jacobi_green && stencil && opt.scheme == FftScheme::newton_cg;
  }
  void choose_reference();

  /// The Krylov spaces of the Newton system for krylov::pcg and krylov::pminres (fft_krylov.cpp).
  struct CgSpace;
  struct MinresSpace;

  krylov::Controls krylov_controls(double rel_tol) const;

  /// PCG on K x = b (x starts at zero); returns iterations. With `shift` > 0 it solves
  /// (K + shift K_S) x = b, K_S the operator of the medium C_shift (a Levenberg–Marquardt step, used
  /// when K is indefinite away from the solution), preconditioned by the Green operator of
  /// C0 + shift C_shift. Sets `breakdown` when a direction of non-positive
  /// curvature stops it.
  /// `residual`: CG's r (b may be the same vector, which the solve then overwrites; recover_rhs() gets it
  /// back); null: the member work vector.
  int pcg(const KVec& b, const std::array<bool, 9>& free, double rel_tol, KVec& x, double shift, bool& breakdown,
          KVec* residual = nullptr);

  /// The right-hand side b back from the residual r = b − (K + shift K_S) x that a solve left in b's
  /// storage (one operator application; exact up to the recurrence's round-off, for a retry).
  void recover_rhs(KVec& b, const KVec& x, const std::array<bool, 9>& free, double shift);

  /// Σ_k m_k Re(āᵤ · bᵤ) + a_f · b_f: the inner product of the Krylov space (half spectrum, mode weights).
  double dot(const KVec& a, const KVec& b) const;
  /// y ← α x + β y (both parts).
  static void axpby(double alpha, const KVec& x, double beta, KVec& y);

  /// Preconditioned MINRES on K x = b with the SPD preconditioner of pcg() (reference Green operator +
  /// macro block). Used where CG meets negative curvature: past a bifurcation of the cell (fiber
  /// micro-buckling in compression) the tangent at the equilibrium is indefinite, and a
  /// Levenberg–Marquardt shift then stalls Newton just above the tolerance, while MINRES returns the
  /// Newton step itself. Returns iterations, `converged` false when it did not reach rel_tol.
  int pminres(const KVec& b, const std::array<bool, 9>& free, double rel_tol, KVec& x, bool& converged);

  // ---------------------------------------------------------------------------------------------
  // Failure diagnosis.

  /// The hot spots of the current iterate (ũ, F̄ and the laminate vectors as they are now; see
  /// diagnostics.hpp): the matrix side of every non-fiber point, then the nodal forces of `r`.
  /// Destroys the real buffer.
  detail::HotSpots hot_spots(const KVec& r);
  // Distributed: collective, the fractions of the named voxels come from the ranks that own them.
  std::string voxel_name(std::size_t v) const;
  std::string describe(const detail::HotSpots& h) const;

  // ---------------------------------------------------------------------------------------------
  // One (sub)step from the committed state to t_new.

  using StepOutcome = detail::SubstepOutcome;

  static StepOutcome& fatal(StepOutcome& out, std::string why);
  /// A converged sub-step: ok unless a phase is at its material limit there (fatal).
  StepOutcome& converged(StepOutcome& out) const;

  /// Back to the line search's last accepted iterate ũ − applied · Δũ, F̄_prev (no copy of ũ is kept):
  /// applied = 0.
  void move_to_accepted(const KVec& dx, double& applied, const Mat3& Fbar_prev);

  /// The working state of one Newton sub-step (step()): what is prescribed, the iteration's mode, and
  /// the line search's last accepted iterate ũ − applied · Δũ, F̄_prev (no copy of ũ is kept).
  struct NewtonState {
    std::array<bool, 9> free{};
    Vec9 P_target = Vec9::Zero();
    Mat3 target;  // prescribed components at t_new
    double t_new = 0.0, dt = 0.0;
    KVec r, dx;   // residual (then right-hand side) and Newton step
    int max_it = 0;
    double err = 0.0, first_err = -1.0;
    // Pseudo-transient continuation (FftSolverOptions::max_continuation_iterations), entered when
    // Newton stagnates: shift δ of the reference medium, residual of the previous iterate.
    bool continuation = false;
    // MINRES for negative curvature near the solution: always (indefinite_solver = minres), or once the
    // shifted iteration has stalled (minres_fallback).
    bool minres_mode = false;
    double ptc_shift = 0.0, ptc_err = 0.0;
    double applied = 0.0;
    Mat3 Fbar_prev, step_macro = Mat3::Zero();
    bool had_prescribed_step = false;
    double lm_shift = 0.0;
    bool full_first_step = false;
    bool extrapolated = false;  // the step starts from the extrapolated predictor (else the tangent predictor)
  };

  StepOutcome step(const MixedControl& control, double t_new, double dt);
  /// Iteration 0: the extrapolated predictor, else the tangent predictor's state, evaluated; false
  /// (out.why set) when the material fails there.
  bool evaluate_predictor(NewtonState& s, StepOutcome& out);
  /// Iterations after the first: the backtracking line search along the last Newton step; false (out.why
  /// set, with the diagnosis at the last accepted iterate) when it fails.
  bool search_line(NewtonState& s, StepOutcome& out);
  /// F̄_target − F̄ on the prescribed components (zero on the free ones).
  Mat3 prescribed_gap(const NewtonState& s) const;
  /// The continuation's shift after an iterate, or its start when Newton stagnates.
  void follow_continuation(NewtonState& s, int it, bool prescribed_reached, StepOutcome& out) const;
  /// At the last allowed iteration: false when the loop ends, true when the MINRES fallback extends it.
  bool extend_with_minres(NewtonState& s, int it, bool prescribed_reached, StepOutcome& out) const;
  /// The Newton system's right-hand side −r − K [0; ΔF_p] in r's storage.
  void form_newton_rhs(NewtonState& s, const Mat3& dFp, bool prescribed_reached, StepOutcome& out);
  /// Solves for the Newton step dx (CG, shifted on breakdowns, MINRES on negative curvature) and
  /// records it as the line search's next direction.
  void solve_newton_step(NewtonState& s, int it, const Mat3& dFp, bool prescribed_reached, StepOutcome& out);

  /// Basic Moulinec–Suquet scheme: ũ ← ũ − K0⁻¹ Dᴴ P, F̄_free ← F̄_free − C0_ff⁻¹ (⟨P⟩ − P*).
  StepOutcome fixed_point(const std::array<bool, 9>& free, const Vec9& P_target, const Mat3& target, double dt,
                          KVec& r);

  void commit(double dt);
  std::vector<double> slab_node_displacement(fft::FieldTransform& t, int step, const Mat3& G) {
    return detail::slab_node_displacement(*dist, t, step, grid, G);
  }

  void restore();

  RveStep record(double t, double angle0) const {
    return detail::record_step(t, angle0, Fbar, unflatten(T_load * sums.P), sums,
                               [this](const Mat3& A) { return to_load(A); }, a0_load);
  }

  /// F, P, σ and the von Mises stress of voxel v into the fields (load frame).
  static void put_voxel_fields(RveFields& f, std::size_t v, const Mat3& Fm, const Mat3& Pm, const Mat3& Sm);
  /// P of the last evaluation at voxel v (one point, elastic phases: the streamed evaluation), computed
  /// again at its F: the law, or the laminate from its converged jump vector; at pure points of a mixed
  /// phase plus the residual's P_full − P_law = ratio (slope − W_V″ cof F), from the evaluation's
  /// linearization (PressureIteration::correct(), evaluate_residual()).
  Mat3 evaluated_stress(std::size_t v, const Mat3& F) const;

  /// Fields of the converged state (P still in the real buffer, ũ current). Destroys the buffer.
  RveFields fields();

  /// Displacement u = (F̄_grid − I) y + ũ(y) at the (n1+1)(n2+1)(n3+1) voxel corners y (grid frame,
  /// y1 fastest; the corners of the last layer repeat ũ of the first, periodic, with the macro part
  /// continued). ũ at the corners is the c2r transform of its spectrum (rotated/hex: the nodal
  /// displacement of the discretization; spectral: the trigonometric interpolant). Uses fft's buffers.
  std::vector<double> node_displacement();
};

}  // namespace softhom::rve
