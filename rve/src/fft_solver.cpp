// Newton–Krylov and Moulinec–Suquet FFT solvers for periodic fiber cells (see fft_solver.hpp).
#include "softhom/rve/fft_solver.hpp"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <sstream>
#include <stdexcept>

#include <Eigen/Dense>

#include "softhom/fe/krylov.hpp"
#include "softhom/fe/line_search.hpp"
#include "softhom/fft/field_buffer.hpp"
#include "softhom/fft/stencil.hpp"
#include "softhom/materials/interrupt.hpp"
#include "softhom/materials/errors.hpp"
#include "compact_tangents.hpp"
#include "diagnostics.hpp"
#include "fft_distribution.hpp"
#include "fft_mean_dilatation.hpp"
#include "fft_local_bulk.hpp"
#include "fft_preconditioner.hpp"
#include "fft_storage.hpp"
#include "laminate.hpp"
#include "memory_budget.hpp"
#include "step_driver.hpp"

namespace softhom::rve {

using fft::Complex;

const char* to_string(FftScheme s) { return s == FftScheme::newton_cg ? "newton-cg" : "moulinec-suquet"; }
const char* to_string(ReferenceMedium r) {
  return r == ReferenceMedium::mean_tangent ? "mean-tangent" : r == ReferenceMedium::geometric ? "geometric" : "isotropic";
}
const char* to_string(KrylovOperator k) { return k == KrylovOperator::stencil ? "stencil" : "fourier"; }
const char* to_string(TangentPrecision t) { return t == TangentPrecision::single_precision ? "single" : "double"; }
const char* to_string(Preconditioner p) {
  return p == Preconditioner::jacobi_green       ? "jacobi-green"
         : p == Preconditioner::green_local_bulk ? "green-local-bulk"
         : p == Preconditioner::automatic        ? "auto"
                                                 : "green";
}
const char* to_string(VolumetricKinematics v) {
  return v == VolumetricKinematics::mean_dilatation ? "mean-dilatation" : "pointwise";
}

Mat3 grid_rotation(double fiber_angle_deg) {
  const double a = fiber_angle_deg * 3.14159265358979323846 / 180.0;
  Mat3 R;
  R.col(0) = Vec3(std::cos(a), -std::sin(a), 0.0);
  R.col(2) = Vec3(std::sin(a), std::cos(a), 0.0);
  R.col(1) = R.col(2).cross(R.col(0));
  return R;
}

namespace {

using Clock = std::chrono::steady_clock;
constexpr double kPhaseEps = 1e-12;  // fractions closer than this to 0/1 are pure voxels

/// 9×9 operator of X ↦ R X Rᵀ on row-major flattened tensors.
Mat9 rotation_operator(const Mat3& R) {
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

/// Running sums of one evaluation pass (per thread, then reduced).
struct PassSums {
  Vec9 P = Vec9::Zero();
  Mat9 A = Mat9::Zero();
  Mat9 phase_A[2] = {Mat9::Zero(), Mat9::Zero()};  // Σ w A over the pure voxels of each phase
  double phase_A_w[2] = {0.0, 0.0};
  // per phase (0 matrix, 1 fiber): Σ w P, Σ w F, Σ w P Fᵀ (= J σ), Σ w J, Σ w
  Mat3 phase_P[2] = {Mat3::Zero(), Mat3::Zero()};
  Mat3 phase_F[2] = {Mat3::Zero(), Mat3::Zero()};
  Mat3 phase_PFt[2] = {Mat3::Zero(), Mat3::Zero()};
  double phase_J[2] = {0.0, 0.0};
  double phase_w[2] = {0.0, 0.0};
  // Smallest Material::limit_margin of each phase over its points (composite points: its laminate
  // side) and the voxel where it is; checked on converged states (a phase at its limit is fatal).
  double margin[2] = {1.0, 1.0};
  std::size_t v_margin[2] = {0, 0};
  void see_margin(int x, double m, std::size_t v) {
    if (m < margin[x]) {
      margin[x] = m;
      v_margin[x] = v;
    }
  }
  void add(const PassSums& o) {
    P += o.P;
    for (int x = 0; x < 2; ++x) see_margin(x, o.margin[x], o.v_margin[x]);
    A += o.A;
    for (int x = 0; x < 2; ++x) {
      phase_A[x] += o.phase_A[x];
      phase_A_w[x] += o.phase_A_w[x];
    }
    for (int x = 0; x < 2; ++x) {
      phase_P[x] += o.phase_P[x];
      phase_F[x] += o.phase_F[x];
      phase_PFt[x] += o.phase_PFt[x];
      phase_J[x] += o.phase_J[x];
      phase_w[x] += o.phase_w[x];
    }
  }
};

/// A Krylov vector: fluctuation spectrum (3 fields) and the free macro components (load frame).
struct KVec {
  std::vector<Complex> u;
  Vec9 f = Vec9::Zero();
};

}  // namespace

struct FftRveSolver::Impl {
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
  // Mixed (pressure) Newton iteration for nearly incompressible phases (see pressure_correction()).
  bool mixed[2] = {false, false};
  double K_vol[2] = {0.0, 0.0};
  bool mixed_active = false;                       // any phase mixed
  bool linearized_pressure = false;                // evaluate with p from the last linearization
  double predictor_ratio = -1.0;                   // ≥ 0: predictor, p = p_committed + ratio · dp_last
  // Per point pressures of the mixed iteration: of the last evaluation, and the committed one with its
  // last increment, which only place the extrapolated predictor (float). The evaluation's pressure is
  // read only to commit it (in float) and to diagnose a failure; its deviation q = p − W_V′(J) in the
  // tangent is passed on in double (store_compact()), so float loses nothing the iteration uses.
  std::vector<float> p_trial, p_committed, dp_last;
  std::optional<FftRveSolver::MixedPressures> pending_pressures;  // set_mixed_pressures(): for the next run's start
  // One linearization per point, p(F) = s + c:F with c = W_V″(J_k) cof F_k (see pressure_slope()) and
  // s (double) taken with that c, so that p(F_k) = W_V′(J_k) to double round-off and only the slope is
  // perturbed (≈ 6e-8 relative). pressure_correction() reads it at point p and overwrites it there with
  // the linearization at the evaluated F, so it holds that of the last evaluation: of the last accepted
  // iterate once the line search has accepted its trial (the accepted trial is the last one evaluated),
  // and relinearize_pressures() puts back the accepted one before a trial follows a rejected one (or a
  // material failure that stopped a pass half way). The slopes c: from the F of the compact tangent
  // record (float F, written at every evaluation: 36 B per point less), else stored (lin_c, 9 floats).
  std::vector<float> lin_c;
  std::vector<double> lin_s;
  // Per point: P_full − P̂ = −(p − W_V′(J)) cof F, a correction of the residual, is parallel to the slope
  // c of the same evaluation: stored as the factor (1 float instead of 9).
  std::vector<float> dP_ratio;
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
       const FftSolverOptions& o)
      : opt(o),
        grid{image.n, image.size},
        op(grid, o.discretization),
        dist(detail::make_slabs(grid, o.distributed, grid_text(image.n))),
        nq(op.points()),
        N(dist ? dist->local_voxels() : grid.voxels()),
        NM(dist ? dist->local_modes() : grid.modes()),
        NP(N * std::size_t(op.points())) {
    Ntot = grid.voxels();
    if (dist) {
      op.restrict_to_planes(dist->slab().begin, dist->slab().count);
      v0 = dist->voxel_offset();
    }
    R = grid_rotation(angle);
    T_load = rotation_operator(R);
    detail::check_slab_image(image, dist.get());
    // y3 unless the image gives per-voxel directions (a slab image: the orientation sums of all slabs)
    Eigen::Matrix3d orientation = image.owned_orientation_sum();
    if (dist && image.is_slab()) dist->sum(orientation.data(), 9);
    a0_load = R * principal_fiber_axis(orientation);
    // global → load: frameᵀ; load → grid: Rᵀ.
    const Mat3 Q = R.transpose() * frame.transpose();
    mat[0] = MaterialPtr(matrix->rotated(Q));
    mat[1] = MaterialPtr(fiber->rotated(Q));
    for (int x = 0; x < 2; ++x) state_size[x] = mat[x]->state_size();
    const double G0 = mat[0]->initial_shear_modulus(), G1 = mat[1]->initial_shear_modulus();
    const double K0 = mat[0]->initial_bulk_modulus(), K1 = mat[1]->initial_bulk_modulus();
    G_min = std::min(G0, G1);
    G_max = std::max(G0, G1);
    K_max = std::max(K0, K1);
    // Moulinec–Suquet reference: arithmetic mean of the extreme Lamé moduli (the classic choice).
    mu_ref = 0.5 * (G0 + G1);
    lambda_ref = 0.5 * ((K0 - 2.0 / 3.0 * G0) + (K1 - 2.0 / 3.0 * G1));

    mean_dilatation = check_mean_dilatation(opt, op);
    if (opt.preconditioner == Preconditioner::automatic) opt.preconditioner = automatic_preconditioner(opt, op, G0, G1, K0, K1);
    local_bulk = check_local_bulk(opt, op);
    for (int x = 0; x < 2; ++x) {
      K_vol[x] = mat[x]->volumetric_modulus();
      const double G = mat[x]->initial_shear_modulus();
      mixed[x] = opt.scheme == FftScheme::newton_cg && opt.mixed_pressure && K_vol[x] > 0.0 &&
                 K_vol[x] >= opt.mixed_pressure_ratio * G;
      mixed_active = mixed_active || mixed[x];
    }
    // Refuse a grid that cannot fit before anything of its size is allocated.
    detail::refuse_if_too_big(planned_bytes(), "microstructure.grid", grid_text(grid.n));
    if (image.fiber_fraction.size() != image.held_voxels())
      throw InputError("microstructure", "", "phase image has " + std::to_string(image.fiber_fraction.size()) +
                                                 " values for " + std::to_string(image.held_voxels()) + " voxels");
    // Every rank checks the image it holds (whole or its slab); the first bad value of any rank is the
    // InputError on every rank. Each keeps the fractions of its planes.
    std::optional<double> bad;
    for (double f : image.fiber_fraction)
      if (!(f >= 0.0 && f <= 1.0) && !bad) bad = f;
    if (dist && image.is_slab()) bad = detail::first_bad_fraction(*dist, bad);
    if (bad) throw InputError("microstructure", std::to_string(*bad), "fiber fraction outside [0, 1]");
    const std::size_t first = image.is_slab() ? image.owned_offset() : v0;  // this rank's voxel v0 in the arrays
    comp_id.assign(N, kMatrixVoxel);
    double vf = 0.0;
    for (std::size_t v = 0; v < N; ++v) {
      double f = image.fiber_fraction[first + v];
      if (f < kPhaseEps) f = 0.0;
      if (f > 1.0 - kPhaseEps) f = 1.0;
      vf += f;
      if (f == 1.0) comp_id[v] = kFiberVoxel;
      if (f > 0.0 && f < 1.0) {
        comp_id[v] = int(comp_normal.size());
        comp_phi.push_back(f);
        Vec3 n = image.normal.size() == image.held_voxels() ? image.normal[first + v] : Vec3::Zero();
        if (!(n.norm() > 0.5)) n = detail::estimate_interface_normal(image, v0 + v);
        comp_normal.push_back(n.norm() > 0.0 ? Vec3(n.normalized()) : Vec3::Zero());
      }
    }
    if (dist) vf = dist->sum(vf);
    achieved_vf = vf / double(Ntot);
    lam_a.assign(comp_normal.size() * nq * 3, 0.0);
    lam_a_trial = lam_a;
    for (int x = 0; x < 2; ++x)
      if (state_size[x] > 0) {
        hist_old[x].assign(NP * state_size[x], 0.0);
        for (std::size_t p = 0; p < NP; ++p) mat[x]->init_state(hist_old[x].data() + p * state_size[x]);
        hist_new[x] = hist_old[x];
      }
    if (mixed_active) {
      lin_s.assign(NP, 0.0);
      p_trial.assign(NP, 0.0f);
      p_committed.assign(NP, 0.0f);
      dp_last.assign(NP, 0.0f);
      dP_ratio.assign(NP, 0.0f);
    }
    // Section grids: the i3 columns of ∇ũ vanish and Div does not read them, so 6 of 9 fields per point
    // are transformed (the voxel loops treat those columns as zero).
    const bool with_stencil = opt.scheme == FftScheme::newton_cg && opt.krylov_operator == KrylovOperator::stencil &&
                              fft::StencilGradient::supported(op);
    // With the stencil operator ∇ũ and P stay in real space (transformed block by block through fft3,
    // gradient_to_real() and residual()): no spectrum of the 9·nq fields. Distributed: room for the
    // stencil store's lower halo plane after the fields (see stencil_store()).
    streamed = with_stencil && streams_evaluation();
    if (streamed)
      ;  // no 9-field buffer: ∇ũ and P live only inside the streamed passes
    else if (with_stencil)
      fft = std::make_unique<fft::FieldBuffer>(9 * nq, N, dist ? 24 * dist->plane_voxels() : 0);
    else if (dist)
      fft = std::make_unique<fft::SlabFFT>(*dist, 9 * nq, opt.plan, op.columns());
    else
      fft = std::make_unique<fft::BatchedFFT>(grid, 9 * nq, opt.plan, op.columns());
    if (with_stencil) {
      stencil = std::make_unique<fft::StencilGradient>(op);
      // Its per-voxel values (≤ 24) live in fft's real buffer (9·nq per voxel), unused during a solve.
      if (!streamed && stencil->stored_values() > 9 * nq) throw std::logic_error("stencil values do not fit the FFT buffer");
      if (dist) {
        stencil->restrict_to_slab(dist->slab().count);
        fft3 = std::make_unique<fft::SlabFFT>(*dist, 3, opt.plan, 3, 1);  // + the displacement's upper halo
        if (local_bulk) bulk_fft = std::make_unique<fft::SlabFFT>(*dist, 1, opt.plan);
      } else {
        // In place (the real fields in the spectrum buffer, rows padded): −24 B per voxel.
        fft3 = std::make_unique<fft::BatchedFFT>(grid, 3, opt.plan, 3, fft3_in_place());
        if (fft3->padded_rows()) stencil->set_padded_fields(fft3->real_row_pitch(), fft3->real_stride());
        if (local_bulk) bulk_fft = std::make_unique<fft::BatchedFFT>(grid, 1, opt.plan, 3, true);
      }
    }
    // Stencil operator: tangents in blocks of 8 points (structure of arrays, fft::symmetric_product_batch()),
    // zero-padded to whole blocks; Fourier operator: per point.
    // Single precision (stencil only): tangent_f instead of tangent.
    if (opt.scheme == FftScheme::newton_cg) {
      if (stencil && opt.tangent_precision == TangentPrecision::single_precision) {
        if (compact_tangents_apply())
          compact = std::make_unique<detail::CompactTangents>(NP, comp_normal.size() * std::size_t(nq));
        else
          tangent_f.assign(45 * ((NP + 7) / 8 * 8), 0.0f);
        green.use_single_precision(true);  // the preconditioner's table too (fft::ReferenceGreen)
      } else {
        tangent.assign(45 * (stencil ? (NP + 7) / 8 * 8 : NP), 0.0);
      }
    }
    // The pressure slopes are stored unless the compact records hold the F they follow from.
    if (mixed_active && !compact) lin_c.assign(9 * NP, 0.0f);
    if (mean_dilatation) md_coupling.resize(N, nq);
    if (local_bulk) bulk_w.assign(N, 0.0f);
    if (streamed) ensure_stream_scratch();
    u.assign(3 * NM, 0.0);
    u_committed = u;
    if (opt.scheme == FftScheme::newton_cg) {
      // CG work vectors once, here (pcg() reuses them), so that memory_bytes() is what a run holds.
      // Stencil operator: no z (CgSpace recomputes K0⁻¹ r in the direction update) and no Ap (fft3's buffer).
      // No CG residual of its own (the step's residual is the right-hand side and becomes CG's r, see
      // pcg()) except for the Jacobi–Green CG on nodal vectors.
      cg_p.u.assign(3 * NM, 0.0);
      if (jacobi_green()) cg_r.u.assign(3 * NM, 0.0);
      if (!stencil) cg_z.u.assign(3 * NM, 0.0);
      if (!stencil) cg_Ap.u.assign(3 * NM, 0.0);
    }
  }

  /// VolumetricKinematics::mean_dilatation needs several points per voxel (hex) and the stencil
  /// operator of the Newton–CG scheme (its batches hold whole voxels, where the voxel coupling is added).
  static bool check_mean_dilatation(const FftSolverOptions& o, const fft::GradientOperator& op) {
    if (o.volumetric != VolumetricKinematics::mean_dilatation) return false;
    const char* v = to_string(o.volumetric);
    if (o.discretization != fft::Discretization::hex)
      throw InputError("solver.volumetric", v, "needs discretization = \"hex\" (got \"" + std::string(fft::to_string(o.discretization)) + "\")");
    if (o.scheme != FftScheme::newton_cg) throw InputError("solver.volumetric", v, "needs scheme = \"newton-cg\"");
    if (o.krylov_operator != KrylovOperator::stencil || !fft::StencilGradient::supported(op))
      throw InputError("solver.volumetric", v, "needs krylov_operator = \"stencil\" (and a grid with n1, n2 > 1)");
    return true;
  }

  /// Preconditioner::automatic: the local bulk where it applies and the bulk moduli spread much further
  /// than the shear moduli (the spread it takes out against the one it leaves), else green.
  static Preconditioner automatic_preconditioner(const FftSolverOptions& o, const fft::GradientOperator& op, double G0,
                                                 double G1, double K0, double K1) {
    const bool applies = o.discretization == fft::Discretization::rotated && o.scheme == FftScheme::newton_cg &&
                         o.krylov_operator == KrylovOperator::stencil && fft::StencilGradient::supported(op);
    if (!applies || !(std::min(G0, G1) > 0.0) || !(std::min(K0, K1) > 0.0)) return Preconditioner::green;
    const double bulk_spread = std::max(K0, K1) / std::min(K0, K1), shear_spread = std::max(G0, G1) / std::min(G0, G1);
    return bulk_spread >= kLocalBulkSpreadRatio * shear_spread ? Preconditioner::green_local_bulk : Preconditioner::green;
  }
  /// Preconditioner::green_local_bulk needs one point per voxel and the stencil operator of the
  /// Newton–CG scheme (its fused CG passes carry the correction).
  static bool check_local_bulk(const FftSolverOptions& o, const fft::GradientOperator& op) {
    if (o.preconditioner != Preconditioner::green_local_bulk) return false;
    const char* v = to_string(o.preconditioner);
    if (o.discretization != fft::Discretization::rotated)
      throw InputError("solver.preconditioner", v, "needs discretization = \"rotated\" (one point per voxel; got \"" +
                                                       std::string(fft::to_string(o.discretization)) + "\")");
    if (o.scheme != FftScheme::newton_cg) throw InputError("solver.preconditioner", v, "needs scheme = \"newton-cg\"");
    if (o.krylov_operator != KrylovOperator::stencil || !fft::StencilGradient::supported(op))
      throw InputError("solver.preconditioner", v, "needs krylov_operator = \"stencil\" (and a grid with n1, n2 > 1)");
    return true;
  }

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
  bool streams_evaluation() const {
    return opt.stream_evaluation && nq == 1 && !mean_dilatation &&
           opt.preconditioner != Preconditioner::jacobi_green && state_size[0] == 0 && state_size[1] == 0 &&
           fft::StencilGradient::streams(op);
  }
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
  detail::StorageSizes storage_sizes() const {
    detail::StorageSizes s;
    s.voxels = N;
    s.modes = NM;
    s.points = NP;
    s.fft_fields = fft ? std::size_t(fft->fields()) : 0;
    s.fft_spectra = fft && fft->transformed_fields() ? s.fft_fields : 0;
    s.stream_scratch_values = stream_scratch.size();
    s.fft3_fields = fft3 ? std::size_t(fft3->fields()) : 0;
    s.fft3_in_place = fft3 && fft3->padded_rows();
    const bool single = !tangent_f.empty() || compact;
    s.tangent_values = tangent_f.empty() ? tangent.size() : tangent_f.size();
    s.tangent_value_bytes = single ? sizeof(float) : sizeof(double);
    s.compact_values = compact ? compact->record_values() : 0;
    s.composite_tangent_values = compact ? compact->full_values() : 0;
    s.green_values = fft::ReferenceGreen::kValuesPerMode * NM;  // tabulated at the first solve
    s.green_value_bytes = single ? sizeof(float) : sizeof(double);
    s.jacobi_values = jacobi_green() ? 3 * N : 0;  // set with the reference medium
    s.local_bulk_voxels = bulk_w.size();
    s.local_bulk_in_place = bulk_fft && bulk_fft->padded_rows();
    s.history_values = hist_old[0].size() + hist_old[1].size();
    s.laminate_values = lam_a.size();
    s.composite_voxels = comp_normal.size();
    s.mixed_points = p_trial.size();
    s.mixed_slope_points = lin_c.size() / 9;
    s.mean_dilatation_values = md_coupling.memory_bytes() / sizeof(double);
    s.spectral_vectors = spectral_vectors();
    return s;
  }
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
  detail::StorageSizes planned_sizes() const {
    const bool newton = opt.scheme == FftScheme::newton_cg;
    const bool with_stencil = newton && opt.krylov_operator == KrylovOperator::stencil && fft::StencilGradient::supported(op);
    detail::StorageSizes s;
    s.voxels = N;
    s.modes = NM;
    s.points = NP;
    const bool streams = with_stencil && streams_evaluation();
    s.fft_fields = streams ? 0 : std::size_t(9 * nq);
    s.fft_spectra = with_stencil ? 0 : s.fft_fields;
    s.stream_scratch_values = streams ? fft::StencilGradient::stream_scratch_values(grid, omp_get_max_threads(), bool(dist)) : 0;
    s.fft3_fields = with_stencil ? 3 : 0;
    s.fft3_in_place = with_stencil && fft3_in_place();
    const bool single = with_stencil && opt.tangent_precision == TangentPrecision::single_precision;
    s.tangent_values = newton ? 45 * (with_stencil ? (NP + 7) / 8 * 8 : NP) : 0;
    if (single && compact_tangents_apply()) {  // composite points' full tangents: counted as none
      s.tangent_values = 0;
      s.compact_values = std::size_t(kCompactValues) * ((NP + 7) / 8 * 8);
    }
    s.tangent_value_bytes = single ? sizeof(float) : sizeof(double);
    s.green_values = fft::ReferenceGreen::kValuesPerMode * NM;
    s.green_value_bytes = single ? sizeof(float) : sizeof(double);
    s.jacobi_values = with_stencil && opt.preconditioner == Preconditioner::jacobi_green ? 3 * N : 0;
    s.local_bulk_voxels = local_bulk ? N : 0;
    s.local_bulk_in_place = local_bulk && !dist;
    s.history_values = NP * std::size_t(state_size[0] + state_size[1]);
    s.mixed_points = mixed_active ? NP : 0;
    s.mixed_slope_points = mixed_active && !(single && compact_tangents_apply()) ? NP : 0;
    s.mean_dilatation_values = opt.volumetric == VolumetricKinematics::mean_dilatation ? 18 * NP + N : 0;
    s.spectral_vectors = spectral_vectors(newton, with_stencil, with_stencil && opt.preconditioner == Preconditioner::jacobi_green);
    return s;
  }
  /// Bytes the solver will allocate for this grid and these options (planned_sizes()), saturating for
  /// absurd grids (they must still be refused).
  std::size_t planned_bytes() const {
    if (double(N) * 1e4 * double(nq) >= double(std::numeric_limits<std::size_t>::max()))
      return std::numeric_limits<std::size_t>::max();
    return detail::storage_total(detail::storage_list(planned_sizes()));
  }

  /// Compact tangents (FftSolverOptions::compact_tangent) when both phases' laws have them, the
  /// preconditioner does not read the stored tangents (jacobi_green) and the stored tangent is the law's
  /// (with mean dilatation it is K_q of the voxel's energy, not a law's linearization). With
  /// single-precision stencil tangents.
  bool compact_tangents_apply() const {
    return opt.compact_tangent && opt.preconditioner != Preconditioner::jacobi_green &&
           opt.volumetric != VolumetricKinematics::mean_dilatation &&
           mat[0]->has_compact_linearization() && mat[1]->has_compact_linearization();
  }
  /// Compact record of pure point p of phase x at F (after its evaluation and pressure_correction()): the
  /// mixed iteration's q ∂cof/∂F, q = p − W_V′(J) (pressure_correction()'s value), is part of the tangent.
  void store_compact(int x, std::size_t p, const Mat3& F, double q) {
    CompactLinearization L;
    mat[x]->compact_linearization(F, L);
    if (mixed[x]) add_pressure_stiffness(L, q, F.determinant());
    compact->store(p, F, L);
  }

  Mat3 to_grid(const Mat3& X_load) const { return R.transpose() * X_load * R; }
  Mat3 to_load(const Mat3& X_grid) const { return R * X_grid * R.transpose(); }

  // ---------------------------------------------------------------------------------------------
  // Material points.

  /// Laminate rule for a composite point (laminate.hpp). `a` (in/out) is the jump vector, warm-started.
  MaterialStatus laminate(const Mat3& F, double f, const Vec3& n, Vec3& a, std::size_t p, double dt, Mat3& P,
                          Mat9* A, Mat3 Px[2], Mat3 Fx[2]) const {
    detail::LaminatePoint pt;
    for (int x = 0; x < 2; ++x) {
      pt.phase[x] = mat[x].get();
      pt.state_old[x] = state_size[x] ? hist_old[x].data() + p * state_size[x] : nullptr;
      pt.state_new[x] = state_size[x] ? const_cast<double*>(hist_new[x].data()) + p * state_size[x] : nullptr;
    }
    pt.K_max = K_max;
    return detail::laminate_point(pt, F, f, n, a, dt, P, A, Px, Fx);
  }

  /// Mixed (u, p) Newton iteration at a pure point of a nearly incompressible phase x. The law's
  /// volumetric stress W_V′(J) cof F is replaced by p cof F, with p the pressure of the last accepted
  /// iterate F_k advanced by the linearized constraint:
  ///   p(F) = W_V′(J_k) + W_V″(J_k) cof F_k : (F − F_k)  (stored as p = s + c:F).
  /// Condensing δp of the mixed Newton system gives the tangent A + (p − W_V′(J)) ∂cof/∂F (symmetric)
  /// and the right-hand side −Div P_full, P_full the unmodified stress; the merit of the line search is
  /// Div P̂ with the stress P̂ returned here. A finite rotation θ then no longer produces a K θ² pressure
  /// spike that stalls the line search (K/G = 1.2e5 for ecoflex). At convergence p = W_V′(J), P̂ = P_full.
  /// Returns q = p − W_V′(J).
  double pressure_correction(int x, std::size_t p, const Mat3& F, Mat3& P, Mat9* A) {
    const VolumetricState vs = volumetric_state(K_vol[x], F);
    const Mat3& cof = vs.cof;
    const double J = vs.J;
    double pr = vs.dU;
    if (predictor_ratio >= 0.0) {
      // Extrapolated predictor: the pressure is extrapolated itself. A linearly extrapolated F leaves
      // the curved J = 1 manifold by O(ΔF²), which W_V′(J) or any linearization turns into K ΔF²
      // (tens of MPa against a matrix G of 0.017 MPa); the pressure history is smooth instead.
      pr = double(p_committed[p]) + predictor_ratio * double(dp_last[p]);
    } else if (linearized_pressure) {
      const Mat3 c = pressure_slope(x, p);  // of the last accepted iterate (read before it is overwritten)
      pr = lin_s[p];
      for (int k = 0; k < 9; ++k) pr += c(k / 3, k % 3) * F(k / 3, k % 3);
    }
    const double q = pr - vs.dU;
    p_trial[p] = float(pr);
    linearize_pressure(x, p, F, vs);
    dP_ratio[p] = float(-q / vs.ddU);
    if (q == 0.0) return q;
    P += q * cof;
    if (A) add_cofactor_derivative(q / J, cof, *A);
    return q;
  }
  /// A composite point's tangent for FftSolverOptions::composite_tangent = projected: left as it is when
  /// its symmetric part is positive definite (a Cholesky test, no eigen-decomposition), else that
  /// symmetric part with its negative eigenvalues set to 0. Applied where the point is evaluated, so the
  /// stored tangent and the mean tangent that chooses the reference medium are the same projected one.
  static void project_semidefinite(Mat9& A) {
    const Mat9 S = 0.5 * (A + A.transpose());
    if (Eigen::LLT<Mat9>(S).info() == Eigen::Success) return;
    Eigen::SelfAdjointEigenSolver<Mat9> es(S);
    const Vec9 e = es.eigenvalues().cwiseMax(0.0);
    A = es.eigenvectors() * e.asDiagonal() * es.eigenvectors().transpose();
  }
  /// A += w J ∂cof F/∂F, from ∂cof_iJ/∂F_kL = (cof_iJ cof_kL − cof_iL cof_kJ) / J.
  static void add_cofactor_derivative(double w, const Mat3& cof, Mat9& A) {
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        for (int k = 0; k < 3; ++k)
          for (int l = 0; l < 3; ++l) A(3 * i + j, 3 * k + l) += w * (cof(i, j) * cof(k, l) - cof(i, l) * cof(k, j));
  }
  /// J, cof F, W_V′(J) and W_V″(J) of the volumetric energy W_V = K/2 ((J² − 1)/2 − ln J) at F.
  struct VolumetricState {
    double J, dU, ddU;
    Mat3 cof;
  };
  static VolumetricState volumetric_state(double K, const Mat3& F) {
    VolumetricState s;
    s.J = F.determinant();
    s.cof = s.J * F.inverse().transpose();
    s.dU = volumetric_dU(K, s.J);
    s.ddU = volumetric_ddU(K, s.J);
    return s;
  }
  static double volumetric_dU(double K, double J) { return 0.5 * K * (J - 1.0 / J); }
  static double volumetric_ddU(double K, double J) { return 0.5 * K * (1.0 + 1.0 / (J * J)); }
  /// The slope c of the linearization held at pure point p of mixed phase x (that of the last
  /// evaluation at p, see lin_s): stored (lin_c), or W_V″(J) cof F recomputed from the float F of the
  /// compact record, which is what linearize_pressure() took it from.
  Mat3 pressure_slope(int x, std::size_t p) const {
    Mat3 c;
    if (compact) {
      const VolumetricState vs = volumetric_state(K_vol[x], compact->F(p));
      c = vs.ddU * vs.cof;
    } else {
      const float* l = &lin_c[9 * p];
      for (int k = 0; k < 9; ++k) c(k / 3, k % 3) = double(l[k]);
    }
    return c;
  }
  /// The linearization p(F') = s + c:F' at F (volumetric state vs) into point p: c rounded to float (the
  /// stored slope, or the compact record's F it is recomputed from), s with that c, so that
  /// p(F) = W_V′(J) to double round-off.
  void linearize_pressure(int x, std::size_t p, const Mat3& F, const VolumetricState& vs) {
    Mat3 c;
    if (compact) {
      compact->store_F(p, F);  // store_compact() writes it again with the tangent
      c = pressure_slope(x, p);
    } else {
      float* l = &lin_c[9 * p];
      for (int k = 0; k < 9; ++k) {
        l[k] = float(vs.ddU * vs.cof(k / 3, k % 3));
        c(k / 3, k % 3) = double(l[k]);
      }
    }
    double s0 = vs.dU;
    for (int k = 0; k < 9; ++k) s0 -= c(k / 3, k % 3) * F(k / 3, k % 3);
    lin_s[p] = s0;
  }
  /// Puts back the linearization of the last accepted iterate (ũ, F̄ in the grid frame) after a rejected
  /// line-search trial overwrote it (all or, after a material failure, part of it): recomputed at every
  /// pure point of a mixed phase as pressure_correction() computed it there, not stored a second time
  /// (44 B per point).
  void relinearize_pressures(const Mat3& Fbar_grid) {
    if (streamed) {
      displacement_to_real(u);
#pragma omp parallel
      stencil->gradient_pass(fft3->real(0), nullptr, [&](std::size_t p0, int count, const double* grad, double*) {
        for (int l = 0; l < count; ++l) {
          const std::size_t v = p0 + std::size_t(l);
          if (comp_id[v] >= 0 || !mixed[pure_phase(v)]) continue;
          const int x = pure_phase(v);
          const Mat3 F = lane_F(Fbar_grid, grad, l);
          linearize_pressure(x, v, F, volumetric_state(K_vol[x], F));
        }
      });
      return;
    }
    gradient_to_real(u);
    if (mean_dilatation) {
#pragma omp parallel for schedule(static)
      for (std::size_t v = 0; v < N; ++v) {
        if (comp_id[v] >= 0 || !mixed[pure_phase(v)]) continue;
        detail::MeanDilatationVoxel md;
        if (!prepare_mean_dilatation(v, Fbar_grid, md)) continue;
        Mat3 cof[detail::MeanDilatationVoxel::kMaxPoints];
        voxel_cofactors(md, cof);
        linearize_voxel_pressure(pure_phase(v), v, md, cof);
      }
      return;
    }
#pragma omp parallel for schedule(static)
    for (std::size_t v = 0; v < N; ++v) {
      if (comp_id[v] >= 0) continue;
      const int x = pure_phase(v);
      if (!mixed[x]) continue;
      for (int q = 0; q < nq; ++q) {
        const Mat3 F = point_F(Fbar_grid, v, q);
        linearize_pressure(x, v * nq + q, F, volumetric_state(K_vol[x], F));
      }
    }
  }

  /// Packed symmetric tangent of point p into `tangent` (layout: see the constructor).
  void store_tangent(std::size_t p, const Mat9& A) {
    if (compact) {  // pure points: store_compact()
      if (comp_id[p / nq] >= 0) compact->store_full(std::size_t(comp_id[p / nq]) * nq + p % nq, A);
      return;
    }
    if (!stencil) return pack_symmetric(A, &tangent[45 * p]);
    double S[45];
    pack_symmetric(A, S);
    if (!tangent_f.empty()) {
      float* block = &tangent_f[45 * (p - p % 8)] + p % 8;
      for (int idx = 0; idx < 45; ++idx) block[8 * idx] = float(S[idx]);
      return;
    }
    double* block = &tangent[45 * (p - p % 8)] + p % 8;
    for (int idx = 0; idx < 45; ++idx) block[8 * idx] = S[idx];
  }

  /// Point q of voxel v at F: its phase's law (with the mixed iteration's pressure) or the laminate /
  /// Voigt rule of a composite voxel. P, the tangent into *A when asked (not stored), the phase sums and
  /// margins into `local`. Shared by the evaluation passes (stored gradient or streamed).
  MaterialStatus evaluate_point(std::size_t v, int q, const Mat3& F, double dt, Mat3& P, Mat9* A, PassSums& local) {
    const double invN = 1.0 / double(Ntot);
    const std::size_t p = v * nq + q;
    Mat3 Px[2], Fx[2];
    MaterialStatus s;
    const double f = fraction(v);
    const double w = op.quadrature()[q].weight * invN;
    if (comp_id[v] < 0) {
      const int x = pure_phase(v);
      s = mat[x]->evaluate(F, state_size[x] ? hist_old[x].data() + p * state_size[x] : nullptr,
                           state_size[x] ? hist_new[x].data() + p * state_size[x] : nullptr, dt, P, A);
      double q_p = 0.0;
      // Mean dilatation: one pressure per voxel, voxel_pressure_correction() once its points are evaluated.
      if (s == MaterialStatus::ok && mixed[x] && !mean_dilatation) q_p = pressure_correction(x, p, F, P, A);
      if (s == MaterialStatus::ok && A && compact) store_compact(x, p, F, q_p);
      if (s == MaterialStatus::ok && A && opt.reference == ReferenceMedium::geometric) {
        local.phase_A[x] += w * (*A);
        local.phase_A_w[x] += w;
      }
      if (s == MaterialStatus::ok) {
        local.phase_P[x] += w * P;
        local.phase_F[x] += w * F;
        local.phase_PFt[x] += w * P * F.transpose();
        local.phase_J[x] += w * F.determinant();
        local.phase_w[x] += w;
        local.see_margin(x, mat[x]->limit_margin(F), v0 + v);
      }
    } else {
      const std::size_t c = std::size_t(comp_id[v]) * nq + q;
      const Vec3& n = comp_normal[comp_id[v]];
      if (n.squaredNorm() == 0.0) {
        // Voigt (equal strain) rule where no interface normal can be found.
        Mat9 A1, A0;
        s = mat[1]->evaluate(F, state_size[1] ? hist_old[1].data() + p * state_size[1] : nullptr,
                             state_size[1] ? hist_new[1].data() + p * state_size[1] : nullptr, dt, Px[1],
                             A ? &A1 : nullptr);
        if (s == MaterialStatus::ok)
          s = mat[0]->evaluate(F, state_size[0] ? hist_old[0].data() + p * state_size[0] : nullptr,
                               state_size[0] ? hist_new[0].data() + p * state_size[0] : nullptr, dt, Px[0],
                               A ? &A0 : nullptr);
        P = f * Px[1] + (1.0 - f) * Px[0];
        if (A && s == MaterialStatus::ok) *A = f * A1 + (1.0 - f) * A0;
        Fx[0] = Fx[1] = F;
      } else {
        Vec3 a(lam_a_trial[3 * c], lam_a_trial[3 * c + 1], lam_a_trial[3 * c + 2]);
        s = laminate(F, f, n, a, p, dt, P, A, Px, Fx);
        if (s == MaterialStatus::ok)
          for (int i = 0; i < 3; ++i) lam_a_trial[3 * c + i] = a[i];
      }
      if (s == MaterialStatus::ok && A && opt.composite_tangent == CompositeTangent::projected) project_semidefinite(*A);
      if (s == MaterialStatus::ok)
        for (int x = 0; x < 2; ++x) {
          const double wx = w * (x == 1 ? f : 1.0 - f);
          local.phase_P[x] += wx * Px[x];
          local.phase_F[x] += wx * Fx[x];
          local.phase_PFt[x] += wx * Px[x] * Fx[x].transpose();
          local.phase_J[x] += wx * Fx[x].determinant();
          local.phase_w[x] += wx;
          local.see_margin(x, mat[x]->limit_margin(Fx[x]), v0 + v);
        }
    }
    return s;
  }

  /// Evaluates every material point at F = F̄ + ∇ũ (gradient already in fft->real), writes P into the
  /// real buffer in place, stores tangents when asked; fills `sums`. Returns the first failure.
  MaterialStatus evaluate_points(const Mat3& Fbar_grid, double dt, bool with_tangent) {
    const double invN = 1.0 / double(Ntot);
    int failure = 0;
    PassSums total;
#pragma omp parallel
    {
      PassSums local;
      Mat9 A_point;
      detail::MeanDilatationVoxel md;
      std::unique_ptr<detail::MeanDilatationResponse> md_out;
      if (mean_dilatation) md_out = std::make_unique<detail::MeanDilatationResponse>();
#pragma omp for schedule(static)
      for (std::size_t v = 0; v < N; ++v) {
        int seen;
#pragma omp atomic read
        seen = failure;
        if (seen) continue;
        if (mean_dilatation && !prepare_mean_dilatation(v, Fbar_grid, md)) {
#pragma omp atomic write
          failure = int(MaterialStatus::inverted);
          continue;
        }
        for (int q = 0; q < nq; ++q) {
          const std::size_t p = v * nq + q;
          double* base = fft->real(9 * q) + v;
          const Mat3 F = mean_dilatation ? md.modified(q) : point_F(Fbar_grid, v, q);
          Mat3 P;
          Mat9* A = with_tangent ? &A_point : nullptr;
          const double w = op.quadrature()[q].weight * invN;
          const MaterialStatus s = evaluate_point(v, q, F, dt, P, A, local);
          if (s != MaterialStatus::ok || !P.allFinite()) {
            const int code = s == MaterialStatus::ok ? int(MaterialStatus::not_finite) : int(s);
#pragma omp atomic write
            failure = code;
            break;
          }
          if (mean_dilatation) {  // the voxel's stresses and tangents follow from all its points (below)
            md_out->P[q] = P;
            if (A) md_out->K[q] = *A;
            ++md.evaluated;
            continue;
          }
          for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) base[std::size_t(3 * i + j) * N] = P(i, j);
          local.P += w * flatten(P);
          if (A) {
            local.A += w * (*A);
            store_tangent(p, *A);
          }
        }
        if (mean_dilatation && md.evaluated == nq) finish_mean_dilatation(v, md, *md_out, with_tangent, local);
      }
#pragma omp critical
      total.add(local);
    }
    sums = total;
    if (dist) {
      // A failure on any rank fails the pass on all (the same control flow everywhere).
      failure = dist->max(failure);
      if (!failure) detail::reduce_pass_sums(sums, *dist);
    }
    return MaterialStatus(failure);
  }

  /// F_q = F̄ + ∇ũ_q of voxel v (gradient in fft->real) into `md`, and its J̄, α_q; false if inverted.
  bool prepare_mean_dilatation(std::size_t v, const Mat3& Fbar_grid, detail::MeanDilatationVoxel& md) const {
    double w[8];
    for (int q = 0; q < nq; ++q) {
      md.F[q] = point_F(Fbar_grid, v, q);
      w[q] = op.quadrature()[q].weight;
    }
    return md.prepare(nq, w);
  }
  /// The laws' P̄_q, A_q (in out.P, out.K) at F̄_q of voxel v → the stresses of the discrete energy
  /// into the real buffer, K_q into the tangent store and the voxel coupling (fft_mean_dilatation.hpp).
  void finish_mean_dilatation(std::size_t v, const detail::MeanDilatationVoxel& md, detail::MeanDilatationResponse& out,
                              bool with_tangent, PassSums& local) {
    Mat3 Pbar[8];
    Mat9 Abar[8];
    for (int q = 0; q < nq; ++q) {
      Pbar[q] = out.P[q];
      if (with_tangent) Abar[q] = out.K[q];
    }
    detail::mean_dilatation_response(md, Pbar, with_tangent ? Abar : nullptr, out);
    if (comp_id[v] < 0 && mixed[pure_phase(v)]) voxel_pressure_correction(pure_phase(v), v, md, out, with_tangent);
    const double invN = 1.0 / double(Ntot);
    for (int q = 0; q < nq; ++q) {
      double* base = fft->real(9 * q) + v;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) base[std::size_t(3 * i + j) * N] = out.P[q](i, j);
      local.P += md.w[q] * invN * flatten(out.P[q]);
      if (with_tangent) store_tangent(v * nq + q, out.K[q]);
    }
    if (!with_tangent) return;
    local.A += invN * out.voxel_tangent;
    md_coupling.store(v, out);
  }

  /// The mixed (u, p) iteration of a mean-dilatation voxel v of mixed phase x: its volumetric energy is
  /// W_V(J̄) (fft_mean_dilatation.hpp), so it carries one pressure p, linearized as at a pure point of the
  /// pointwise kinematics (pressure_correction()) but in J̄ = Σ_q w_q J_q:
  ///   p(F) = W_V′(J̄_k) + W_V″(J̄_k) Σ_q w_q cof F_q,k : (F_q − F_q,k),
  /// held per point as the slope c_q = W_V″(J̄_k) cof F_q,k (lin_c) and per voxel as s (lin_s at the
  /// voxel's first point). With q = p − W_V′(J̄), the stress of point q gains q cof F_q (∂J̄/∂F_q = w_q
  /// cof F_q) and its tangent K_q the geometric term q ∂cof F_q/∂F_q (∂²J̄ is block-diagonal in the
  /// points): the voxel's bulk stiffness W_V″ ∂J̄ ⊗ ∂J̄ stays, the pressure W_V′(J̄) ∂²J̄ of a spike in J̄
  /// is replaced by the linearized one. dP_ratio = −q / W_V″ at every point takes P̂ back to the true
  /// stress in evaluate_residual().
  void voxel_pressure_correction(int x, std::size_t v, const detail::MeanDilatationVoxel& md,
                                 detail::MeanDilatationResponse& out, bool with_tangent) {
    const std::size_t p0 = v * nq;
    const double dU = volumetric_dU(K_vol[x], md.J_mean), ddU = volumetric_ddU(K_vol[x], md.J_mean);
    double pr = dU;
    if (predictor_ratio >= 0.0) {
      pr = double(p_committed[p0]) + predictor_ratio * double(dp_last[p0]);
    } else if (linearized_pressure) {
      pr = lin_s[p0];
      for (int q = 0; q < nq; ++q) pr += md.w[q] * ddot(pressure_slope(x, p0 + std::size_t(q)), md.F[q]);
    }
    const double qv = pr - dU;
    Mat3 cof[detail::MeanDilatationVoxel::kMaxPoints];
    voxel_cofactors(md, cof);
    linearize_voxel_pressure(x, v, md, cof);
    for (int q = 0; q < nq; ++q) {
      p_trial[p0 + std::size_t(q)] = float(pr);
      dP_ratio[p0 + std::size_t(q)] = float(-qv / ddU);
      if (qv == 0.0) continue;
      out.P[q] += qv * cof[q];
      if (!with_tangent) continue;
      Mat9 G = Mat9::Zero();
      add_cofactor_derivative(qv / md.J[q], cof[q], G);
      out.K[q] += G;
      out.voxel_tangent += md.w[q] * G;
    }
  }
  static void voxel_cofactors(const detail::MeanDilatationVoxel& md, Mat3* cof) {
    for (int q = 0; q < md.nq; ++q) cof[q] = md.J[q] * md.F[q].inverse().transpose();
  }
  /// The linearization of voxel v's pressure at its current F_q (see voxel_pressure_correction()): the
  /// slopes rounded to float, s with those slopes, so that p(F_k) = W_V′(J̄_k) to double round-off.
  /// The slopes are always stored (lin_c): compact tangent records are off with mean dilatation.
  void linearize_voxel_pressure(int x, std::size_t v, const detail::MeanDilatationVoxel& md, const Mat3* cof) {
    const std::size_t p0 = v * nq;
    const double ddU = volumetric_ddU(K_vol[x], md.J_mean);
    double s0 = volumetric_dU(K_vol[x], md.J_mean);
    for (int q = 0; q < nq; ++q) {
      float* l = &lin_c[9 * (p0 + std::size_t(q))];
      for (int k = 0; k < 9; ++k) {
        l[k] = float(ddU * cof[q](k / 3, k % 3));
        s0 -= md.w[q] * double(l[k]) * md.F[q](k / 3, k % 3);
      }
    }
    lin_s[p0] = s0;
  }

  /// ∇ũ into the real buffer. Stencil operator: block (q, i) by block through fft3 (fft has no spectrum).
  void gradient_to_real(const std::vector<Complex>& uh) {
    if (!stencil) {
      op.gradient(uh.data(), fft->spectrum(0), false);
      fft->backward();
      return;
    }
    const int ncol = op.columns();
    if (ncol < 3) std::fill(fft3->spectrum(2), fft3->spectrum(2) + NM, Complex(0.0));  // defined values in the unused field
    for (int q = 0; q < nq; ++q)
      for (int i = 0; i < 3; ++i) {
        op.gradient_block(uh.data() + std::size_t(i) * NM, q, fft3->spectrum(0));
        fft3->backward();
        for (int j = 0; j < ncol; ++j) copy_from_real(*fft3, j, fft->real(9 * q + 3 * i + j));
      }
  }
  /// Real field `field` of grid transform t (dense or padded rows, FieldTransform::real_row_pitch()) to
  /// and from a dense voxel field.
  void copy_from_real(fft::FieldTransform& t, int field, double* to) const {
    const double* from = t.real(field);
    const std::size_t n1 = std::size_t(grid.n[0]), pitch = t.real_row_pitch(), rows = N / n1;
#pragma omp parallel for schedule(static)
    for (std::size_t r = 0; r < rows; ++r)
      for (std::size_t i = 0; i < n1; ++i) to[r * n1 + i] = from[r * pitch + i];
  }
  void copy_to_real(const double* from, fft::FieldTransform& t, int field) const {
    double* to = t.real(field);
    const std::size_t n1 = std::size_t(grid.n[0]), pitch = t.real_row_pitch(), rows = N / n1;
#pragma omp parallel for schedule(static)
    for (std::size_t r = 0; r < rows; ++r)
      for (std::size_t i = 0; i < n1; ++i) to[r * pitch + i] = from[r * n1 + i];
  }
  /// Three component spectra (3·NM) to real space; returns the transform holding them and the field
  /// step between the components (fft: fields 0, 3, 6, which are transformed for any number of columns;
  /// fft3: 0, 1, 2).
  std::pair<fft::FieldTransform*, int> vector_to_real(const std::vector<Complex>& uh) {
    if (stencil) {
      std::copy(uh.begin(), uh.begin() + std::ptrdiff_t(3 * NM), fft3->spectrum(0));
      fft3->backward();
      return {fft3.get(), 1};
    }
    for (int i = 0; i < 3; ++i) std::copy(uh.begin() + i * NM, uh.begin() + (i + 1) * NM, fft->spectrum(3 * i));
    fft->backward();
    return {fft.get(), 3};
  }

  /// Residual of the current state: r_u = Dᴴ P̂ and the macro stress error. Expects P in the real
  /// buffer (after evaluate_points).
  void residual(const std::array<bool, 9>& free, const Vec9& P_target, KVec& r) {
    if (stencil) {
      for (int q = 0; q < nq; ++q)
        for (int i = 0; i < 3; ++i) {
          for (int j = 0; j < op.columns(); ++j) copy_to_real(fft->real(9 * q + 3 * i + j), *fft3, j);
          fft3->forward();
          op.divergence_block(fft3->spectrum(0), q, r.u.data() + std::size_t(i) * NM, 1.0 / double(Ntot), q > 0);
        }
    } else {
      fft->forward();
      op.divergence(fft->spectrum(0), r.u.data(), 1.0 / double(Ntot));
    }
    macro_residual(free, P_target, r);
  }

  /// Residual of the evaluated iterate: `r` is the true residual (Div P_full: right-hand side and
  /// convergence test), the return value its relative norm; `merit` is set from Div P̂ (line search).
  /// Leaves P_full in the real buffer and its mean in sums.P.
  double evaluate_residual(const std::array<bool, 9>& free, const Vec9& P_target, KVec& r) {
    residual(free, P_target, r);
    if (!mixed_active) return residual_norm(r, free, P_target);
    residual_norm(r, free, P_target);
    const double merit_hat = merit;
    Vec9 mean = Vec9::Zero();
    const double invN = 1.0 / double(Ntot);
#pragma omp parallel
    {
      Vec9 local = Vec9::Zero();
#pragma omp for schedule(static)
      for (std::size_t v = 0; v < N; ++v)
        for (int q = 0; q < nq; ++q) {
          const std::size_t p = v * nq + q;
          const double ratio = dP_ratio[p];
          if (ratio == 0.0) continue;  // points without the pressure iteration, or q = 0
          // The slopes at p are those of this evaluation (pressure_correction() wrote them).
          const Mat3 slope = pressure_slope(pure_phase(v), p);
          double* base = fft->real(9 * q) + v;
          for (int c = 0; c < 9; ++c) {
            const double d = ratio * slope(c / 3, c % 3);
            base[std::size_t(c) * N] += d;
            local[c] += op.quadrature()[q].weight * d;
          }
        }
#pragma omp critical
      mean += local;
    }
    if (dist) dist->sum(mean.data(), 9);
    sums.P += invN * mean;
    residual(free, P_target, r);
    const double err = residual_norm(r, free, P_target);
    true_merit = merit;
    merit = merit_hat;
    return err;
  }
  // ---------------------------------------------------------------------------------------------
  // Streamed evaluation (streams_evaluation()): ∇ũ, the laws and the nodal forces in one real-space
  // pass over fft3's buffer (fft::StencilGradient::streamed_pass), no 9-field buffer. The same
  // iterates as the stored path to round-off (the divergence summed in another order).

  /// ũ's real nodal displacement into fft3's real buffer (in place of its spectrum; on a slab with its
  /// upper halo plane).
  void displacement_to_real(const std::vector<Complex>& uh) {
    std::copy(uh.begin(), uh.begin() + std::ptrdiff_t(3 * NM), fft3->spectrum(0));
    fft3->backward();
    fill_displacement_halo();
  }
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
  double spectral_norm2(const Complex* a, const Complex* b, double b_scale) const {
    double s = 0.0;
#pragma omp parallel for reduction(+ : s) schedule(static)
    for (std::size_t k = 0; k < NM; ++k) {
      const double lap = op.laplacian(op.mode_offset() + k);
      if (lap <= 0.0) continue;
      double e = 0.0;
      for (int c = 0; c < 3; ++c) e += std::norm(b ? a[c * NM + k] - b_scale * b[c * NM + k] : a[c * NM + k]);
      s += grid.mode_weight(k) * e / lap;
    }
    return global_sum(s);
  }
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
                                   const Vec9& P_target, KVec& r, double& err) {
    constexpr int B = fft::StencilGradient::kBatch;
    const double invN = 1.0 / double(Ntot);
    displacement_to_real(u);
    ensure_stream_scratch();
    int failure = 0;
    PassSums total;
    Vec9 correction = Vec9::Zero();  // volume mean of P_full − P̂
#pragma omp parallel
    {
      PassSums local;
      Vec9 local_correction = Vec9::Zero();
      Mat9 A_point;
      stencil->streamed_pass(fft3->real(0), stream_scratch.data(), [&](std::size_t p0, int count, const double* grad, double* stress) {
        for (int l = 0; l < count; ++l) {
          const std::size_t v = p0 + std::size_t(l);  // one point per voxel
          int seen;
#pragma omp atomic read
          seen = failure;
          Mat3 P = Mat3::Zero();
          if (!seen) {
            Mat9* A = with_tangent ? &A_point : nullptr;
            const MaterialStatus st = evaluate_point(v, 0, lane_F(Fbar_grid, grad, l), dt, P, A, local);
            if (st != MaterialStatus::ok || !P.allFinite()) {
              const int code = st == MaterialStatus::ok ? int(MaterialStatus::not_finite) : int(st);
#pragma omp atomic write
              failure = code;
              P.setZero();
            } else {
              local.P += invN * flatten(P);
              if (A) {
                local.A += invN * (*A);
                store_tangent(v, *A);
              }
              const double ratio = mixed_active ? double(dP_ratio[v]) : 0.0;
              if (ratio != 0.0) {  // P_full = P̂ + ratio · slope (evaluate_residual())
                const Mat3 d = ratio * pressure_slope(pure_phase(v), v);
                P += d;
                local_correction += flatten(d);
              }
            }
          }
          for (int c = 0; c < 9; ++c) stress[c * B + l] = P(c / 3, c % 3);
        }
      }, true, false, slab_shift_up());
#pragma omp critical
      {
        total.add(local);
        correction += local_correction;
      }
    }
    sums = total;
    if (dist) {
      // A failure on any rank fails the pass on all (the same control flow everywhere).
      failure = dist->max(failure);
      if (!failure) {
        detail::reduce_pass_sums(sums, *dist);
        dist->sum(correction.data(), 9);
      }
    }
    if (failure) return MaterialStatus(failure);
    fft3->forward();
    const Complex* s3 = fft3->spectrum(0);
    r.u.resize(3 * NM);
#pragma omp parallel for schedule(static)
    for (std::size_t a = 0; a < 3 * NM; ++a) r.u[a] = invN * s3[a];
    if (!mixed_active) {
      macro_residual(free, P_target, r);
      err = residual_norm(r, free, P_target);
      return MaterialStatus::ok;
    }
    // Merit of P̂: Dᴴ P̂ = r_u − Dᴴ (P_full − P̂), the correction's divergence in fft3.
#pragma omp parallel
    stencil->streamed_pass(fft3->real(0), stream_scratch.data(), [&](std::size_t p0, int count, const double*, double* stress) {
      for (int l = 0; l < count; ++l) {
        const std::size_t v = p0 + std::size_t(l);
        const double ratio = dP_ratio[v];
        const Mat3 d = ratio != 0.0 ? Mat3(ratio * pressure_slope(pure_phase(v), v)) : Mat3::Zero();
        for (int c = 0; c < 9; ++c) stress[c * B + l] = d(c / 3, c % 3);
      }
    }, false, false, slab_shift_up());
    fft3->forward();
    macro_residual(free, P_target, r);  // of P̂ (sums.P)
    const double merit_hat = std::sqrt(spectral_norm2(r.u.data(), fft3->spectrum(0), invN) + r.f.squaredNorm());
    sums.P += invN * correction;
    macro_residual(free, P_target, r);
    err = residual_norm(r, free, P_target);
    true_merit = merit;
    merit = merit_hat;
    return MaterialStatus::ok;
  }

  /// The undeformed state's points (phase sums, reference medium; tangents for Newton). Streamed: with
  /// its residual in a CG work vector, which the first solve overwrites.
  MaterialStatus evaluate_start() {
    if (!streamed) {
      gradient_to_real(u);
      return evaluate_points(to_grid(Fbar), 0.0, opt.scheme == FftScheme::newton_cg);
    }
    const std::array<bool, 9> none{};
    double err = 0.0;
    cg_p.u.resize(3 * NM);
    return evaluate_streamed(to_grid(Fbar), 0.0, true, none, Vec9::Zero(), cg_p, err);
  }

  /// The iterate (ũ, F̄) evaluated: its points (tangents stored when asked) and, when they all succeed,
  /// the residual r and its relative norm `err` (merit set). Streamed or through the 9-field buffer.
  MaterialStatus evaluate_iterate(double dt, bool with_tangent, const std::array<bool, 9>& free, const Vec9& P_target,
                                  KVec& r, double& err) {
    if (streamed) return evaluate_streamed(to_grid(Fbar), dt, with_tangent, free, P_target, r, err);
    gradient_to_real(u);
    const MaterialStatus s = evaluate_points(to_grid(Fbar), dt, with_tangent);
    if (s == MaterialStatus::ok) err = evaluate_residual(free, P_target, r);
    return s;
  }

  void commit_pressures(bool track_increment) {
    if (!mixed_active) return;
    for (std::size_t p = 0; p < NP; ++p) {
      dp_last[p] = track_increment ? float(double(p_trial[p]) - double(p_committed[p])) : 0.0f;
      p_committed[p] = p_trial[p];
    }
  }

  /// Stress scale of the relative residual: the macro stress on prescribed-F components and the
  /// stress targets (not the free components, whose error is part of the residual), floored.
  double stress_scale(const std::array<bool, 9>& free, const Vec9& P_target) const {
    const Vec9 Pl = T_load * sums.P;
    double s = 1e-6 * G_min;
    for (int c = 0; c < 9; ++c) s = std::max(s, free[c] ? std::abs(P_target[c]) : std::abs(Pl[c]));
    return s;
  }

  /// Relative residual norm (see FftSolverOptions::tolerance).
  double residual_norm(const KVec& r, const std::array<bool, 9>& free, const Vec9& P_target) {
    const double s = spectral_norm2(r.u.data(), nullptr, 0.0);
    merit = std::sqrt(s + r.f.squaredNorm());
    return std::max(std::sqrt(s), r.f.cwiseAbs().maxCoeff()) / stress_scale(free, P_target);
  }

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

  static void axpy(double alpha, const KVec& x, KVec& y) {
    const std::size_t n = x.u.size();
#pragma omp parallel for schedule(static)
    for (std::size_t i = 0; i < n; ++i) y.u[i] += alpha * x.u[i];
    y.f += alpha * x.f;
  }

  /// δP = (A + shift C_shift)(δF̄ + ∇δũ) at every point, in place in the real buffer (which holds ∇δũ on
  /// the transformed columns); returns the volume mean of δP (grid frame). The one pass over the
  /// stored tangents of a Krylov iteration: fused, no allocation, static schedule (the same voxel
  /// partition as evaluate_points(), which writes the tangents, so each thread reads what it wrote).
  Vec9 tangent_product(const Vec9& dFbar, double shift) {
    const Mat9 S = shift * C_shift;  // Levenberg–Marquardt shift (see pcg)
    const int ncol = op.columns();
    Vec9 mean = Vec9::Zero();
    double wq[8];
    for (int q = 0; q < nq; ++q) wq[q] = op.quadrature()[q].weight;
    const double* T = tangent.data();
#pragma omp parallel
    {
      double local[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
#pragma omp for schedule(static)
      for (std::size_t v = 0; v < N; ++v)
        for (int q = 0; q < nq; ++q) {
          double* base = fft->real(9 * q) + v;
          double dF[9], dP[9];
          for (int c = 0; c < 9; ++c) dF[c] = dFbar[c] + (c % 3 < ncol ? base[std::size_t(c) * N] : 0.0);
          symmetric_product(T + 45 * (v * nq + q), dF, dP);
          if (shift != 0.0) Eigen::Map<Vec9>(dP) += S * Eigen::Map<const Vec9>(dF);
          for (int c = 0; c < 9; ++c) {
            if (c % 3 < ncol) base[std::size_t(c) * N] = dP[c];
            local[c] += wq[q] * dP[c];
          }
        }
#pragma omp critical
      for (int c = 0; c < 9; ++c) mean[c] += local[c];
    }
    if (dist) dist->sum(mean.data(), 9);
    return mean / double(Ntot);
  }

  /// Stencil form of tangent_product() and the adjoint: the nodal displacement δũ in fft3's real buffer
  /// (with its halo) becomes the nodal forces f = Bᵀ (A + shift C_shift) (δF̄ + B δũ) there, and ⟨δũ, f⟩ (this
  /// rank's sum) goes to *dot when given. Streamed: one pass (StencilGradient::streamed_pass); else the
  /// gradient pass keeps its per-voxel values in fft's real buffer for the gather pass. Returns the
  /// volume mean of δP (grid frame).
  /// δP = A : δF of the stored tangents of the batch of points p0 … p0 + count − 1 (dF, dP [9][8] as in
  /// fft::StencilGradient::gradient_pass): compact records, with the composite points' full tangents, or
  /// the packed 9×9 tangents in float or double.
  void tangent_product_batch(std::size_t p0, int count, const double* dF, double* dP) const {
    if (compact)
      compact->product(p0, count, dF, dP, [&](int l) {
        const std::size_t p = p0 + std::size_t(l);
        const int c = comp_id[p / nq];
        return c < 0 ? -1L : long(c) * nq + long(p % nq);
      });
    else if (!tangent_f.empty())
      fft::symmetric_product_batch(tangent_f.data() + 45 * p0, dF, dP);
    else
      fft::symmetric_product_batch(tangent.data() + 45 * p0, dF, dP);  // block p0/8 starts at 360·p0/8
  }
  Vec9 stencil_tangent_product(const Vec9& dFbar, double shift, double* dot = nullptr) {
    const Mat9 S = shift * C_shift;
    Vec9 mean = Vec9::Zero();
    double wq[8];
    for (int q = 0; q < nq; ++q) wq[q] = op.quadrature()[q].weight;
    if (streamed) ensure_stream_scratch();
    double dot_sum = 0.0;
#pragma omp parallel reduction(+ : dot_sum)
    {
      double local[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
      constexpr int B = fft::StencilGradient::kBatch;
      static_assert(B == 8, "fft::symmetric_product_batch() and the tangent blocks hold 8 points");
      auto body = [&](std::size_t p0, int count, const double* grad, double* dP) {
        alignas(64) double dF[9 * B];
        for (int c = 0; c < 9; ++c)
          for (int l = 0; l < B; ++l) dF[c * B + l] = dFbar[c] + grad[c * B + l];
        tangent_product_batch(p0, count, dF, dP);
        if (mean_dilatation) md_coupling.add_to_batch<B>(p0, count, wq, dF, dP);
        for (int l = 0; l < count; ++l) {
          if (shift != 0.0)
            for (int a = 0; a < 9; ++a) {
              double acc = 0.0;
              for (int b = 0; b < 9; ++b) acc += S(a, b) * dF[b * B + l];
              dP[a * B + l] += acc;
            }
          const double w = wq[(p0 + l) % nq];
          for (int c = 0; c < 9; ++c) local[c] += w * dP[c * B + l];
        }
      };
      if (streamed)
        dot_sum += stencil->streamed_pass(fft3->real(0), stream_scratch.data(), body, true, dot != nullptr, slab_shift_up());
      else
        stencil->gradient_pass(fft3->real(0), stencil_store(), body);
#pragma omp critical
      for (int c = 0; c < 9; ++c) mean[c] += local[c];
    }
    if (!streamed) {
      fill_store_halo();
      dot_sum = stencil->divergence_pass(stencil_store(), fft3->real(0), dot ? fft3->real(0) : nullptr);
    }
    if (dot) *dot = dot_sum;
    if (dist) dist->sum(mean.data(), 9);
    return mean / double(Ntot);
  }

  /// y = K x with the stored tangents; x.f holds load-frame macro components (any mask applied by caller).
  void apply(const KVec& x, const std::array<bool, 9>& free, KVec& y, double shift = 0.0) {
    if (stencil) {
      displacement_to_real(x.u);
      const Vec9 mean = stencil_tangent_product(flatten(to_grid(unflatten(x.f))), shift);
      fft3->forward();
      const double invN = 1.0 / double(Ntot);
      const Complex* s3 = fft3->spectrum(0);
      y.u.resize(3 * NM);
#pragma omp parallel for schedule(static)
      for (std::size_t a = 0; a < 3 * NM; ++a) y.u[a] = invN * s3[a];
      const Vec9 ml = T_load * mean;
      for (int c = 0; c < 9; ++c) y.f[c] = free[c] ? ml[c] : 0.0;
      return;
    }
    op.gradient(x.u.data(), fft->spectrum(0), false);
    fft->backward();
    const Vec9 mean = tangent_product(flatten(to_grid(unflatten(x.f))), shift);
    fft->forward();
    op.divergence(fft->spectrum(0), y.u.data(), 1.0 / double(Ntot));
    const Vec9 ml = T_load * mean;
    for (int c = 0; c < 9; ++c) y.f[c] = free[c] ? ml[c] : 0.0;
  }

  /// The CG direction update fused with the operator: p ← z + β p, Ap = K p; returns ⟨p, Ap⟩.
  /// With the stencil operator Ap.u is not written: the unnormalised spectrum N·Ap.u is left in fft3's
  /// spectrum buffer, which the CG update reads with the factor 1/N (no extra pass). ⟨p, Ap⟩ is then
  /// taken on the real fields, which equals the half-spectrum sum because the CG vectors are spectra of
  /// real fields (b comes from r2c transforms, and D, K0⁻¹ map k and −k to complex conjugates).
  /// `r_for_z` (stencil operator): z.u is not stored, p ← K0⁻¹ r + βp from the residual.
  double apply_direction(const KVec& z, double beta, KVec& p, const std::array<bool, 9>& free, KVec& Ap,
                         double shift, const KVec* r_for_z = nullptr) {
    if (stencil) {
      // p ← z + βp, and a copy for the c2r transform (which destroys its input).
      Complex* s3 = fft3->spectrum(0);
      const Complex* zu = z.u.data();
      Complex* pu = p.u.data();
      if (r_for_z) {
        green.direction_update(r_for_z->u.data(), beta, pu, s3);
        if (local_bulk_in(shift))
          green.add_bulk_correction(bulk_cof, r_for_z->u.data(), bulk_fft->spectrum(0), 1.0 / double(Ntot), bulk_w0, pu, s3);
      } else {
#pragma omp parallel for schedule(static)
        for (std::size_t a = 0; a < 3 * NM; ++a) {
          const Complex v = beta == 0.0 ? zu[a] : zu[a] + beta * pu[a];
          pu[a] = v;
          s3[a] = v;
        }
      }
      p.f = beta == 0.0 ? Vec9(z.f) : Vec9(z.f + beta * p.f);
      fft3->backward();
      fill_displacement_halo();
      // ⟨p, Ap⟩ on the real fields (Parseval: Σ_half m_k Re(p̂_k* Âp_k) = Σ_y p(y)·f(y) / N).
      double pAp_local = 0.0;
      const Vec9 mean = stencil_tangent_product(flatten(to_grid(unflatten(p.f))), shift, &pAp_local);
      const double pAp = global_sum(pAp_local) / double(Ntot);
      fft3->forward();
      const Vec9 ml = T_load * mean;
      for (int c = 0; c < 9; ++c) Ap.f[c] = free[c] ? ml[c] : 0.0;
      return pAp + p.f.dot(Ap.f);
    }
    op.gradient_of_update(z.u.data(), beta, p.u.data(), fft->spectrum(0));
    p.f = beta == 0.0 ? Vec9(z.f) : Vec9(z.f + beta * p.f);
    fft->backward();
    const Vec9 mean = tangent_product(flatten(to_grid(unflatten(p.f))), shift);
    fft->forward();
    const double pAp = global_sum(op.divergence_dot(fft->spectrum(0), Ap.u.data(), 1.0 / double(Ntot), p.u.data()));
    const Vec9 ml = T_load * mean;
    for (int c = 0; c < 9; ++c) Ap.f[c] = free[c] ? ml[c] : 0.0;
    return pAp + p.f.dot(Ap.f);
  }

  /// Macro block of the preconditioner: z_f = Minv r_f on the free components.
  static void precondition_macro(const Vec9& rf, const Eigen::MatrixXd& macro_inverse, const std::vector<int>& free_idx,
                                 Vec9& zf) {
    zf.setZero();
    if (free_idx.empty()) return;
    Eigen::VectorXd r(free_idx.size());
    for (std::size_t a = 0; a < free_idx.size(); ++a) r[a] = rf[free_idx[a]];
    const Eigen::VectorXd z = macro_inverse * r;
    for (std::size_t a = 0; a < free_idx.size(); ++a) zf[free_idx[a]] = z[a];
  }

  /// z = M⁻¹ r: reference-medium Green operator per mode (tabulated by set_reference()), macro block inverse.
  void precondition(const KVec& r, const Eigen::MatrixXd& macro_inverse, const std::vector<int>& free_idx, KVec& z) {
    green.apply(r.u.data(), z.u.data());
    precondition_macro(r.f, macro_inverse, free_idx, z.f);
  }

  /// Indices of the stress-controlled (free) macro components.
  static std::vector<int> free_indices(const std::array<bool, 9>& free) {
    std::vector<int> idx;
    for (int c = 0; c < 9; ++c)
      if (free[c]) idx.push_back(c);
    return idx;
  }

  /// Inverse of the free-free block of the (shifted) reference medium C0 + shift · C_shift, load frame.
  Eigen::MatrixXd macro_block_inverse(const std::vector<int>& free_idx, double shift = 0.0) const {
    const Mat9 Cl = T_load * (C0 + shift * C_shift) * T_load.transpose();
    const int m = int(free_idx.size());
    Eigen::MatrixXd B(m, m);
    for (int a = 0; a < m; ++a)
      for (int b = 0; b < m; ++b) B(a, b) = Cl(free_idx[a], free_idx[b]);
    return m ? Eigen::MatrixXd(B.inverse()) : Eigen::MatrixXd(0, 0);
  }

  /// Chooses the reference medium C0 for the next linear solve(s) and tabulates its Green operator.
  /// `shift_without_bulk`: the Levenberg–Marquardt shift of the next solves is that of
  /// shift_medium(C0), else of C0.
  void set_reference(bool shift_without_bulk = false) {
    choose_reference();
    if (local_bulk) set_local_bulk_reference();
    C_shift = shift_without_bulk ? shift_medium(C0) : C0;
    green.set(C0);
    green_shift = 0.0;
    if (jacobi_green()) detail::set_jacobi_scaling(*this);
  }
  /// The Green table for the medium C0 + shift · C_shift (re-tabulated only when the shift changes).
  void tabulate_green(double shift) {
    if (shift == green_shift) return;
    green.set(C0 + shift * C_shift);
    green_shift = shift;
  }
  /// The medium of the Levenberg–Marquardt shift: C0 with its largest stiffness brought down to the
  /// next one. With a nearly incompressible phase C0's largest eigenvalue is the bulk stiffness (K/G up
  /// to 1.2e5) and its eigenvector the dilatation; negative curvature of the tangent (a pressure p times
  /// ∂cof/∂F, far from equilibrium) lives in isochoric modes, at the shear stiffness. A shift of the
  /// whole C0 would also damp the dilatation, which the Newton step must correct (a linear step leaves
  /// J − 1 = O(∇u²), a pressure spike K (J − 1)): with shift 10 the iteration then removes the spike
  /// about 15 % per step. Without the bulk stiffness the shifted step corrects J − 1 at once.
  static Mat9 shift_medium(const Mat9& C) {
    Eigen::SelfAdjointEigenSolver<Mat9> es(0.5 * (C + C.transpose()));
    if (es.info() != Eigen::Success) return C;
    Vec9 e = es.eigenvalues();
    if (!(e[7] > 0.0) || !(e[8] > e[7])) return C;
    e[8] = e[7];
    return es.eigenvectors() * e.asDiagonal() * es.eigenvectors().transpose();
  }
  /// Preconditioner::green_local_bulk (fft_local_bulk.hpp): C0 (chosen as usual) becomes the isotropic
  /// medium (k0, μ0) of its projection, pulled back at F̄; the weights w(x) come from the stored tangents.
  void set_local_bulk_reference() {
    const detail::IsotropicModuli iso = detail::isotropic_projection(C0);
    const double k0 = std::max(iso.K, 0.0), mu0 = std::max(iso.mu, 1e-12 * std::max(k0, 1.0));
    const Mat3 Fg = to_grid(Fbar);
    const double J = Fg.determinant();
    C0 = detail::isotropic_pull_back(k0, mu0, Fg);
    bulk_cof = J * Fg.inverse().transpose();
    bulk_w0 = J / (k0 + 4.0 / 3.0 * mu0);
    Vec9 b;
    for (int c = 0; c < 9; ++c) b[c] = bulk_cof(c / 3, c % 3);
    const double b2 = b.squaredNorm();
    constexpr int B = fft::StencilGradient::kBatch;
    double w_sum = 0.0;
#pragma omp parallel for schedule(static) reduction(+ : w_sum)
    for (std::size_t p0 = 0; p0 < NP; p0 += B) {
      const int count = int(std::min<std::size_t>(B, NP - p0));
      alignas(64) double dF[9 * B], dP[9 * B];
      for (int c = 0; c < 9; ++c)
        for (int l = 0; l < B; ++l) dF[c * B + l] = b[c];
      tangent_product_batch(p0, count, dF, dP);
      for (int l = 0; l < count; ++l) {
        double bAb = 0.0;
        for (int c = 0; c < 9; ++c) bAb += b[c] * dP[c * B + l];
        const double w = J / (detail::local_bulk_modulus(bAb, J, b2) + 4.0 / 3.0 * mu0);
        bulk_w[p0 + std::size_t(l)] = float(w);
        w_sum += double(float(w));
      }
    }
    bulk_w_sum = global_sum(w_sum);
  }
  /// The local-bulk part of z = M⁻¹ r for CG's r (spectral): ψ = η·r/|η|² to real space, θ = w (ψ + c)
  /// with c = −Σ wψ / Σ w, and back into bulk_fft's spectrum (unnormalised, read by the next direction's
  /// add_bulk_correction()). Returns ⟨r, z_bulk⟩ = (Σ ψθ − w0 Σ ψ²)/N (Parseval, global).
  double local_bulk_prepare(const Complex* r) {
    green.bulk_potential(bulk_cof, r, bulk_fft->spectrum(0));
    bulk_fft->backward();
    double* f = bulk_fft->real(0);
    const float* w = bulk_w.data();
    const std::size_t n1 = std::size_t(grid.n[0]), pitch = bulk_fft->real_row_pitch();
    const long rows = long(N / n1);
    double s_w_psi = 0.0, s_w_psi2 = 0.0, s_psi2 = 0.0;
#pragma omp parallel for schedule(static) reduction(+ : s_w_psi, s_w_psi2, s_psi2)
    for (long row = 0; row < rows; ++row) {
      const double* fr = f + std::size_t(row) * pitch;
      const float* wr = w + std::size_t(row) * n1;
      for (std::size_t i = 0; i < n1; ++i) {
        const double psi = fr[i], wv = double(wr[i]);
        s_w_psi += wv * psi;
        s_w_psi2 += wv * psi * psi;
        s_psi2 += psi * psi;
      }
    }
    if (dist) {  // one reduction for the three sums
      double sums3[3] = {s_w_psi, s_w_psi2, s_psi2};
      dist->sum(sums3, 3);
      s_w_psi = sums3[0];
      s_w_psi2 = sums3[1];
      s_psi2 = sums3[2];
    }
    const double c = bulk_w_sum > 0.0 ? -s_w_psi / bulk_w_sum : 0.0;
#pragma omp parallel for schedule(static)
    for (long row = 0; row < rows; ++row) {
      double* fr = f + std::size_t(row) * pitch;
      const float* wr = w + std::size_t(row) * n1;
      for (std::size_t i = 0; i < n1; ++i) fr[i] = double(wr[i]) * (fr[i] + c);
    }
    bulk_fft->forward();
    return (s_w_psi2 + c * s_w_psi - bulk_w0 * s_psi2) / double(Ntot);
  }
  /// The correction applies to unshifted solves only (the Green table is that of C0 itself).
  bool local_bulk_in(double shift) const { return local_bulk && shift == 0.0; }

  bool jacobi_green() const {
    return opt.preconditioner == Preconditioner::jacobi_green && stencil && opt.scheme == FftScheme::newton_cg;
  }
  void choose_reference() {
    if (opt.reference == ReferenceMedium::geometric && opt.scheme == FftScheme::newton_cg &&
        sums.phase_A_w[0] > 0.0 && sums.phase_A_w[1] > 0.0) {
      // Isotropic projections of the phase-mean tangents.
      double K[2], mu[2];
      for (int x = 0; x < 2; ++x) {
        const detail::IsotropicModuli iso = detail::isotropic_projection(sums.phase_A[x] / sums.phase_A_w[x]);
        K[x] = iso.K;
        mu[x] = iso.mu;
      }
      if (K[0] > 0.0 && K[1] > 0.0 && mu[0] > 0.0 && mu[1] > 0.0) {
        const double K0 = std::sqrt(K[0] * K[1]), mu0 = std::sqrt(mu[0] * mu[1]);
        C0 = detail::isotropic_tangent(K0 - 2.0 / 3.0 * mu0, mu0);
        return;
      }
    }
    if (opt.reference != ReferenceMedium::isotropic && opt.scheme == FftScheme::newton_cg)
      C0 = 0.5 * (sums.A + sums.A.transpose());
    else
      C0 = detail::isotropic_tangent(lambda_ref, mu_ref);
  }

  /// The Krylov space of the Newton system for krylov::pcg: half spectra of ũ with mode weights and
  /// the free macro components; the direction update is fused with the operator and the solution
  /// update with the preconditioner and ⟨r, z⟩ (one pass each over the spectra).
  struct CgSpace {
    Impl& m;
    const std::array<bool, 9>& free;
    const Eigen::MatrixXd& Minv;
    const std::vector<int>& free_idx;
    double shift;
    const KVec* r_live = nullptr;  // CG's r, when z.u is not stored (stencil operator)
    void start(const KVec& b, KVec& x, KVec& r) {
      r_live = &r;
      r.u = b.u;
      r.f = b.f;
      x.u.assign(3 * m.NM, 0.0);
      x.f.setZero();
    }
    double precondition_dot(const KVec& r, KVec& z) {
      precondition_macro(r.f, Minv, free_idx, z.f);
      const double bulk = m.local_bulk_in(shift) ? m.local_bulk_prepare(r.u.data()) : 0.0;
      return m.global_sum(m.green.apply_dot(r.u.data(), z.u.empty() ? nullptr : z.u.data())) + bulk + r.f.dot(z.f);
    }
    double direction(const KVec& z, double beta, KVec& p, KVec& Ap) {
      return m.apply_direction(z, beta, p, free, Ap, shift, z.u.empty() ? r_live : nullptr);
    }
    double update(double alpha, const KVec& p, const KVec& Ap, KVec& x, KVec& r, KVec& z) {
      double rz_new = m.stencil ? m.green.cg_update(alpha, p.u.data(), m.fft3->spectrum(0), x.u.data(), r.u.data(),
                                                    z.u.empty() ? nullptr : z.u.data(), 1.0, 1.0 / double(m.Ntot))
                                : m.green.cg_update(alpha, p.u.data(), Ap.u.data(), x.u.data(), r.u.data(), z.u.data());
      rz_new = m.global_sum(rz_new);
      if (m.local_bulk_in(shift)) rz_new += m.local_bulk_prepare(r.u.data());
      x.f += alpha * p.f;
      r.f -= alpha * Ap.f;
      precondition_macro(r.f, Minv, free_idx, z.f);
      return rz_new + r.f.dot(z.f);
    }
  };

  /// The same space for krylov::pminres (unfused operations, shift-free operator and preconditioner).
  struct MinresSpace {
    Impl& m;
    const std::array<bool, 9>& free;
    const Eigen::MatrixXd& Minv;
    const std::vector<int>& free_idx;
    KVec zero_like(const KVec& b) const { return KVec{std::vector<Complex>(b.u.size(), 0.0), Vec9::Zero()}; }
    void precondition(const KVec& r, KVec& z) { m.precondition(r, Minv, free_idx, z); }
    void apply(const KVec& x, KVec& y) { m.apply(x, free, y); }
    double dot(const KVec& a, const KVec& b) const { return m.dot(a, b); }
    void axpby(double alpha, const KVec& x, double beta, KVec& y) const { Impl::axpby(alpha, x, beta, y); }
    void divide(KVec& x, double s) const {
      for (auto& e : x.u) e /= s;
      x.f /= s;
    }
    void combine(const KVec& z, double a3, const KVec& w_old, double a2, const KVec& w, double a1, KVec& w_new, double c,
                 KVec& x) const {
      const std::size_t nu = z.u.size();
#pragma omp parallel for schedule(static)
      for (std::size_t i = 0; i < nu; ++i) {
        w_new.u[i] = (z.u[i] - a3 * w_old.u[i] - a2 * w.u[i]) / a1;
        x.u[i] += c * w_new.u[i];
      }
      w_new.f = (z.f - a3 * w_old.f - a2 * w.f) / a1;
      x.f += c * w_new.f;
    }
  };

  krylov::Controls krylov_controls(double rel_tol) const {
    krylov::Controls c;
    c.rel_tol = rel_tol;
    c.max_iterations = opt.max_krylov_iterations;
    c.stop = dist ? nullptr : &stop_requested;  // distributed: polled collectively per Newton iteration
    return c;
  }

  /// PCG on K x = b (x starts at zero); returns iterations. With `shift` > 0 it solves
  /// (K + shift K_S) x = b, K_S the operator of the medium C_shift (a Levenberg–Marquardt step, used
  /// when K is indefinite away from the solution), preconditioned by the Green operator of
  /// C0 + shift C_shift. Sets `breakdown` when a direction of non-positive
  /// curvature stops it.
  /// `residual`: CG's r (b may be the same vector, which the solve then overwrites; recover_rhs() gets it
  /// back); null: the member work vector.
  int pcg(const KVec& b, const std::array<bool, 9>& free, double rel_tol, KVec& x, double shift, bool& breakdown,
          KVec* residual = nullptr) {
    const auto start = Clock::now();
    const std::vector<int> free_idx = free_indices(free);
    tabulate_green(shift);
    const Eigen::MatrixXd Minv = macro_block_inverse(free_idx, shift);
    cg_p.u.resize(3 * NM);
    if (!stencil) cg_z.u.resize(3 * NM);  // the stencil operator's CG recomputes z (CgSpace::direction)
    if (!stencil) cg_Ap.u.resize(3 * NM);  // the stencil operator leaves Ap in fft3's spectrum buffer
    // Per iteration (Fourier operator): one fused pass p ← z + βp → ∇p, FFT⁻¹ of 6·nq (section) or 9·nq
    // fields, the tangent pass, FFT, one fused pass Div → Ap and ⟨p, Ap⟩, one fused pass x += αp,
    // r −= αAp, z = M⁻¹r and ⟨r, z⟩. Stencil operator (rotated/hex): p ← z + βp (+ copy), FFT⁻¹ of 3
    // fields, one real-space pass ∇p → δP → per-voxel nodal values (SIMD tangent product over 8
    // points), one gather pass Bᵀ δP with ⟨p, Ap⟩, FFT of 3 fields, the same CG update pass reading Ap
    // from the FFT buffer.
    CgSpace space{*this, free, Minv, free_idx, shift};
    auto macro = [&](const Vec9& rf) {
      Vec9 zf;
      precondition_macro(rf, Minv, free_idx, zf);
      return zf;
    };
    const krylov::CgResult res = jacobi_green() && shift == 0.0
                                     ? detail::jacobi_green_pcg(*this, b, free, macro, krylov_controls(rel_tol), x)
                                     : krylov::pcg(space, b, x, residual ? *residual : cg_r, cg_z, cg_p, cg_Ap,
                                                   krylov_controls(rel_tol));
    breakdown = res.breakdown;
    krylov_seconds += std::chrono::duration<double>(Clock::now() - start).count();
    return res.iterations;
  }

  /// The right-hand side b back from the residual r = b − (K + shift K_S) x that a solve left in b's
  /// storage (one operator application; exact up to the recurrence's round-off, for a retry).
  void recover_rhs(KVec& b, const KVec& x, const std::array<bool, 9>& free, double shift) {
    cg_p.u.resize(3 * NM);
    apply(x, free, cg_p, shift);
    axpy(1.0, cg_p, b);
  }

  /// Σ_k m_k Re(āᵤ · bᵤ) + a_f · b_f: the inner product of the Krylov space (half spectrum, mode weights).
  double dot(const KVec& a, const KVec& b) const {
    double s = 0.0;
#pragma omp parallel for reduction(+ : s) schedule(static)
    for (std::size_t k = 0; k < NM; ++k) {
      const double m = grid.mode_weight(k);
      for (int c = 0; c < 3; ++c) s += m * std::real(std::conj(a.u[c * NM + k]) * b.u[c * NM + k]);
    }
    return global_sum(s) + a.f.dot(b.f);
  }
  /// y ← α x + β y (both parts).
  static void axpby(double alpha, const KVec& x, double beta, KVec& y) {
    const std::size_t n = x.u.size();
#pragma omp parallel for schedule(static)
    for (std::size_t i = 0; i < n; ++i) y.u[i] = alpha * x.u[i] + beta * y.u[i];
    y.f = alpha * x.f + beta * y.f;
  }

  /// Preconditioned MINRES on K x = b with the SPD preconditioner of pcg() (reference Green operator +
  /// macro block). Used where CG meets negative curvature: past a bifurcation of the cell (fiber
  /// micro-buckling in compression) the tangent at the equilibrium is indefinite, and a
  /// Levenberg–Marquardt shift then stalls Newton just above the tolerance, while MINRES returns the
  /// Newton step itself. Returns iterations, `converged` false when it did not reach rel_tol.
  int pminres(const KVec& b, const std::array<bool, 9>& free, double rel_tol, KVec& x, bool& converged) {
    const auto start = Clock::now();
    const std::vector<int> free_idx = free_indices(free);
    tabulate_green(0.0);
    const Eigen::MatrixXd Minv = macro_block_inverse(free_idx);
    MinresSpace space{*this, free, Minv, free_idx};
    const krylov::MinresResult res = krylov::pminres(space, b, x, krylov_controls(rel_tol));
    converged = res.converged;
    krylov_seconds += std::chrono::duration<double>(Clock::now() - start).count();
    return res.iterations;
  }

  // ---------------------------------------------------------------------------------------------
  // Failure diagnosis.

  /// The hot spots of the current iterate (ũ, F̄ and the laminate vectors as they are now; see
  /// diagnostics.hpp): the matrix side of every non-fiber point, then the nodal forces of `r`.
  /// Destroys the real buffer.
  detail::HotSpots hot_spots(const KVec& r) {
    detail::HotSpots h;
    const Mat3 Fg = to_grid(Fbar);
    auto see_point = [&](std::size_t v, int q, Mat3 F) {
      const std::size_t p = v * nq + q;
      const double f = fraction(v);
      if (f >= 1.0) return;
      const bool composite = comp_id[v] >= 0;
      if (composite && comp_normal[comp_id[v]].squaredNorm() > 0.0) {
        const std::size_t c = std::size_t(comp_id[v]) * nq + q;
        const Vec3 a(lam_a_trial[3 * c], lam_a_trial[3 * c + 1], lam_a_trial[3 * c + 2]);
        F -= f * a * comp_normal[comp_id[v]].transpose();
      }
      h.see_matrix_point(v0 + v, mat[0]->limit_margin(F), F.determinant(), composite);
      if (mixed[0] && !composite) h.see_pressure(v0 + v, double(p_trial[p]));
    };
    if (streamed) {
      displacement_to_real(u);
      // one thread: the points in voxel order, as below (ties name the first voxel)
#pragma omp parallel num_threads(1)
      stencil->gradient_pass(fft3->real(0), nullptr, [&](std::size_t p0, int count, const double* grad, double*) {
        for (int l = 0; l < count; ++l) see_point(p0 + std::size_t(l), 0, lane_F(Fg, grad, l));
      });
    } else {
      gradient_to_real(u);
      for (std::size_t v = 0; v < N; ++v)
        for (int q = 0; q < nq; ++q) see_point(v, q, point_F(Fg, v, q));
    }
    // Nodal forces Dᴴ P in real space.
    const auto [t, step] = vector_to_real(r.u);
    std::vector<double> f(3 * N);  // dense copies of the three components (a failure path)
    for (int i = 0; i < 3; ++i) copy_from_real(*t, i * step, f.data() + i * N);
    h.see_forces(f.data(), f.data() + N, f.data() + 2 * N, N);
    if (dist) {
      h.v_force += v0;
      detail::reduce_hot_spots(h, *dist, N);
    }
    return h;
  }
  // Distributed: collective, the fractions of the named voxels come from the ranks that own them.
  std::string voxel_name(std::size_t v) const {
    if (!dist) return detail::voxel_name(grid.n, local_fraction(), v);
    const double f = detail::fractions_of(*dist, local_fraction(), N, v0, {v})[0];
    return detail::voxel_name(grid.n, detail::FractionOf([f](std::size_t) { return f; }), v);
  }
  std::string describe(const detail::HotSpots& h) const {
    if (!dist) return detail::describe_hot_spots(h, grid.n, local_fraction(), mixed[0], Fbar_committed(0, 0));
    const std::vector<std::size_t> named{h.v_margin, h.v_J_min, h.v_force, h.v_p};
    const std::vector<double> f = detail::fractions_of(*dist, local_fraction(), N, v0, named);
    auto fraction = [&](std::size_t v) { return f[std::find(named.begin(), named.end(), v) - named.begin()]; };
    return detail::describe_hot_spots(h, grid.n, detail::FractionOf(fraction), mixed[0], Fbar_committed(0, 0));
  }

  // ---------------------------------------------------------------------------------------------
  // One (sub)step from the committed state to t_new.

  using StepOutcome = detail::SubstepOutcome;

  static StepOutcome& fatal(StepOutcome& out, std::string why) {
    out.fatal = true;
    out.why = std::move(why);
    return out;
  }
  /// A converged sub-step: ok unless a phase is at its material limit there (fatal).
  StepOutcome& converged(StepOutcome& out) const {
    const std::string where[2] = {voxel_name(sums.v_margin[0]), voxel_name(sums.v_margin[1])};
    if (std::string why = detail::phase_limit_reached(sums.margin, where, Fbar); !why.empty()) return fatal(out, why);
    out.ok = true;
    return out;
  }

  /// Back to the line search's last accepted iterate ũ − applied · Δũ, F̄_prev (no copy of ũ is kept):
  /// applied = 0.
  void move_to_accepted(const KVec& dx, double& applied, const Mat3& Fbar_prev) {
#pragma omp parallel for schedule(static)
    for (std::size_t i = 0; i < u.size(); ++i) u[i] -= applied * dx.u[i];
    applied = 0.0;
    Fbar = Fbar_prev;
  }

  StepOutcome step(const MixedControl& control, double t_new, double dt) {
    StepOutcome out;
    std::array<bool, 9> free{};
    Vec9 P_target = Vec9::Zero();
    Mat3 target = Fbar;  // prescribed components at t_new
    for (int c = 0; c < 9; ++c) {
      free[c] = control.kind[c] == ControlKind::stress;
      if (free[c])
        P_target[c] = control.value[c](t_new);
      else
        target(c / 3, c % 3) = control.value[c](t_new);
    }
    KVec r{std::vector<Complex>(3 * NM), Vec9::Zero()}, dx;
    if (std::string why = detail::target_inverts(control, t_new, Fbar_committed); !why.empty()) return fatal(out, why);
    if (opt.scheme == FftScheme::moulinec_suquet) return fixed_point(free, P_target, target, dt, r);

    int max_it = opt.max_newton_iterations;
    double err = 0.0, first_err = -1.0;
    // Pseudo-transient continuation (FftSolverOptions::max_continuation_iterations), entered when
    // Newton stagnates: shift δ of the reference medium, residual of the previous iterate.
    bool continuation = false;
    // MINRES for negative curvature near the solution: always (indefinite_solver = minres), or once the
    // shifted iteration has stalled (minres_fallback).
    bool minres_mode = opt.indefinite_solver == IndefiniteSolver::minres;
    double ptc_shift = 0.0, ptc_err = 0.0;
    // The last accepted iterate is u − applied · dx (no copy of ũ kept): the line search moves u along dx.
    double applied = 0.0;
    Mat3 Fbar_prev = Fbar, step_macro = Mat3::Zero();
    bool had_prescribed_step = false;
    // The predictor takes the extrapolated pressure (or, at the committed state, the exact W_V′(J),
    // which is what the linearization there would give); every later iterate takes its pressure from
    // the linearization at the last accepted state (see pressure_correction()).
    linearized_pressure = false;
    double lm_shift = 0.0;
    bool full_first_step = false;
    bool extrapolated = false;  // the step starts from the extrapolated predictor (else the tangent predictor)
    for (int it = 0; it <= max_it; ++it) {
      if (stop_now()) {
        out.why = "stopped by a signal";
        return out;
      }
      // Evaluate the new iterate. After a Newton update, a backtracking line search on the residual
      // norm: nearly incompressible matrices (K/G ~ 1e5) make full Newton steps overshoot in J.
      if (it == 0) {
        // Predictor: linear extrapolation of the last converged increment (prescribed components set
        // exactly); the path is smooth, so this lands much closer to the solution than the tangent
        // predictor when the matrix is nearly incompressible. Falls back to the tangent predictor.
        extrapolated = false;
        if (extrapolate && dt_last > 0.0 && !du_last.empty()) {
          const double ratio = dt / dt_last;
          for (std::size_t i = 0; i < u.size(); ++i) u[i] = u_committed[i] + ratio * Complex(du_last[i]);
          Fbar = Fbar_committed + ratio * dF_last;
          for (int c = 0; c < 9; ++c)
            if (!free[c]) Fbar(c / 3, c % 3) = target(c / 3, c % 3);
          predictor_ratio = ratio;
          extrapolated = evaluate_iterate(dt, true, free, P_target, r, err) == MaterialStatus::ok;
          predictor_ratio = -1.0;
          if (!extrapolated) restore();
          // Its merit (extrapolated pressure) is not comparable with the Newton iterates' (pressure
          // reset to the constraint's linearization), so the first Newton step is taken in full.
          else if (mixed_active) full_first_step = true;
        }
        const MaterialStatus s = extrapolated ? MaterialStatus::ok : evaluate_iterate(dt, true, free, P_target, r, err);
        if (s != MaterialStatus::ok) {
          out.why = std::string("material call failed (") + to_string(s) + ")";
          return out;
        }
        linearized_pressure = mixed_active;
      } else {
        MaterialStatus last = MaterialStatus::ok;
        int trials = 0;
        auto trial = [&](double scale) -> std::optional<double> {
          if (mixed_active && (trials++ > 0 || opt.relinearize_every_trial)) {
            // The previous trial was rejected and left its linearization (all of it, or part after a
            // material failure): back to the accepted iterate (applied = 0) and its linearization before
            // this trial reads it (FftSolverOptions::relinearize_every_trial: before every trial, a check).
            // A trial evaluated with the rejected one's linearization would still converge to the same
            // stress, by another path.
            move_to_accepted(dx, applied, Fbar_prev);
            relinearize_pressures(to_grid(Fbar));
          }
          const double move = scale - applied;
#pragma omp parallel for schedule(static)
          for (std::size_t i = 0; i < u.size(); ++i) u[i] += move * dx.u[i];
          applied = scale;
          Fbar = Fbar_prev + scale * step_macro;
          last = evaluate_iterate(dt, true, free, P_target, r, err);
          if (last != MaterialStatus::ok) return std::nullopt;
          if (!std::isfinite(err)) return std::nullopt;
          return merit;
        };
        // Continuation accepts any admissible iterate: on the way from the end of one equilibrium
        // branch to the next the residual has to grow before it falls.
        // Mixed iteration: the trials are measured with the pressure linearized at the accepted
        // iterate x_k, which reproduces W_V′ there, so the reference is x_k's true residual; the
        // merit x_k was accepted with (the previous linearization's) is not comparable and, taken as
        // the reference, let the true residual grow several-fold or held the step to the last trial
        // (BENCHMARKS.md, "FFT Newton iterations: the line search's reference").
        const double merit_accepted = mixed_active ? true_merit : merit;
        const bool accepted =
            fe::backtracking_line_search(merit_accepted, continuation || had_prescribed_step, trial).accepted;
        if (!accepted) {
          out.why = last != MaterialStatus::ok ? std::string("material call failed (") + to_string(last) + ")"
                                               : std::string("line search failed");
          // Diagnose the last accepted iterate, not the rejected trial (an overshooting full step of a
          // nearly incompressible matrix can be arbitrarily far from anything the cell can reach).
          // r holds the right-hand side of the last solve: re-evaluate the restored iterate's residual,
          // with its linearization (the trials overwrote it).
          // The composite points start their laminate solves from the committed jump vectors: the
          // failed trials left theirs, from which a solve at the accepted F can fail too and leave the
          // diagnosis without a residual (RveStops.FftFailedLineSearchIsDiagnosedAtTheAcceptedIterate).
          move_to_accepted(dx, applied, Fbar_prev);
          lam_a_trial = lam_a;
          if (mixed_active) relinearize_pressures(to_grid(Fbar));
          double accepted_err = 0.0;
          const MaterialStatus again = evaluate_iterate(dt, false, free, P_target, r, accepted_err);
          // Without its residual the hot spots would name a zero force at voxel (0, 0, 0): say so instead.
          out.why += again == MaterialStatus::ok
                         ? "; " + describe(hot_spots(r))
                         : std::string("; the last accepted iterate could not be evaluated again (") + to_string(again) + ")";
          return out;
        }
      }
      out.residuals.push_back(err);
      if (opt.on_newton_iteration) opt.on_newton_iteration(t_new, it, err, out.krylov_iterations);
      Mat3 dFp = Mat3::Zero();
      for (int c = 0; c < 9; ++c)
        if (!free[c]) dFp(c / 3, c % 3) = target(c / 3, c % 3) - Fbar(c / 3, c % 3);
      const bool prescribed_reached = dFp.cwiseAbs().maxCoeff() == 0.0;
      if (!std::isfinite(err)) {
        out.why = "non-finite residual";
        return out;
      }
      // Round-off floor: stresses ~ K (J − 1) carry absolute errors ~ ε K (K/G = 1.2e5 for ecoflex), so
      // a relative tolerance below ε K / |P̄| cannot be reached; there the floor counts as convergence.
      const double floor = 64.0 * std::numeric_limits<double>::epsilon() * K_max / stress_scale(free, P_target);
      if (prescribed_reached && err <= std::max(opt.tolerance, floor)) {
        return converged(out);
      }
      if (continuation) {
        // Switched evolution relaxation, one-sided: the shift follows a falling residual, so it
        // vanishes (Newton) as the iteration closes in on an equilibrium, but is not raised while the
        // residual grows on the way between branches (that would stall the descent); only an
        // indefinite linear solve raises it (the Levenberg–Marquardt retry below).
        ptc_shift *= std::clamp(err / ptc_err, 0.2, 1.0);
        if (ptc_shift < 1e-9) ptc_shift = 0.0;
        ptc_err = err;
        ++out.continuation_iterations;
      } else if (prescribed_reached && opt.max_continuation_iterations > 0 && it >= 10 &&
                 (it == max_it || err > 0.3 * out.residuals[out.residuals.size() - 4])) {
        // Stagnation (less than a factor 3 in three iterations after ten): the branch has ended.
        continuation = true;
        ptc_shift = std::max(10.0 * lm_shift, 1e-2);
        ptc_err = err;
        max_it = it + opt.max_continuation_iterations;
      }
      if (it == max_it) {
        if (!minres_mode && !continuation && opt.minres_fallback && prescribed_reached && err < opt.minres_below) {
          // The shifted iteration stalls just above the tolerance next to a bifurcation point of the
          // cell (singular tangent): take the exact Newton steps there (MINRES on negative curvature).
          minres_mode = true;
          lm_shift = 0.0;
          max_it = it + opt.max_newton_iterations;
          ++out.minres_fallbacks;
        } else {
          break;
        }
      }
      if (prescribed_reached) {
        if (first_err < 0.0) first_err = err;
        if (err > 1e6 * std::max(first_err, opt.tolerance)) {
          out.why = "Newton diverged";
          return out;
        }
      }
      // The solve after the step's full linear increment (the extrapolated predictor's, else that after
      // the tangent predictor's step, which is taken in full) starts where J − 1 = O(Δ∇u²) near the
      // fibers, a pressure spike K (J − 1) that makes the tangent indefinite (composite voxels, whose
      // laminate carries the law's own pressure): its shift must leave the dilatation free
      // (shift_medium()). Later solves shift by C0 itself, which damps every mode alike and measured
      // better once the spike is gone (BENCHMARKS.md, "FFT Newton iterations").
      set_reference(it == 0 || (it == 1 && !extrapolated));
      // Right-hand side −r − K [0; ΔF_p] (tangent predictor for the prescribed increment), formed in
      // r's storage: r is not read again before the next evaluation overwrites it. The CG work vectors
      // serve as e and K e (pcg overwrites them).
      KVec& b = r;
      for (auto& c : b.u) c = -c;
      b.f = -b.f;
      if (!prescribed_reached) {
        KVec& e = dx;  // pcg() starts from zero
        KVec& Ke = cg_p;
        e.u.assign(3 * NM, 0.0);
        e.f = flatten(dFp);
        Ke.u.resize(3 * NM);
        apply(e, free, Ke);
        ++out.krylov_iterations;
        axpy(-1.0, Ke, b);
      }
      // Forcing term (Eisenstat–Walker-like): loose while far from the solution, tight near it.
      double eta = std::clamp(std::max(std::min(1e-2, err), 0.1 * opt.tolerance / std::max(err, 1e-300)), 1e-12, 0.1);
      if (opt.krylov_tolerance > 0.0) eta = opt.krylov_tolerance;
      // Indefinite tangent (large pressure or compression away from the solution): retry the linear
      // solve as a Levenberg–Marquardt step with a shift of the reference medium, which grows by 10
      // on each breakdown and starts the next Newton iteration ten times smaller.
      bool breakdown = false;
      double shift = continuation ? ptc_shift : lm_shift;
      const double lin_tol = prescribed_reached ? eta : std::min(eta, 1e-3);
      // The solve's residual lives in b's storage (one spectral vector less): after a breakdown b is
      // recovered for the retry.
      const bool rhs_in_place = !jacobi_green();
      for (int attempt = 0; attempt < 8; ++attempt) {
        const int cg_iterations = pcg(b, free, lin_tol, dx, shift, breakdown, rhs_in_place ? &b : nullptr);
        out.krylov_iterations += cg_iterations;
        if (!breakdown) break;
        out.discarded_krylov_iterations += cg_iterations;
        if (rhs_in_place) {
          recover_rhs(b, dx, free, shift);
          ++out.krylov_iterations;
          ++out.discarded_krylov_iterations;
        }
        // Negative curvature near the solution (the residual is already small): an indefinite
        // equilibrium tangent, not a transient of the iteration — solve it as it is (MINRES).
        if (minres_mode && shift == 0.0 && prescribed_reached &&
            err < opt.minres_below) {
          bool converged = false;
          const int minres_iterations = pminres(b, free, lin_tol, dx, converged);
          out.krylov_iterations += minres_iterations;
          if (!converged) out.discarded_krylov_iterations += minres_iterations;
          ++out.minres_solves;
          if (converged) {
            breakdown = false;
            break;
          }
        }
        shift = shift == 0.0 ? 1e-3 : 10.0 * shift;
        ++out.shifted_solves;
      }
      lm_shift = shift >= 1e-2 ? 0.1 * shift : 0.0;
      if (continuation) ptc_shift = shift;
      ++out.newton_iterations;
      applied = 0.0;
      Fbar_prev = Fbar;
      step_macro = dFp + unflatten(dx.f);
      had_prescribed_step = !prescribed_reached || (it == 0 && full_first_step);
    }
    out.why = "no convergence in " + std::to_string(opt.max_newton_iterations) + " Newton iterations" +
              (continuation ? " + " + std::to_string(out.continuation_iterations) + " continuation iterations" : std::string()) +
              " (residual " + std::to_string(err) + "); " + describe(hot_spots(r));
    return out;
  }

  /// Basic Moulinec–Suquet scheme: ũ ← ũ − K0⁻¹ Dᴴ P, F̄_free ← F̄_free − C0_ff⁻¹ (⟨P⟩ − P*).
  StepOutcome fixed_point(const std::array<bool, 9>& free, const Vec9& P_target, const Mat3& target, double dt,
                          KVec& r) {
    StepOutcome out;
    for (int c = 0; c < 9; ++c)
      if (!free[c]) Fbar(c / 3, c % 3) = target(c / 3, c % 3);
    set_reference();
    const std::vector<int> free_idx = free_indices(free);
    const Eigen::MatrixXd Minv = macro_block_inverse(free_idx);
    KVec z{std::vector<Complex>(3 * NM), Vec9::Zero()};
    double err = 0.0;
    for (int it = 0; it <= opt.max_fixed_point_iterations; ++it) {
      if (stop_now()) {
        out.why = "stopped by a signal";
        return out;
      }
      gradient_to_real(u);
      const MaterialStatus s = evaluate_points(to_grid(Fbar), dt, false);
      if (s != MaterialStatus::ok) {
        out.why = std::string("material call failed (") + to_string(s) + ")";
        return out;
      }
      residual(free, P_target, r);
      err = residual_norm(r, free, P_target);
      if (!std::isfinite(err) || err > 1e12) {
        out.why = "fixed point diverged";
        return out;
      }
      if (err <= opt.tolerance) {
        out.residuals.push_back(err);
        return converged(out);
      }
      precondition(r, Minv, free_idx, z);
      for (std::size_t i = 0; i < u.size(); ++i) u[i] -= z.u[i];
      Fbar -= unflatten(z.f);
      ++out.newton_iterations;
    }
    out.residuals.push_back(err);
    out.why = "fixed point: no convergence in " + std::to_string(opt.max_fixed_point_iterations) + " iterations";
    return out;
  }

  void commit(double dt) {
    // Remember the converged increment: the next step starts from its linear extrapolation.
    du_last.resize(u.size());
    for (std::size_t i = 0; i < u.size(); ++i) du_last[i] = std::complex<float>(u[i] - u_committed[i]);
    dF_last = Fbar - Fbar_committed;
    dt_last = dt;
    u_committed = u;
    Fbar_committed = Fbar;
    lam_a = lam_a_trial;
    for (int x = 0; x < 2; ++x)
      if (state_size[x]) hist_old[x].swap(hist_new[x]);
    commit_pressures(true);
  }
  std::vector<double> slab_node_displacement(fft::FieldTransform& t, int step, const Mat3& G) {
    return detail::slab_node_displacement(*dist, t, step, grid, G);
  }

  void restore() {
    u = u_committed;
    Fbar = Fbar_committed;
    lam_a_trial = lam_a;
  }

  RveStep record(double t, double angle0) const {
    return detail::record_step(t, angle0, Fbar, unflatten(T_load * sums.P), sums,
                               [this](const Mat3& A) { return to_load(A); }, a0_load);
  }

  /// F, P, σ and the von Mises stress of voxel v into the fields (load frame).
  static void put_voxel_fields(RveFields& f, std::size_t v, const Mat3& Fm, const Mat3& Pm, const Mat3& Sm) {
    const Mat3 dev = Sm - Sm.trace() / 3.0 * Mat3::Identity();
    f.von_mises[v] = std::sqrt(1.5 * ddot(dev, dev));
    for (int c = 0; c < 9; ++c) {
      f.F[9 * v + c] = Fm(c / 3, c % 3);
      f.P[9 * v + c] = Pm(c / 3, c % 3);
      f.sigma[9 * v + c] = Sm(c / 3, c % 3);
    }
  }
  /// P of the last evaluation at voxel v (one point, elastic phases: the streamed evaluation), computed
  /// again at its F: the law, or the laminate from its converged jump vector; at pure points of a mixed
  /// phase plus the residual's P_full − P_law = ratio (slope − W_V″ cof F), from the evaluation's
  /// linearization (pressure_correction(), evaluate_residual()).
  Mat3 evaluated_stress(std::size_t v, const Mat3& F) const {
    Mat3 P = Mat3::Zero();
    if (comp_id[v] < 0) {
      const int x = pure_phase(v);
      mat[x]->evaluate(F, nullptr, nullptr, 0.0, P, nullptr);
      const double ratio = mixed[x] ? double(dP_ratio[v]) : 0.0;
      if (ratio != 0.0) {
        const VolumetricState vs = volumetric_state(K_vol[x], F);
        P += ratio * (pressure_slope(x, v) - vs.ddU * vs.cof);
      }
      return P;
    }
    const double f = fraction(v);
    const Vec3& n = comp_normal[comp_id[v]];
    Mat3 Px[2], Fx[2];
    if (n.squaredNorm() == 0.0) {
      mat[1]->evaluate(F, nullptr, nullptr, 0.0, Px[1], nullptr);
      mat[0]->evaluate(F, nullptr, nullptr, 0.0, Px[0], nullptr);
      return f * Px[1] + (1.0 - f) * Px[0];
    }
    const std::size_t c = std::size_t(comp_id[v]);
    Vec3 a(lam_a_trial[3 * c], lam_a_trial[3 * c + 1], lam_a_trial[3 * c + 2]);
    laminate(F, f, n, a, v, 0.0, P, nullptr, Px, Fx);
    return P;
  }

  /// Fields of the converged state (P still in the real buffer, ũ current). Destroys the buffer.
  RveFields fields() {
    RveFields f;
    f.F.assign(9 * N, 0.0);
    f.P.assign(9 * N, 0.0);
    f.sigma.assign(9 * N, 0.0);
    f.von_mises.assign(N, 0.0);
    f.fiber_fraction.resize(N);
    for (std::size_t v = 0; v < N; ++v) f.fiber_fraction[v] = fraction(v);
    if (streamed) {
      displacement_to_real(u);
      const Mat3 Fg = to_grid(Fbar);
#pragma omp parallel
      stencil->gradient_pass(fft3->real(0), nullptr, [&](std::size_t p0, int count, const double* grad, double*) {
        for (int l = 0; l < count; ++l) {
          const std::size_t v = p0 + std::size_t(l);
          const Mat3 F = lane_F(Fg, grad, l);
          const Mat3 Fm = to_load(F), Pm = to_load(evaluated_stress(v, F));
          put_voxel_fields(f, v, Fm, Pm, cauchy_from_piola(Fm, Pm));
        }
      });
      f.displacement = node_displacement();
      return f;
    }
    // P of the last evaluation is in the real buffer, which ∇ũ overwrites next. One point per voxel
    // (rotated, spectral): P goes straight into the field and σ follows from the voxel's F and P; several
    // points (hex): σ is the mean of the points' σ, so the points' P are copied (9·nq fields).
    const bool one_point = nq == 1;
    std::vector<double> P;
    if (one_point) {
#pragma omp parallel for schedule(static)
      for (std::size_t v = 0; v < N; ++v) {
        Mat3 Pq;
        for (int c = 0; c < 9; ++c) Pq(c / 3, c % 3) = fft->real(c)[v];
        const Mat3 Pl = to_load(Pq);
        for (int c = 0; c < 9; ++c) f.P[9 * v + c] = Pl(c / 3, c % 3);
      }
    } else {
      P.assign(fft->real(0), fft->real(0) + 9 * NP);
    }
    gradient_to_real(u);
    const Mat3 Fg = to_grid(Fbar);
#pragma omp parallel for schedule(static)
    for (std::size_t v = 0; v < N; ++v) {
      Mat3 Fm = Mat3::Zero(), Pm = Mat3::Zero(), Sm = Mat3::Zero();
      for (int q = 0; q < nq; ++q) {
        const Mat3 Fq = point_F(Fg, v, q);
        const double w = op.quadrature()[q].weight;
        Fm += w * to_load(Fq);
        if (one_point) continue;
        Mat3 Pq;
        for (int c = 0; c < 9; ++c) Pq(c / 3, c % 3) = P[std::size_t(9 * q + c) * N + v];
        Pm += w * to_load(Pq);
        Sm += w * to_load(cauchy_from_piola(Fq, Pq));
      }
      if (one_point) {
        for (int c = 0; c < 9; ++c) Pm(c / 3, c % 3) = f.P[9 * v + c];
        Sm = cauchy_from_piola(Fm, Pm);  // frame-covariant: the same as in the grid frame, rotated
      }
      put_voxel_fields(f, v, Fm, Pm, Sm);
    }
    f.displacement = node_displacement();
    return f;
  }

  /// Displacement u = (F̄_grid − I) y + ũ(y) at the (n1+1)(n2+1)(n3+1) voxel corners y (grid frame,
  /// y1 fastest; the corners of the last layer repeat ũ of the first, periodic, with the macro part
  /// continued). ũ at the corners is the c2r transform of its spectrum (rotated/hex: the nodal
  /// displacement of the discretization; spectral: the trigonometric interpolant). Uses fft's buffers.
  std::vector<double> node_displacement() {
    const auto [t, step] = vector_to_real(u);
    const Mat3 G = to_grid(Fbar) - Mat3::Identity();
    if (dist) return slab_node_displacement(*t, step, G);
    const std::array<int, 3>& n = grid.n;
    const std::size_t m1 = n[0] + 1, m2 = n[1] + 1, m3 = n[2] + 1;
    std::vector<double> out(3 * m1 * m2 * m3);
    for (std::size_t i3 = 0; i3 < m3; ++i3)
      for (std::size_t i2 = 0; i2 < m2; ++i2)
        for (std::size_t i1 = 0; i1 < m1; ++i1) {
          const std::size_t v = t->real_index(i1 % n[0] + std::size_t(n[0]) * (i2 % n[1] + std::size_t(n[1]) * (i3 % n[2])));
          const Vec3 y(double(i1) * grid.spacing(0), double(i2) * grid.spacing(1), double(i3) * grid.spacing(2));
          const Vec3 uy = G * y + Vec3(t->real(0)[v], t->real(step)[v], t->real(2 * step)[v]);
          double* o = &out[3 * (i1 + m1 * (i2 + m2 * i3))];
          for (int c = 0; c < 3; ++c) o[c] = uy[c];
        }
    return out;
  }
};

FftRveSolver::FftRveSolver(const PhaseImage& image, MaterialPtr matrix, MaterialPtr fiber, double fiber_angle_deg,
                           const Mat3& load_frame, const FftSolverOptions& options)
    : impl_(std::make_unique<Impl>(image, std::move(matrix), std::move(fiber), fiber_angle_deg, load_frame, options)) {}
FftRveSolver::~FftRveSolver() = default;

const fft::Grid& FftRveSolver::grid() const { return impl_->grid; }
int FftRveSolver::quadrature_points() const { return impl_->nq; }
Preconditioner FftRveSolver::preconditioner() const { return impl_->opt.preconditioner; }

std::string FftRveSolver::fft_description() const {
  // With the stencil operator every transform is fft3's (3 fields); fft holds real fields only.
  return impl_->stencil ? impl_->fft3->describe() : impl_->fft->describe();
}
double FftRveSolver::achieved_volume_fraction() const { return impl_->achieved_vf; }
double FftRveSolver::planning_seconds() const {
  return (impl_->fft ? impl_->fft->planning_seconds() : 0.0) + (impl_->fft3 ? impl_->fft3->planning_seconds() : 0.0);
}
std::vector<double> FftRveSolver::displacement() { return impl_->node_displacement(); }
const fft::SlabDecomposition* FftRveSolver::slabs() const { return impl_->dist.get(); }
std::size_t FftRveSolver::memory_bytes() const {
  return detail::storage_total(detail::storage_list(impl_->storage_sizes()));
}
std::vector<std::pair<std::string, std::size_t>> FftRveSolver::memory_breakdown() const {
  return detail::storage_list(impl_->storage_sizes());
}
std::size_t FftRveSolver::planned_memory_bytes() const { return impl_->planned_bytes(); }

FftRveState FftRveSolver::state() const {
  const Impl& m = *impl_;
  FftRveState s;
  s.F = m.Fbar_committed;
  s.u = m.u_committed;
  s.history_matrix = m.hist_old[0];
  s.history_fiber = m.hist_old[1];
  s.laminate = m.lam_a;
  s.du_last.assign(m.du_last.begin(), m.du_last.end());
  s.dF_last = m.dF_last;
  s.dt_last = m.dt_last;
  return s;
}

void FftRveSolver::set_state(const FftRveState& s) {
  Impl& m = *impl_;
  auto check = [](const char* what, std::size_t got, std::size_t want) {
    if (got != want)
      throw InputError("state", std::string(what) + " of " + std::to_string(got) + " values",
                       "this solver needs " + std::to_string(want) + " (a state of another grid or phases)");
  };
  check("u", s.u.size(), m.u.size());
  check("history_matrix", s.history_matrix.size(), m.hist_old[0].size());
  check("history_fiber", s.history_fiber.size(), m.hist_old[1].size());
  check("laminate", s.laminate.size(), m.lam_a.size());
  if (!s.du_last.empty()) check("du_last", s.du_last.size(), m.u.size());
  if (!s.F.allFinite() || !(s.F.determinant() > 0.0)) throw InputError("state.F", "", "not a deformation gradient (det F <= 0)");
  m.Fbar = m.Fbar_committed = s.F;
  m.u = m.u_committed = s.u;
  m.hist_old[0] = m.hist_new[0] = s.history_matrix;
  m.hist_old[1] = m.hist_new[1] = s.history_fiber;
  m.lam_a = m.lam_a_trial = s.laminate;
  m.du_last.assign(s.du_last.begin(), s.du_last.end());
  m.dF_last = s.dF_last;
  m.dt_last = s.dt_last;
}

FftRveSolver::MixedPressures FftRveSolver::mixed_pressures() const {
  const StateView v = state_view();
  return {{v.pressure.begin(), v.pressure.end()}, {v.pressure_increment.begin(), v.pressure_increment.end()}};
}

FftRveSolver::StateView FftRveSolver::state_view() const {
  const Impl& m = *impl_;
  StateView v;
  v.F = m.Fbar_committed;
  v.dF_last = m.dF_last;
  v.dt_last = m.dt_last;
  v.u = m.u_committed;
  v.du_last = m.du_last;
  v.history_matrix = m.hist_old[0];
  v.history_fiber = m.hist_old[1];
  v.laminate = m.lam_a;
  if (m.mixed_active) {
    v.pressure = m.p_committed;
    v.pressure_increment = m.dp_last;
  }
  return v;
}

void FftRveSolver::set_mixed_pressures(MixedPressures p) {
  Impl& m = *impl_;
  const std::size_t want = m.mixed_active ? m.p_committed.size() : 0;
  if (p.committed.empty() && p.increment.empty()) {
    // None saved (a state written without a mixed phase's pressures, e.g. before its kinematics had
    // one): the next run derives them at its start, as after a warm start.
    m.pending_pressures.reset();
    return;
  }
  if (p.committed.size() != want || p.increment.size() != want)
    throw InputError("state", "pressures of " + std::to_string(p.committed.size()) + " and " +
                                  std::to_string(p.increment.size()) + " points",
                     "this solver's mixed iteration has " + std::to_string(want));
  m.pending_pressures = std::move(p);
}

RveRunResult FftRveSolver::run(const MixedControl& control,
                               const std::function<void(const RveStep&, const RveFields*)>& on_step,
                               const std::function<bool(double)>& want_fields, double t_start) {
  control.validate();
  Impl& m = *impl_;
  const auto run_start = Clock::now();
  RveRunResult result;
  // The start state (t = 0: undeformed), evaluated so that phase sums and the reference are defined.
  m.linearized_pressure = false;
  if (m.evaluate_start() != MaterialStatus::ok)
    throw ConvergenceError(t_start == 0.0 ? "material call failed at F = I"
                                          : "material call failed at the start state (t = " + format_number(t_start) + ")");
  m.commit_pressures(false);
  if (m.pending_pressures) {
    // A continued run: the pressures the saved run carried, and the laminate vectors as committed (the
    // evaluation above iterated them once more from the committed ones).
    m.p_committed = std::move(m.pending_pressures->committed);
    m.dp_last = std::move(m.pending_pressures->increment);
    m.pending_pressures.reset();
    m.restore();
  }
  const double angle0 = fiber_angle_deg(Mat3::Identity(), m.a0_load);
  struct Engine {
    Impl& m;
    const MixedControl& control;
    double angle0;
    const std::function<void(const RveStep&, const RveFields*)>& on_step;
    const std::function<bool(double)>& want_fields;
    detail::SubstepOutcome step(double t_new, double dt) { return m.step(control, t_new, dt); }
    void commit(double dt) { m.commit(dt); }
    void restore() { m.restore(); }
    RveStep record(double t) const { return m.record(t, angle0); }
    void emit(const RveStep& s, double) {
      if (!on_step) return;
      if (want_fields && want_fields(s.t)) {
        const RveFields f = m.fields();
        on_step(s, &f);
      } else {
        on_step(s, nullptr);
      }
    }
  } engine{m, control, angle0, on_step, want_fields};
  m.krylov_seconds = 0.0;
  StepControlOptions steps;
  steps.max_cutbacks = m.opt.max_cutbacks;
  // Distributed: no wall-time budget (each rank's clock would decide the cut-backs on its own).
  steps.max_step_seconds = m.dist ? 0.0 : m.opt.max_step_seconds;
  detail::run_output_steps(control, steps, engine, result, run_start, t_start);
  result.krylov_seconds = m.krylov_seconds;
  return result;
}

Mat9 FftRveSolver::homogenized_tangent(double krylov_tolerance, RveCounts* counts) {
  Impl& m = *impl_;
  if (m.opt.scheme != FftScheme::newton_cg)
    throw InputError("solver.scheme", to_string(m.opt.scheme), "the homogenized tangent needs newton-cg (stored tangents)");
  const std::array<bool, 9> prescribed{};  // no free macro component: K_uu δũ = −Dᴴ A E
  std::array<bool, 9> all{};
  all.fill(true);                          // macro rows of K [δũ; E] = ⟨A (E + ∇δũ)⟩
  m.set_reference();
  const std::vector<int> no_free;
  const Eigen::MatrixXd no_macro(0, 0);
  KVec e{std::vector<Complex>(3 * m.NM, 0.0), Vec9::Zero()}, b{std::vector<Complex>(3 * m.NM), Vec9::Zero()};
  KVec x{std::vector<Complex>(3 * m.NM, 0.0), Vec9::Zero()}, y{std::vector<Complex>(3 * m.NM), Vec9::Zero()};
  m.cg_p.u.resize(3 * m.NM);
  if (!m.stencil) m.cg_z.u.resize(3 * m.NM);
  if (!m.stencil) m.cg_Ap.u.resize(3 * m.NM);
  Mat9 C = Mat9::Zero();
  int iterations = 0;
  for (int c = 0; c < 9; ++c) {
    e.f = Vec9::Unit(c);
    m.apply(e, prescribed, b);
    for (auto& v : b.u) v = -v;
    b.f.setZero();
    Impl::CgSpace space{m, prescribed, no_macro, no_free, 0.0};
    const krylov::CgResult res = krylov::pcg(space, b, x, m.cg_r, m.cg_z, m.cg_p, m.cg_Ap, m.krylov_controls(krylov_tolerance));
    iterations += res.iterations + 2;  // + the operator applications of the right-hand side and the average
    bool converged = res.converged;
    if (res.breakdown) {  // indefinite tangent field (past a bifurcation): MINRES, as the Newton step
      iterations += m.pminres(b, prescribed, krylov_tolerance, x, converged);
    }
    if (!converged)
      throw ConvergenceError("homogenized tangent: the linear cell problem of F̄ component " + std::to_string(c / 3 + 1) +
                             std::to_string(c % 3 + 1) + " did not converge in " +
                             std::to_string(m.opt.max_krylov_iterations) + " Krylov iterations");
    x.f = e.f;
    m.apply(x, all, y);
    C.col(c) = y.f;
  }
  if (counts) counts->krylov_iterations += iterations;
  return C;
}

FftRveSolver::DenseOperator FftRveSolver::dense_fluctuation_operator() {
  Impl& m = *impl_;
  const std::size_t n = 6 * m.NM;
  if (n > 4096 || m.dist)
    throw InputError("microstructure.grid", std::to_string(m.Ntot) + " voxels",
                     "the dense Newton operator is for one-process cells of at most 4096 unknowns");
  const std::array<bool, 9> prescribed{};
  DenseOperator out;
  out.K.resize(Eigen::Index(n), Eigen::Index(n));
  out.laplacian.resize(n);
  KVec e{std::vector<Complex>(3 * m.NM, 0.0), Vec9::Zero()}, y{std::vector<Complex>(3 * m.NM), Vec9::Zero()};
  for (std::size_t j = 0; j < n; ++j) {
    const std::size_t a = j / 2;
    out.laplacian[j] = m.op.laplacian(m.op.mode_offset() + a % m.NM);
    e.u[a] = j % 2 ? Complex(0.0, 1.0) : Complex(1.0, 0.0);
    m.apply(e, prescribed, y);
    e.u[a] = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t b = i / 2;
      const double w = m.grid.mode_weight(b % m.NM);
      out.K(Eigen::Index(i), Eigen::Index(j)) = w * (i % 2 ? y.u[b].imag() : y.u[b].real());
    }
  }
  return out;
}

}  // namespace softhom::rve
