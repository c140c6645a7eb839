#pragma once
// Finite-strain FFT homogenization of a periodic fiber cell (Fourier–Galerkin / FE-on-FFT Newton–Krylov,
// Moulinec–Suquet baseline) under the macroscopic mixed control of `softhom point`.
//
// Unknowns. The displacement fluctuation ũ (half spectrum, three components) and the free components
// of the macroscopic gradient F̄ in the load frame. Per material point (voxel × quadrature point q):
//   F_q = F̄_grid + ∇_q ũ,   F̄_grid = Rᵀ F̄_load R,
// with R = [g1 g2 g3] the grid axes in load-frame coordinates (grid_rotation()). The Newton system is
//   [ Dᴴ A D    Dᴴ A B ] [δũ]     [ Dᴴ P            ]
//   [ Bᵀ A D    Bᵀ A B ] [δf ] = − [ mask(⟨P⟩_load − P*) ]
// (B: uniform field Rᵀ E R of a free load-frame component E), symmetric, solved by preconditioned CG.
// The preconditioner is the exact inverse of the same system for a homogeneous reference medium C0
// (the volume-averaged current tangent): block-diagonal, 3×3 per Fourier mode plus the macro block —
// the FE-based reference preconditioner of Ladecký et al. 2023 when the discretization is "hex". Where
// the phases' bulk moduli spread much further than their shear moduli (a nearly incompressible matrix
// around compressible fibers) the rotated scheme's reference medium takes each voxel's own bulk modulus
// instead, still inverted exactly (Preconditioner::green_local_bulk, rve/src/fft_local_bulk.hpp).
// CG vectors live in Fourier space (the preconditioner is local there); for rotated/hex the operator
// K p is applied with real-space stencils (KrylovOperator::stencil): p̂ → 3 fields back, ∇p, δP = A:(δF̄
// + ∇p) and the nodal forces Bᵀ δP in real space (gather, no write races), 3 fields forward. Tangents
// are then stored in blocks of 8 points (SIMD across points).
// Prescribed load increments enter through the tangent predictor (first Newton iteration linearised
// at the previous converged state), so steps are warm-started and the fibers are not loaded
// homogeneously.
//
// Composite voxels (0 < fiber fraction < 1) use the laminate rule with the voxel's interface normal n:
// F_f = F + (1−φ) a⊗n, F_m = F − φ a⊗n, traction continuity (P_f − P_m) n = 0 solved per point by
// Newton, P = φ P_f + (1−φ) P_m, tangent by static condensation.
//
// Section grids (n3 = 1) solve the straight-fiber cell with full 3D kinematics: ũ depends on (y1, y2)
// only but has three components, F̄ is a full 3×3 tensor.
#include <complex>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "softhom/fft/gradient.hpp"
#include "softhom/fft/plan.hpp"
#include "softhom/materials/loading.hpp"
#include "softhom/materials/material.hpp"
#include "softhom/rve/geometry.hpp"

namespace softhom::rve {

enum class FftScheme { newton_cg, moulinec_suquet };
/// Reference medium of the preconditioner: mean_tangent = symmetrized volume average of the current
/// tangents; geometric = isotropic medium with the geometric means of the phases' current bulk and
/// shear moduli (isotropic projections of the phase-mean tangents), which centres the spectrum when one
/// phase is stiffer in shear and the other in bulk (glass in ecoflex); isotropic = the fixed
/// Moulinec–Suquet choice from the initial moduli.
enum class ReferenceMedium { mean_tangent, isotropic, geometric };
/// Form of the Krylov operator K p = Dᴴ A (δF̄ + D p) of the Newton–CG scheme (same values to round-off):
/// stencil = the rotated/hex gradient and its adjoint as local stencils in real space, 3 displacement
/// fields transformed back and 3 nodal-force fields forward per iteration (fft/stencil.hpp); fourier =
/// gradient and divergence per Fourier mode, 9·nq stress/strain fields transformed (6·nq on sections).
/// The spectral discretization has no local stencil and always takes the Fourier form.
enum class KrylovOperator { stencil, fourier };
/// What the Newton–CG solver does when CG meets negative curvature near the solution (see
/// FftSolverOptions::indefinite_solver).
enum class IndefiniteSolver { minres, shift };
/// Tangents of the composite points in the Newton operator (FftSolverOptions::composite_tangent).
enum class CompositeTangent { exact, projected };
/// Preconditioner of the Newton–CG linear solves (FftSolverOptions::preconditioner).
enum class Preconditioner { automatic, green, jacobi_green, green_local_bulk };
/// Storage of the tangents read by the stencil Krylov operator (FftSolverOptions::tangent_precision).
enum class TangentPrecision { double_precision, single_precision };
/// Volumetric kinematics of the quadrature points (FftSolverOptions::volumetric).
enum class VolumetricKinematics { pointwise, mean_dilatation };
const char* to_string(FftScheme s);
const char* to_string(ReferenceMedium r);
const char* to_string(KrylovOperator k);
/// "double" | "single".
const char* to_string(TangentPrecision t);
/// "auto" | "green" | "jacobi-green" | "green-local-bulk".
const char* to_string(Preconditioner p);
/// Preconditioner::automatic takes the local bulk when max K / min K ≥ this × max G / min G.
constexpr double kLocalBulkSpreadRatio = 3.0;
/// "pointwise" | "mean-dilatation".
const char* to_string(VolumetricKinematics v);

struct FftSolverOptions {
  fft::Discretization discretization = fft::Discretization::rotated;
  FftScheme scheme = FftScheme::newton_cg;
  ReferenceMedium reference = ReferenceMedium::mean_tangent;
  /// Newton/fixed point: RMS of the incompatible part of P (Σ_k |Dᴴ P̂|²/|D|²)^½ and the macro stress
  /// error, both relative to max(max|P̄_ij|, 1e-6 G_min).
  double tolerance = 1e-7;
  /// Relative (preconditioned-norm) tolerance of each linear solve; 0: adaptive forcing term
  /// η = clamp(max(min(1e-2, err), 0.1 tol / err), 1e-12, 0.1) (Eisenstat–Walker-like).
  double krylov_tolerance = 0.0;
  int max_newton_iterations = 30;
  int max_krylov_iterations = 5000;
  int max_fixed_point_iterations = 20000;
  int max_cutbacks = 12;         ///< a step may be halved this many times
  /// Pseudo-transient continuation when Newton stagnates (a fold or bifurcation of the cell, e.g. the
  /// micro-buckling of fibers in compression: the equilibrium branch of the last step ends and Newton
  /// stalls at a non-zero residual minimum): the iteration continues as
  /// (K + δ K0) Δx = −r, accepted without a residual decrease, with δ following the residual (switched
  /// evolution relaxation), i.e. a damped descent toward the nearest stable equilibrium, ending in
  /// Newton's quadratic convergence (δ → 0) there. This many iterations at most; 0 (default) disables:
  /// measured on the ecoflex compression cells that stall past micro-buckling, it converges some
  /// sub-steps (23–99 iterations) but not the run (the stall sits at a residual floor ≈ 1e-6, not at a
  /// fold), and switched on by default it slowed ordinary Newton stalls (357 vs 132 Newton at K/G = 1.2e5).
  int max_continuation_iterations = 0;
  /// Negative curvature in CG at a Newton residual below `minres_below` means an indefinite tangent at
  /// the equilibrium: the cell is past a bifurcation (fiber micro-buckling in compression) and the
  /// principal (unbuckled) branch it is on is unstable. `minres` solves the Newton step as it is
  /// (preconditioned MINRES): Newton converges on the principal branch — the solution of the
  /// imperfection-free problem, as an implicit FE code follows it — and each such step is logged as
  /// unstable. `shift` takes Levenberg–Marquardt steps (K + μ K0) instead, which drift off the principal
  /// branch onto a buckled one where they can (ecoflex circle VF 0.23, α = 45°: F31 → −0.17 and 7 % lower
  /// |P11| at λ = 0.6, 599 Newton / 167 s against 113 / 8 s) and may stall at the bifurcation point
  /// (α = 60°, 32²), where `minres_fallback` then finishes the step with MINRES. Farther from the solution
  /// negative curvature is a transient of the iteration (pressure errors of a nearly incompressible
  /// matrix) and is always shifted.
  IndefiniteSolver indefinite_solver = IndefiniteSolver::minres;
  double minres_below = 1e-3;
  /// With `shift`: when the shifted Newton iteration stalls (max_newton_iterations reached at a
  /// residual below minres_below), continue the step for max_newton_iterations more with MINRES.
  bool minres_fallback = true;
  /// Mixed (u, p) Newton iteration in phases with K ≥ mixed_pressure_ratio · G (Newton–CG only): the
  /// pressure is carried linearized between iterations, so the Newton steps are not limited by the
  /// O(K θ²) volumetric error of finite rotations θ. Same converged solution as the plain iteration.
  bool mixed_pressure = true;
  double mixed_pressure_ratio = 100.0;
  /// The tangents of the composite points in the Newton operator: their laminate's own (`exact`), or
  /// with its negative eigenvalues set to 0 (`projected`). The laminate carries its law's pressure, not
  /// the mixed iteration's, and far from equilibrium its tangent is indefinite at thousands of points
  /// of a fine grid: too few to turn CG's curvature negative, enough to make the direction useless
  /// there. Projected, the 128³ inclined cell's first step to λ = 1.075 converges in one attempt (17 /
  /// 2 163 Newton / Krylov against 53 / 4 556 with a cut-back), but where the indefiniteness is
  /// physical (fibers buckling under compression) the step is no longer a Newton step and the cell does
  /// not converge (BENCHMARKS.md, "Iteration cost and solver options": the shifted first solve). The residual
  /// is always the true one: the converged state does not depend on this choice.
  CompositeTangent composite_tangent = CompositeTangent::exact;
  KrylovOperator krylov_operator = KrylovOperator::stencil;
  /// Tangents of the stencil Krylov operator stored in float (180 instead of 360 B per point, the
  /// default: the largest array of the solver, see BENCHMARKS.md "FFT memory per voxel"): the Krylov
  /// iteration is bound by that stream. With them the reference Green table of the preconditioner is
  /// float too (24 instead of 48 B per mode; any symmetric positive definite preconditioner leaves the
  /// solution as it is). The residual, the material and all arithmetic stay double, so the converged
  /// answer is the same to the Newton tolerance; the Krylov operator is the exact one perturbed by
  /// ≈ 6e-8 relative per tangent entry (symmetric, so CG/MINRES still apply), which inexact Newton
  /// absorbs. The Fourier operator always keeps double.
  TangentPrecision tangent_precision = TangentPrecision::single_precision;
  /// With single-precision tangents (stencil operator, green preconditioner): the pure points of phases
  /// whose law has a compact linearization (Material::has_compact_linearization: isotropic laws in
  /// (I1, J)) store F and five scalars (56 B) instead of the packed 9×9 tangent (180 B), and the Krylov
  /// operator forms δP from them on the fly (rve/src/compact_tangents.hpp). Composite points and other
  /// laws keep the stored tangent. The same operator to float rounding.
  bool compact_tangent = true;
  /// Verification, not a scene key: the mixed (u, p) iteration recomputes the last accepted iterate's
  /// pressure linearization before every line-search trial, not only after a rejected one (it keeps one
  /// linearization per point, which each trial overwrites). With a right restore both give the same
  /// iterates bit for bit; the tests compare them.
  bool relinearize_every_trial = false;
  /// Streamed evaluation where it applies (one process, rotated, stencil operator, elastic phases): the
  /// material evaluation inside the stencil pass, no 9-field buffer (72 B per voxel). false: the stored
  /// 9-field path, for the tests that compare the two (same iterates to round-off).
  bool stream_evaluation = true;
  /// green: the reference-medium Green operator K0⁻¹ per Fourier mode (CG on spectra), the default.
  /// jacobi_green: S K0⁻¹ S with S the real-space diagonal scaling (D0/D)^½ of the stencil operator's
  /// node diagonal D (rve/src/fft_preconditioner.hpp), CG on nodal fields, the same two 3-field
  /// transforms per iteration (+0–10 % time). Measured on the glass/ecoflex cells it takes more
  /// iterations than green (8–15× at K/G = 1.2e5, growing with the grid; 1.1–1.8× with a compressible
  /// matrix, rotated and hex) and fewer only on a small 3D hex cell (BENCHMARKS.md, "FFT solver cost"):
  /// the node diagonal of a nearly incompressible matrix is its bulk stiffness, which the scaling then
  /// equalises instead of the shear stiffness.
  /// Stencil operator only (otherwise green); Levenberg–Marquardt-shifted solves, MINRES and the
  /// homogenized tangent's solves use green.
  /// green_local_bulk: the Green operator of an isotropic medium at F̄ with a homogeneous shear modulus
  /// and each voxel's own bulk modulus (rve/src/fft_local_bulk.hpp), exact in the dilatation modes; one
  /// scalar transform pair more per iteration and 12.5 B per voxel. Rotated, stencil operator only.
  /// automatic (the default): green_local_bulk where it applies and the phases' bulk moduli spread at
  /// least kLocalBulkSpreadRatio times as far as their shear moduli (PDMS/glass: 240 against 5.9), else
  /// green (BENCHMARKS.md, "FFT solver cost").
  Preconditioner preconditioner = Preconditioner::automatic;
  /// pointwise: every quadrature point deforms with its own F_q. mean_dilatation (discretization hex,
  /// Newton–CG with the stencil operator): every point of a voxel sees the voxel's volume ratio,
  /// F̄_q = (J̄/J_q)^{1/3} F_q with J̄ the voxel mean of J_q, in the variationally consistent form (the
  /// energy Σ w_q W(F̄_q), its exact gradient and Hessian; Q1/P0 for decoupled laws, one pressure per
  /// voxel; rve/src/fft_mean_dilatation.hpp). The hex scheme then no longer locks with a nearly
  /// incompressible matrix and converges to the FE answer under transverse load, where rotated does not
  /// (BENCHMARKS.md, "FFT solver cost"). With `mixed_pressure` its nearly incompressible phases carry
  /// one pressure per voxel through the Newton iteration, linearized in the voxel's volume ratio.
  VolumetricKinematics volumetric = VolumetricKinematics::pointwise;
  /// Wall-time budget of one output step's cut-backs [s] (StepControlOptions::max_step_seconds; 0: none).
  double max_step_seconds = 0.0;
  fft::PlanOptions plan;         ///< FFTW rigor, threads, wisdom cache
  /// Distribute the cell over the ranks of MPI_COMM_WORLD (FFTW-MPI slabs of i3, fft/slab.hpp) when MPI
  /// is active with more than one rank; with one rank (or MPI inactive) the one-process solver runs, bit
  /// for bit. 3D grids only, with at least one plane i3 per rank (else InputError on microstructure.grid).
  bool distributed = false;
  /// Called after each Newton iteration's evaluation (Newton–CG), on every rank: the sub-step's target
  /// time, the iteration (0: the predictor), its relative residual (the tolerance's measure) and the
  /// sub-step's Krylov iterations so far. Progress within the long steps of large cells; not a scene
  /// key. Empty: not called.
  std::function<void(double t_new, int iteration, double residual, int krylov_iterations)> on_newton_iteration;
};

/// Grid axes in load-frame coordinates for a fiber at in-plane angle α (spec §7): g3 = a =
/// (sin α, cos α, 0) (fiber axis), g1 = (cos α, −sin α, 0), g2 = g3 × g1 = −e3 (right-handed).
Mat3 grid_rotation(double fiber_angle_deg);

/// Iteration counters of the RVE engines: of one sub-step attempt, summed over the sub-steps of an
/// output step (RveStep) and over the run (RveRunResult).
struct RveCounts {
  int newton_iterations = 0;           ///< fixed-point iterations for Moulinec–Suquet
  int krylov_iterations = 0;
  int substeps = 0;                    ///< converged sub-steps
  int cutbacks = 0;                    ///< failed sub-steps
  int shifted_solves = 0;              ///< Levenberg–Marquardt retries of indefinite linear solves
  int minres_solves = 0;               ///< indefinite linear solves by MINRES (FftSolverOptions::indefinite_solver)
  int discarded_krylov_iterations = 0; ///< of krylov_iterations: in linear solves abandoned at negative curvature
  int continuation_iterations = 0;     ///< pseudo-transient iterations (FftSolverOptions::max_continuation_iterations)
  RveCounts& operator+=(const RveCounts& o) {
    newton_iterations += o.newton_iterations;
    krylov_iterations += o.krylov_iterations;
    substeps += o.substeps;
    cutbacks += o.cutbacks;
    shifted_solves += o.shifted_solves;
    minres_solves += o.minres_solves;
    discarded_krylov_iterations += o.discarded_krylov_iterations;
    continuation_iterations += o.continuation_iterations;
    return *this;
  }
};

/// One converged output step, everything in the load frame; its counts are over the sub-steps of
/// this output step (failed attempts included).
struct RveStep : RveCounts {
  double t = 0.0;
  Mat3 F = Mat3::Identity(), P = Mat3::Zero(), sigma = Mat3::Zero();
  Mat3 P_matrix = Mat3::Zero(), P_fiber = Mat3::Zero();          ///< phase means over reference volume
  Mat3 sigma_matrix = Mat3::Zero(), sigma_fiber = Mat3::Zero();  ///< phase means over current volume
  double fiber_angle_deg = 0.0;        ///< of the mean fiber-phase F applied to a0 (spec §7)
  double fiber_angle_change_deg = 0.0; ///< relative to t = 0
  std::vector<double> residuals;       ///< Newton residual history of the last sub-step
  double wall_seconds = 0.0;
};

/// Per-voxel fields of a converged step (quadrature points averaged), load frame, 9 per voxel row-major;
/// displacement per voxel corner (3 per node of the (n1+1)(n2+1)(n3+1) corner grid, y1 fastest, grid
/// frame: u = (F̄_grid − I) y + ũ, so a viewer can warp the cell), see FftRveSolver::displacement().
struct RveFields {
  std::vector<double> F, P, sigma, von_mises, fiber_fraction;
  std::vector<double> displacement;
};

/// How a run ended early (none when it completed).
enum class RveStop { none, failed, fatal, time_budget, interrupted };  /// fatal: a phase at its material limit, an inverted cell

/// A run; its counts are totals over all sub-step attempts.
struct RveRunResult : RveCounts {
  std::vector<RveStep> steps;   ///< t = 0 row first
  bool completed = false;
  RveStop stop = RveStop::none; ///< why a run that did not complete ended (interrupted: a signal)
  std::string error;
  std::vector<std::string> log;
  double wall_seconds = 0.0;
  double krylov_seconds = 0.0;  ///< of wall_seconds: in the linear solves (cost per Krylov iteration)
};

/// Converged state of an FftRveSolver: everything its next load step depends on. `run` starts from
/// the solver's current state (F = I after construction, else the end of the previous run or the state
/// given to set_state), so a run continued from a saved state repeats the continuation of the solver
/// that saved it operation for operation (warm starts of campaign neighbours, restarts). The pressures
/// of the mixed (u, p) iteration are not part of it: every run re-derives them from F at its start.
struct FftRveState {
  Mat3 F = Mat3::Identity();                  ///< macro gradient F̄, load frame
  std::vector<fft::Complex> u;                ///< fluctuation spectrum ũ (3 × modes)
  std::vector<double> history_matrix, history_fiber;  ///< internal variables per material point
  std::vector<double> laminate;               ///< jump vectors of the composite points (3 each)
  std::vector<fft::Complex> du_last;          ///< last converged increment (extrapolation predictor)
  Mat3 dF_last = Mat3::Zero();
  double dt_last = 0.0;
};

}  // namespace softhom::rve
namespace softhom::fft {
class SlabDecomposition;
}
namespace softhom::rve {

class FftRveSolver {
 public:
  /// `image` in the grid frame; `matrix`/`fiber` in the global frame of `control.frame` (they are
  /// rotated into the grid frame internally); `fiber_angle_deg` places the grid in the load frame.
  FftRveSolver(const PhaseImage& image, MaterialPtr matrix, MaterialPtr fiber, double fiber_angle_deg,
               const Mat3& load_frame, const FftSolverOptions& options = {});
  ~FftRveSolver();
  FftRveSolver(const FftRveSolver&) = delete;
  FftRveSolver& operator=(const FftRveSolver&) = delete;

  /// Runs the control. `want_fields(t)` (optional) says whether fields are wanted at an output time;
  /// `on_step` is called after each converged output step with its fields when wanted (else null).
  /// `t_start` > 0 continues a run: the current state (set_state, set_mixed_pressures) is the one
  /// converged at that output time of `control`, and the run takes the output steps after it (no
  /// t = 0 row). With the state and pressures a run saved there it repeats that run's continuation
  /// operation for operation.
  RveRunResult run(const MixedControl& control,
                   const std::function<void(const RveStep&, const RveFields*)>& on_step = {},
                   const std::function<bool(double)>& want_fields = {}, double t_start = 0.0);

  /// The converged (committed) state, e.g. at the end of a run.
  FftRveState state() const;
  /// Makes `s` the current state (a state of a solver with the same grid, phases and options);
  /// throws InputError("state", ...) when its sizes do not fit this solver.
  void set_state(const FftRveState& s);

  /// The mixed (u, p) iteration's pressures at the converged state, one per point of a mixed phase's
  /// pure points (float, as the solver keeps them; both empty without a mixed phase): the committed
  /// pressure and its last increment, which places the next step's extrapolated predictor. Not part
  /// of FftRveState, whose warm starts re-derive them; a restart that must repeat the saved run
  /// exactly carries them too.
  struct MixedPressures {
    std::vector<float> committed, increment;
  };
  MixedPressures mixed_pressures() const;
  /// The converged state's arrays as the solver holds them, without a copy (valid until the solver
  /// runs or takes another state): what a checkpoint writes, at no extra memory. du_last in float,
  /// as kept; the pressures as mixed_pressures() (empty without a mixed phase).
  struct StateView {
    Mat3 F, dF_last;
    double dt_last = 0.0;
    std::span<const fft::Complex> u;
    std::span<const std::complex<float>> du_last;
    std::span<const double> history_matrix, history_fiber, laminate;
    std::span<const float> pressure, pressure_increment;
  };
  StateView state_view() const;
  /// Given to the next run, which takes them after its evaluation of the start state instead of the
  /// pressures it derives there; throws InputError("state", ...) when their sizes do not fit. Both
  /// empty: the next run derives them (a checkpoint saved without them).
  void set_mixed_pressures(MixedPressures p);

  const fft::Grid& grid() const;
  int quadrature_points() const;
  std::string fft_description() const;
  /// The preconditioner of the Newton–CG solves (Preconditioner::automatic resolved).
  Preconditioner preconditioner() const;
  double achieved_volume_fraction() const;
  /// Bytes of the solver's large arrays (fields, tangents, history, FFT buffers, spectral vectors) as
  /// a run holds them: the sum of memory_breakdown().
  std::size_t memory_bytes() const;
  /// The same by array ("fft_buffers", "tangents", "spectral_vectors", ...; arrays a scene does not
  /// need are absent).
  std::vector<std::pair<std::string, std::size_t>> memory_breakdown() const;
  /// The estimate the constructor compared with the available memory (composite arrays not counted).
  std::size_t planned_memory_bytes() const;
  /// Seconds spent planning FFTs (FFTW_MEASURE) at construction.
  double planning_seconds() const;
  /// Displacement of the current state at the voxel corners (layout of RveFields::displacement): the
  /// macro part (F̄_grid − I) y plus the periodic fluctuation ũ, transformed from its spectrum. Uses
  /// the solver's FFT buffers (call between runs or from on_step, not concurrently with a run).
  std::vector<double> displacement();
  /// The slabs of a distributed solver (FftSolverOptions::distributed over more than one rank), else null.
  /// Then the fields of on_step, displacement() and state() are this rank's slab: the cells of its planes
  /// i3, the corner nodes of its planes i3 (the last rank's also those of the plane i3 = n3).
  const fft::SlabDecomposition* slabs() const;

  /// Homogenized consistent tangent C̄ = ∂P̄/∂F̄ (9×9, load frame, row-major components 3 i + j:
  /// C̄(a, b) = ∂P̄_a/∂F̄_b, MPa) of the current state, every macro component taken as prescribed, by
  /// the solver's own linearization: for each unit perturbation E = e_b the linearized cell problem
  /// Dᴴ A (E + D δũ) = 0 is solved with the stored tangent field A of the last converged Newton
  /// iterate and the Newton step's preconditioner (reference Green operator), and C̄ e_b = ⟨A : (E +
  /// ∇δũ)⟩. Valid right after a run that completed with the Newton–CG scheme (the tangents are those of
  /// its last sub-step, with that sub-step's Δt for laws with history); a mixed-control tangent follows
  /// by static condensation of C̄. `krylov_tolerance`: relative tolerance of each of the 9 linear solves
  /// (preconditioned norm); their iterations are added to `counts` (krylov_iterations) when given.
  /// Uses the solver's FFT buffers (fields of the run are no longer available afterwards).
  /// Throws InputError("solver.scheme") for Moulinec–Suquet (no tangents are stored) and
  /// ConvergenceError when a linear solve does not converge.
  Mat9 homogenized_tangent(double krylov_tolerance = 1e-10, RveCounts* counts = nullptr);

  /// The Newton operator K_uu of the fluctuation (every macro component prescribed) with the stored
  /// tangent field of the last Newton iterate, assembled densely for small cells (eigen-analysis of the
  /// stability of a converged state): K(i, j) = ⟨e_i, K_uu e_j⟩ in the inner product of the Krylov space
  /// (half spectrum with mode weights), basis e_{2a} = real and e_{2a+1} = imaginary unit of spectral
  /// entry a = c·modes + k; `laplacian[i]` = |D_k|² of its mode (0 for the mean mode, large at the
  /// grid's Nyquist frequencies). Its inertia is that of K_uu (Sylvester), apart from zero rows of the
  /// mean and of the imaginary parts of self-conjugate modes. InputError("microstructure.grid") above
  /// 4096 unknowns; one process only.
  struct DenseOperator {
    Eigen::MatrixXd K;
    std::vector<double> laplacian;
  };
  DenseOperator dense_fluctuation_operator();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace softhom::rve
