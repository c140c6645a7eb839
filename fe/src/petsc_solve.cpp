// The PETSc linear solver (petsc_solve.hpp): distributed tangent, GMRES + GAMG with the rigid-body
// near-nullspace, and PETSc's life cycle.
#include "petsc_solve.hpp"
#include "petsc_check.hpp"
#include "petsc_direct_fill.hpp"
#include "petsc_nest.hpp"
#include "petsc_p_multigrid.hpp"
#include "petsc_subdomains.hpp"

#include <petscksp.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <stdexcept>

#include "softhom/materials/errors.hpp"

namespace softhom::fe {
namespace {

bool g_initialised = false, g_finalised = false;
PetscMatrixBytes g_matrix_bytes;  // of the last PetscSolver's first set-up (account_matrices)

constexpr auto check = petsc_check;

double petsc_seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// PETSc's own message of the first error raised while it lives (PETSc's handler prints it to stderr with
/// a traceback; this one keeps it for the error softhom reports).
class PetscErrorCapture {
 public:
  PetscErrorCapture() { PetscPushErrorHandler(&PetscErrorCapture::keep, this); }
  ~PetscErrorCapture() { PetscPopErrorHandler(); }
  PetscErrorCapture(const PetscErrorCapture&) = delete;
  PetscErrorCapture& operator=(const PetscErrorCapture&) = delete;
  const std::string& message() const { return message_; }

 private:
  static PetscErrorCode keep(MPI_Comm, int, const char*, const char*, PetscErrorCode code, PetscErrorType, const char* mess,
                             void* self) {
    std::string& m = static_cast<PetscErrorCapture*>(self)->message_;
    if (m.empty() && mess) m = mess;
    return code;
  }
  std::string message_;
};

/// Runs `setup`, a step in which PETSc reads the options database (its objects read their options when
/// they are set up). A failure there with options of the user's is reported as an input error naming
/// them and PETSc's message (e.g. "Unknown logical value: 10"); without any it stays a runtime error,
/// with PETSc's message.
template <class Setup>
void set_up_with_options(const std::string& options, Setup setup) {
  PetscErrorCapture capture;
  try {
    setup();
  } catch (const std::runtime_error& e) {
    if (options.empty()) throw std::runtime_error(capture.message().empty() ? std::string(e.what()) : e.what() + (": " + capture.message()));
    throw InputError("solver.petsc_options", options,
                     "PETSc cannot set up its solver with these options: " +
                         (capture.message().empty() ? std::string(e.what()) : capture.message()));
  }
}

/// Settings of the field split's blocks, inserted before the user's options (which override them):
/// the displacement block by one V-cycle of BoomerAMG (on the tube and Cook's membrane 1.2–1.7× fewer
/// iterations than GAMG with the rigid-body modes and flatter over the mesh, BENCHMARKS.md), the Schur
/// complement by the inverse of its diagonal approximation (Data::augmentation). BoomerAMG's own
/// defaults (Falgout coarsening, strong threshold 0.25) suit 2D scalar problems: on 3D hex8 elasticity
/// their hierarchy has operator complexity ~4.8, and HMIS coarsening with threshold 0.7, ext+i
/// interpolation truncated to 4 entries and one level of aggressive coarsening costs 2.4–3× less CPU
/// per Newton iteration on the helix tube for 1.3–1.7× more GMRES iterations (the settings of the tuned
/// tet10 device scenes, BENCHMARKS.md).
constexpr const char* kSplitDefaults =
    "-fieldsplit_u_ksp_type preonly -fieldsplit_u_pc_type hypre -fieldsplit_u_pc_hypre_type boomeramg "
    "-fieldsplit_u_pc_hypre_boomeramg_coarsen_type HMIS -fieldsplit_u_pc_hypre_boomeramg_strong_threshold 0.7 "
    "-fieldsplit_u_pc_hypre_boomeramg_interp_type ext+i -fieldsplit_u_pc_hypre_boomeramg_P_max 4 "
    "-fieldsplit_u_pc_hypre_boomeramg_agg_nl 1 "
    "-fieldsplit_p_ksp_type preonly -fieldsplit_p_pc_type jacobi "
    // MUMPS (-pc_factor_mat_solver_type mumps, the default under cavity control) ordered by METIS: on the
    // 5.3e4-dof tube 25 % less factorization time than MUMPS's automatic choice (BENCHMARKS.md).
    "-mat_mumps_icntl_7 5";

/// The displacement block's two-level p-multigrid ([solver] petsc_p_multigrid, petsc_p_multigrid.hpp), inserted after
/// kSplitDefaults and before the user's options again. The P1 Galerkin block keeps three components per
/// vertex (block size 3, which PETSc hands to hypre as three functions: strength and interpolation per
/// displacement component) and carries the vertices' rigid-body modes; it gets the BoomerAMG settings of
/// the P2 block above with Chebyshev relaxation and two V-cycles per application. Measured on the cPASMO
/// 0.5 mesh (ten steps to 6 kPa) and a 9.8e4-dof gripper (three steps), GMRES iterations: scalar
/// BoomerAMG on the free components (the previous default) 1984 and 1305, BoomerAMG with the three
/// functions 1651 and 829, GAMG with the rigid-body modes (two V-cycles) 1678 and 544 (BENCHMARKS.md, "A
/// coarse space with rotations"). GAMG is best on the bending gripper, whose fine scenes select it, but
/// on the fine cPASMO on 2 ranks its counts jumped from ≈ 60 to ≈ 190 per solve at the eighth load step,
/// so BoomerAMG stays the default. The coarse solve is ≈ 1/6 of a displacement solve's cost, and a weak
/// one is most of what makes the counts grow with the load. The P2 level gets one Chebyshev sweep on its
/// diagonal before and after the coarse correction (two sweeps: 3 % fewer GMRES iterations for 1.4× the
/// CPU time on the cPASMO 0.5 mesh); an anisotropic tangent changes that (choose_fine_smoother). With
/// that coarse solve the upper Schur factorization (one displacement solve per GMRES iteration instead
/// of two) pays: 1.22× the iterations for 0.78× the wall time over the cPASMO's ten steps. Its longer
/// solves (up to 158 iterations on the 1.2e6-dof mesh) are what set the GMRES basis's memory there
/// (6 MB per vector and rank), so the restart is capped at 100.
constexpr const char* kPMultigridDefaults =
    "-fieldsplit_u_pc_type mg -fieldsplit_u_pc_mg_levels 2 -fieldsplit_u_pc_mg_galerkin both "
    "-fieldsplit_u_mg_levels_ksp_type chebyshev -fieldsplit_u_mg_levels_pc_type jacobi -fieldsplit_u_mg_levels_ksp_max_it 1 "
    "-fieldsplit_u_mg_coarse_ksp_type preonly -fieldsplit_u_mg_coarse_pc_type hypre -fieldsplit_u_mg_coarse_pc_hypre_type boomeramg "
    "-fieldsplit_u_mg_coarse_pc_hypre_boomeramg_coarsen_type HMIS -fieldsplit_u_mg_coarse_pc_hypre_boomeramg_strong_threshold 0.7 "
    "-fieldsplit_u_mg_coarse_pc_hypre_boomeramg_interp_type ext+i -fieldsplit_u_mg_coarse_pc_hypre_boomeramg_P_max 4 "
    "-fieldsplit_u_mg_coarse_pc_hypre_boomeramg_agg_nl 1 -fieldsplit_u_mg_coarse_pc_hypre_boomeramg_relax_type_all Chebyshev "
    "-fieldsplit_u_mg_coarse_pc_hypre_boomeramg_max_iter 2 -pc_fieldsplit_schur_fact_type upper -ksp_gmres_restart 100";
/// BDDC ([solver] petsc_preconditioner = "bddc", set by PCSetType) on the element partition's subdomains,
/// inserted under the user's options. Primal constraints on the subdomains' vertices, edges and faces,
/// each made a primal unknown by a change of basis (without it the Neumann problem of a subdomain that
/// touches no support keeps the rotations its edge averages do not fix: Cook's membrane on 4 ranks
/// diverged). On every edge and face the constraints are the restrictions of a near-nullspace, all three
/// components together (monolithic): the rigid-body modes and the flux of the volume change
/// (set_bddc_constraints). Near incompressibility wants the flux: the averages alone leave a subdomain's
/// net volume change to the local solves, and they are only a normal flux where a face is flat (never on
/// the staircase faces of a partition of elements). Against the per-component averages they cut the
/// counts 1.2–1.5× on Cook's membrane and 1.6× on 64 subdomains (BENCHMARKS.md, "Macro solver on PETSc", BDDC). Deluxe
/// scaling; the subdomain problems factorized by MUMPS, whose pivoting the K/G = 1e5 matrices need
/// (PETSc's own LU took 33.8 GMRES iterations per solve on the 7 785-dof tube where MUMPS takes 12.1).
/// The primal basis is built as for a symmetric matrix (PCBDDC's default) although the follower-pressure
/// tangent is not: its unsymmetric part is a surface term, and the unsymmetric construction
/// (-pc_bddc_symmetric 0) took more iterations (the 7 785-dof tube: 15.4 / 15.2 per solve at K/G 1e2 /
/// 1e5 against 9.9 / 12.1).
constexpr const char* kBddcDefaults =
    "-pc_bddc_use_faces -pc_bddc_use_change_of_basis -pc_bddc_use_change_on_faces -pc_bddc_use_deluxe_scaling "
    "-pc_bddc_monolithic -pc_bddc_use_nnsp "
    "-pc_bddc_neumann_pc_factor_mat_solver_type mumps -pc_bddc_dirichlet_pc_factor_mat_solver_type mumps";
/// Above this geometric-mean spread of the nodal 3 × 3 blocks (nodal_block_spread) the P2 level gets
/// two Chebyshev sweeps instead of one. (Calibrated in BENCHMARKS.md, "Device scenes": the fiber blocks on the p-multigrid.)
constexpr double kAnisotropicBlockSpread = 3.0;

/// The three translations and three rotations of the nodes at `coords` (x y z per node: this rank's
/// nodes, in the order of its rows): elasticity's near-nullspace, which smoothed aggregation needs in
/// its coarse spaces (without the rotations it sees a scalar Laplacian per component, and bending parts
/// defeat it). `global`: the whole length, or PETSC_DECIDE. Collective.
MatNullSpace rigid_body_modes(MPI_Comm comm, std::vector<double>& coords, PetscInt global = PETSC_DECIDE) {
  Vec xyz = nullptr;
  petsc_check(VecCreateMPIWithArray(comm, 3, PetscInt(coords.size()), global, coords.data(), &xyz), "VecCreateMPIWithArray (coordinates)");
  MatNullSpace modes = nullptr;
  petsc_check(MatNullSpaceCreateRigidBody(xyz, &modes), "MatNullSpaceCreateRigidBody");
  VecDestroy(&xyz);
  return modes;
}

}  // namespace

void petsc_initialize() {
  if (g_initialised) return;
  int mpi_up = 0;
  MPI_Initialized(&mpi_up);
  // PETSc's own handler would print to stderr and abort on signals; softhom handles its signals itself.
  check(PetscInitializeNoArguments(), "PetscInitialize");
  PetscPopSignalHandler();
  g_initialised = true;
  // PETSc started MPI itself (no launcher): nobody else finalises, so do it at exit.
  if (!mpi_up) std::atexit([] { petsc_finalize(); });
}

void petsc_finalize() {
  if (!g_initialised || g_finalised) return;
  g_finalised = true;
  PetscFinalize();
}

// The uncondensed three-field system. The condensed tangent is K_c = A + Σ_k c_k d_k d_kᵀ with
// c_k = V_k U″(θ_k) ~ V_k κ: at κ/G ~ 1e5 an AMG of K_c sees a nearly incompressible operator and its
// Krylov counts grow with κ/G. With one pressure unknown per mixed element, scaled so that its column
// is the unit vector n_k = d_k/|d_k| (p_k = π_k/|d_k|) and its row by c_k|d_k|,
//     [ A              N ] [u]   [b]
//     [ c_k|d_k| d_kᵀ −1 ] [π] = [0]
// has the same u (π_k = c_k|d_k| d_kᵀu, A u + Σ n_k π_k = K_c u), and the condensed residual is
// r_u + Σ n_k r_π,k: a small residual of this system is a small residual of K_c u = b (so the tolerance
// keeps its meaning). Field split (Schur complement, full factorization): BoomerAMG on the displacement
// block (or GAMG with the rigid-body near-nullspace composed on the split, -fieldsplit_u_pc_type gamg),
// Jacobi on a diagonal Schur approximation. With A alone in the displacement block (no volumetric
// stiffness, petsc_augmentation = 0) that diagonal, −(1 + c_k d_kᵀ diag(A)⁻¹ d_k) (selfp's diagonal, the
// scaled pressure mass 1/G + 1/κ), misses the small eigenvalues of the Q1/P0 pair (no uniform inf-sup
// constant) and the counts grow ~1.4× per mesh refinement. The default keeps a part γ_k of the element's
// volumetric stiffness in the displacement block (augmented Lagrangian, Data::augmentation): its
// Schur complement is diagonal up to O(1/γ) whatever the inf-sup constant (with an exact displacement
// solve 6–10 GMRES iterations on the tube), and α = 10 (a bulk modulus ~ 10 G in the displacement
// block) is where one AMG V-cycle on that block does best (α = 1, 3, 30, 100 need 1.2–3× more
// iterations, BENCHMARKS.md).
struct PetscSolver::Data {
  MPI_Comm comm = MPI_COMM_NULL;  // PETSC_COMM_WORLD once PETSc is up
  int rank = 0, size = 1;
  PetscInt ndof = 0, lo = 0, hi = 0;  // this rank's displacement rows: hi − lo of them (lo = 0)
  std::vector<int> dof_of_eq;         // free equation → dof
  const DofMap* dofs = nullptr;
  PetscInt nnodes = 0;
  std::vector<double> coords;         // owned nodes' coordinates (near-nullspace)
  PetscInt plo = 0, phi = 0;          // this rank's element pressures: phi − plo of them (plo = 0)
  std::vector<PetscInt> first;        // per rank: its first global index (u then π block)
  Mat A = nullptr;
  // Augmented-Lagrangian split (augmentation): α ([solver] petsc_augmentation), the diagonal Schur
  // preconditioning matrix it gives (null without the split).
  double al_alpha = kSplitAugmentation;
  Mat schur_pre = nullptr;
  KSP ksp = nullptr;
  Vec b = nullptr, x = nullptr, all = nullptr;
  VecScatter to_all = nullptr;
  IS is_u = nullptr, is_p = nullptr;
  double dirichlet_diagonal = 1.0;
  double option_rtol = 0.0;  // -ksp_rtol of the options (0: none)
  std::string user_options;  // [solver] petsc_options
  LinearSolverChoice choice;  // the route's settings (apply_choice)
  std::vector<PetscInt> dnz, onz;  // preallocation of the owned rows (create_system)
  // Distributed three-field system: dnz, onz count the displacement columns alone and these the
  // pressure columns; the matrix is then a nest of its four blocks (petsc_nest.hpp) unless
  // [solver] petsc_nested_matrix = false asks for one AIJ matrix.
  std::vector<PetscInt> dnz_p, onz_p;
  std::unique_ptr<NestedSaddleMatrix> nest;
  /// Couplings that changed since the last fill (accept_new_entries), entered as zeros at the next one.
  Couplings new_couplings;
  void add_coupling_zeros();
  /// MatSetValues on the system in its own numbering (routed to the nest's blocks).
  void set_values(PetscInt nr, const PetscInt* rows, PetscInt nc, const PetscInt* cols, const PetscScalar* v,
                  InsertMode mode) {
    if (nest) nest->add(nr, rows, nc, cols, v, mode);
    else check(MatSetValues(A, nr, rows, nc, cols, v, mode), "MatSetValues");
  }
  // Distributed assembly (distribute): the PETSc row of every mesh dof and of every element's pressure
  // (−1: none), the owner of every node, this rank's mesh dofs in row order.
  const Mesh* mesh = nullptr;
  bool distributed = false, mixed_rows = false, diagonal_known = false;
  std::vector<PetscInt> urow, prow, owned_dofs;
  // Once the first fill has fixed the pattern, the displacement rows of the elements (and of the
  // augmentation) go straight into the CSR values of the matrix holding them (the nest's u block, or
  // the one AIJ matrix) instead of through MatSetValues (petsc_direct_fill.hpp).
  bool pattern_final = false;
  std::array<DirectFill, 4> fills;  // the nest's blocks (i, j) at 2i + j; the one AIJ matrix at 0
  void begin_direct_fill() {
    if (!pattern_final || bddc) return;
    if (!nest) fills[0].begin(A);
    else
      for (int k = 0; k < 4; ++k) fills[k].begin(nest->block(k / 2, k % 2));
  }
  void end_direct_fill() {
    for (DirectFill& f : fills) f.end();
  }
  /// The nr × nc row-major block v at rows × cols of the system, each set all displacements or all
  /// pressures (p_rows, p_cols): into the values directly during a fill of the final pattern.
  void add_block(bool p_rows, int nr, const PetscInt* rows, bool p_cols, int nc, const PetscInt* cols, const PetscScalar* v) {
    if (!fills[0].active()) {
      set_values(nr, rows, nc, cols, v, ADD_VALUES);
    } else if (!nest) {
      fills[0].add(nr, rows, nc, cols, v);
    } else {
      std::array<PetscInt, 32> br, bc;
      if (nr > 32 || nc > 32) throw std::logic_error("PetscSolver: element block larger than 32");
      for (int i = 0; i < nr; ++i) br[i] = nest->block_index(rows[i]);
      for (int j = 0; j < nc; ++j) bc[j] = nest->block_index(cols[j]);
      fills[2 * p_rows + p_cols].add(nr, br.data(), nc, bc.data(), v);
    }
  }
  std::vector<int> node_owner;
  // BDDC: the condensed displacement system as a MATIS over the element partition's subdomains
  // (petsc_subdomains.hpp), filled through MatSetValuesLocal.
  bool bddc = false, bddc_flux = false;
  std::unique_ptr<Subdomains> subdomains;
  // Its primal constraints (kBddcDefaults): on every face the rigid-body modes and, unless
  // [solver] bddc_flux = false, the flux of the three-field elements' volume change (set_bddc_constraints);
  // flux_weights is this subdomain's Σ_e ∂v_e/∂u = Σ_e V_e ∂θ_e/∂u of the fill.
  std::vector<double> flux_weights;
  MatNullSpace rigid_modes = nullptr;
  ISLocalToGlobalMapping local_to_global = nullptr;
  // Distributed augmented split: the owned three-field elements of this fill, their distinct free rows
  // and the sums s of d over each (degenerate hexes repeat a node), finished in end_fill once diag(A)
  // is assembled.
  struct PendingElement {
    PetscInt prow = -1;
    double c = 0.0, dn = 1.0;
    int n = 0;
    std::array<PetscInt, 30> rows{};
    std::array<double, 30> s{};
  };
  std::vector<PendingElement> pending;
  // Once the pattern is final, γ comes from the previous tangent's diag(A) (`lagged_diagonal`, every
  // system row, without the γ terms; its mean magnitude over the free rows): γ only shapes the
  // preconditioner (the condensed operator A + Σ c d dᵀ is the same for any 0 ≤ γ ≤ c), and the element
  // pass then adds Ke − (c − γ) d dᵀ at once, with no second pass over the elements. `gamma_diagonal`
  // collects Σ γ s² per row of such a fill, to take the γ terms out of the next diag(A).
  std::vector<double> lagged_diagonal;
  double lagged_mean = 0.0;
  bool lagged_fill = false;
  Vec gamma_diagonal = nullptr;
  struct Augmentation {
    double gamma = 0.0, kept = 0.0, x = 0.0;
  };
  // A fill on one process whose pattern is final takes no lock (PetscSolver::concurrent_fill): the
  // elements of one colour write disjoint rows, so Σ γ s² goes straight into gamma_diagonal's array and
  // the Schur diagonal into schur_values (its owned rows, NaN where no element wrote), both handed to
  // PETSc at end_fill.
  PetscScalar* gamma_values = nullptr;
  std::vector<double> schur_values;
  /// The Schur preconditioner's diagonal entry of the element's pressure: −1 − (c − γ) x / (1 + γ x).
  void set_schur_diagonal(const PendingElement& pe, const Augmentation& a) {
    const PetscInt k = pe.prow - (first[rank] + hi);  // this rank's pressure k (hi: its displacement rows)
    const double value = -1.0 - a.kept * a.x / (1.0 + a.gamma * a.x);
    if (!schur_values.empty()) {
      schur_values[std::size_t(k)] = value;
      return;
    }
    PetscInt lo = 0;
    check(MatGetOwnershipRange(schur_pre, &lo, nullptr), "MatGetOwnershipRange");
    check(MatSetValue(schur_pre, lo + k, lo + k, value, INSERT_VALUES), "MatSetValue");
  }
  // The augmented-Lagrangian split of the three-field elements' volumetric stiffness.
  // The condensed tangent is K = A + Σ_k c_k d_k d_kᵀ (c_k = V_k U″(θ_k) ~ V_k κ, d_k = ∂θ_k/∂u). Its
  // part γ_k ≤ c_k stays in the displacement block, A_γ = A + Σ_k γ_k d_k d_kᵀ, and the rest c̃_k = c_k − γ_k
  // is carried by the element pressure. By the Sherman–Morrison–Woodbury identity the Schur complement
  // of the pressure block (in the scaling above) is
  //     S = −I − C̃ Dᵀ A_γ⁻¹ D,   Dᵀ A_γ⁻¹ D = ((Dᵀ A⁻¹ D)⁻¹ + Γ)⁻¹,
  // which tends to the diagonal −(1 + c̃_k/γ_k) as γ grows, whatever the inf-sup constant of the
  // element pair (Q1/P0 has none uniform in h; its small eigenvalues of Dᵀ A⁻¹ D are what make the
  // counts of a mass-matrix-like Schur approximation grow with the mesh). With x_k = d_kᵀ diag(A)⁻¹ d_k
  // (the element's diagonal estimate of Dᵀ A⁻¹ D) and γ_k = α / x_k the displacement block is that of a
  // compressible solid with a bulk modulus ~ α G: AMG on it stays cheap for α = O(10), and the Schur
  // diagonal used is −1 − c̃_k x_k / (1 + γ_k x_k). α = 0 is the plain split (γ = 0, the diagonal of
  // selfp).
  /// γ = min(α / x, c/2), x = Σ s² / max(|diag(A)|, 1e-3 mean) over the element's rows (the bulk part
  /// α / x kept on u is ~α times its shear stiffness), and the part c − γ left to the pressure.
  Augmentation augmentation(const PendingElement& pe, const double* diagonal, double mean) const {
    Augmentation a;
    for (int i = 0; i < pe.n; ++i) a.x += pe.s[i] * pe.s[i] / std::max(std::abs(diagonal[pe.rows[i]]), 1e-3 * mean);
    a.gamma = a.x > 0.0 ? std::min(al_alpha / a.x, 0.5 * pe.c) : 0.0;
    a.kept = pe.c - a.gamma;
    return a;
  }
  // The displacement block's p-multigrid: its interpolation, given to PCMG once the
  // field split has made its sub-solvers.
  bool p_multigrid = false;
  Mat p_interpolation = nullptr;
  // Whether the user's options chose the displacement block's solver or the augmentation (then no
  // fall-back replaces it: fall_back_from_p_multigrid).
  bool user_displacement_solver = false;
  // The fine level's smoother (choose_fine_smoother): the nodal 3 × 3 blocks' spread of the tangents set
  // up (nodal_block_spread) until one exceeds kAnisotropicBlockSpread, and whether that has happened (the
  // anisotropic smoother chosen); neither when the user's options set the smoother.
  double block_spread = 0.0;
  bool anisotropic_smoother = false, user_smoother = false;
  // The coarse level's solver, its vertices (mesh nodes) and their current positions for the next
  // tangent's rigid-body modes (pending until that set-up; [solver] petsc_current_modes = false: the reference
  // positions throughout). The modes of the reference positions are not those of a body that has
  // turned or stretched: a rotation δu = W x of the current configuration changes no strain (δF = W F),
  // δu = W X does (δF = W, strain sym(Fᵀ W) of the order of the displacement gradient), and GAMG's
  // coarse spaces built from the latter lost the fine gripper at 150–175 kPa (GMRES without progress
  // over 2 000 iterations; 30–77 per solve to 200 kPa with the current positions, BENCHMARKS.md "A
  // coarse space with rotations").
  KSP coarse_ksp = nullptr;
  std::vector<int> coarse_nodes;
  /// The coarse level's preconditioner type ("" before the hierarchy exists).
  std::string coarse_pc_type() const {
    PC pc = nullptr;
    PCType type = nullptr;
    if (!coarse_ksp || KSPGetPC(coarse_ksp, &pc) != 0 || PCGetType(pc, &type) != 0 || !type) return "";
    return type;
  }
  bool current_modes = false, modes_pending = false;
  std::vector<double> coarse_current;

  bool saddle() const { return mixed_rows; }
  // The parts of create_system: the matrix of the layout (a MATIS of the subdomains under BDDC, the
  // nest of the (u, p) blocks, or one AIJ matrix), and the preconditioner of the choice with the
  // rigid-body modes `nsp`.
  void create_matrix();
  void set_field_split(PC pc, MatNullSpace nsp);
  void set_bddc(PC pc, MatNullSpace nsp);
  void set_whole_system_preconditioner(PC pc, MatNullSpace nsp);
  /// An element's free dofs: their positions in the element (pos) and rows (the system's, or under BDDC
  /// the subdomain's).
  struct ElementRows {
    std::array<int, 30> pos;
    std::array<PetscInt, 31> rows;
    int nf = 0;
    void sort_ascending();
  };
  ElementRows element_rows(int nn, const int* nodes) const;
  void add_subdomain_element(const ElementRows& er, int nd, const double* Ke, const double* dk, double volume);
  // The parts of distribute: the rows of every mesh dof and element pressure, rank by rank, and the
  // preallocation of this rank's rows (dnz, onz, dnz_p, onz_p).
  void number_rows(const std::vector<int>& element_owner, const std::vector<int>& node_owner,
                   const std::vector<int>& mixed_elements);
  /// Preallocation of the owned rows: the nodes sharing an element or a coupling group with each owned node.
  void count_row_entries(const std::vector<int>& element_owner, const std::vector<int>& mixed_elements,
                         const Couplings& couplings);
  /// Global PETSc index of mesh dof g.
  PetscInt gu(PetscInt g) const { return urow[g]; }
};

/// `defaults` into PETSc's options database, then the user's `options` over them.
static void insert_under_user_options(const char* defaults, const std::string& options) {
  check(PetscOptionsInsertString(nullptr, defaults), "PetscOptionsInsertString (defaults)");
  if (!options.empty() && PetscOptionsInsertString(nullptr, options.c_str()) != 0)
    throw InputError("solver.petsc_options", options, "PETSc cannot parse these options");
}

PetscSolver::PetscSolver(const Mesh& mesh, const DofMap& dofs, const LinearSolverChoice& choice) : d_(std::make_unique<Data>()) {
  petsc_initialize();
  Data& d = *d_;
  d.comm = PETSC_COMM_WORLD;
  MPI_Comm_rank(d.comm, &d.rank);
  MPI_Comm_size(d.comm, &d.size);
  d.mesh = &mesh;
  d.nnodes = mesh.num_nodes();
  d.ndof = 3 * d.nnodes;
  d.dofs = &dofs;
  d.dof_of_eq.assign(dofs.num_free, -1);
  for (int k = 0; k < int(dofs.eq.size()); ++k)
    if (dofs.eq[k] >= 0) d.dof_of_eq[dofs.eq[k]] = k;
  apply_choice(choice);
}

void PetscSolver::apply_choice(const LinearSolverChoice& choice) {
  Data& d = *d_;
  const std::string& options = choice.petsc_options;
  d.choice = choice;
  // One database per solver: the options of an earlier simulation in this process do not carry over.
  check(PetscOptionsClear(nullptr), "PetscOptionsClear");
  insert_under_user_options(kSplitDefaults, options);
  d.user_options = options;
  PetscBool set = PETSC_FALSE;
  PetscReal rtol = 0.0;
  PetscOptionsGetReal(nullptr, nullptr, "-ksp_rtol", &rtol, &set);
  if (set && options.find("-ksp_rtol") != std::string::npos) d.option_rtol = rtol;
  d.bddc = choice.preconditioner == Preconditioner::bddc;
  d.bddc_flux = choice.bddc_flux;
  // Quadratic tets: the displacement block gets the two-level p-multigrid (petsc_p_multigrid.hpp); its
  // settings go in under the user's options.
  d.p_multigrid = choice.p_multigrid;
  if (d.bddc) insert_under_user_options(kBddcDefaults, options);
  d.user_displacement_solver = !choice.p_multigrid_fallback;
  d.al_alpha = choice.augmentation;
  if (d.p_multigrid) {
    insert_under_user_options(kPMultigridDefaults, options);
    d.user_smoother = options.find("-fieldsplit_u_mg_levels_") != std::string::npos;
  }
  d.current_modes = choice.current_modes;
}

PetscSolver::~PetscSolver() {
  if (!d_ || g_finalised) return;  // PETSc's objects went with PetscFinalize
  Data& d = *d_;
  if (d.to_all) VecScatterDestroy(&d.to_all);
  if (d.all) VecDestroy(&d.all);
  if (d.b) VecDestroy(&d.b);
  if (d.x) VecDestroy(&d.x);
  if (d.ksp) KSPDestroy(&d.ksp);
  if (d.A) MatDestroy(&d.A);
  if (d.schur_pre) MatDestroy(&d.schur_pre);
  if (d.is_u) ISDestroy(&d.is_u);
  if (d.is_p) ISDestroy(&d.is_p);
  if (d.p_interpolation) MatDestroy(&d.p_interpolation);
  if (d.gamma_diagonal) VecDestroy(&d.gamma_diagonal);
  if (d.local_to_global) ISLocalToGlobalMappingDestroy(&d.local_to_global);
  if (d.rigid_modes) MatNullSpaceDestroy(&d.rigid_modes);
}

int PetscSolver::ranks() const { return d_->size; }

std::string PetscSolver::description() const {
  if (!d_->ksp) return "petsc";
  KSPType kt;
  PCType pt;
  PC pc;
  KSPGetType(d_->ksp, &kt);
  KSPGetPC(d_->ksp, &pc);
  PCGetType(pc, &pt);
  std::string s = std::string(kt ? kt : "?") + " + " + (pt ? pt : "?");
  if (d_->saddle() && pt && std::string(pt) == PCFIELDSPLIT) {
    s += " (u, p) Schur: augmented u block, jacobi on the Schur diagonal";
    if (d_->p_multigrid) {
      // The coarse solver the options chose (once the hierarchy exists; BoomerAMG by default).
      const std::string type = d_->coarse_pc_type();
      std::string coarse = type;
      if (type.empty() || type == PCHYPRE) coarse = "BoomerAMG (3 functions)";
      else if (type == PCGAMG) coarse = d_->current_modes ? "GAMG (rigid-body modes of the current positions)" : "GAMG (rigid-body modes)";
      s += ", P2 -> P1 multigrid with " + coarse + " on the P1 Galerkin block";
      if (!d_->user_smoother) {
        char buf[160];
        std::snprintf(buf, sizeof buf, ", the P2 level smoothed by %s (nodal block spread %.3g)",
                      d_->anisotropic_smoother ? "two Chebyshev sweeps on its 3 x 3 nodal blocks" : "one Chebyshev sweep on its diagonal",
                      d_->block_spread);
        s += buf;
      }
    }
  }
  return s;
}

std::string PetscSolver::near_nullspace() const {
  if (!d_->bddc) return "rigid-body near-nullspace";
  return d_->bddc_flux ? "rigid-body and volume-flux constraints on edges and faces" : "rigid-body constraints on edges and faces";
}

void PetscSolver::analyze(const CscMatrix&) {
  throw std::logic_error("PetscSolver: the system is laid out by distribute (the element loop fills it)");
}

void PetscSolver::create_system() {
  Data& d = *d_;
  const PetscInt nlocal = (d.hi - d.lo) + (d.phi - d.plo);
  const PetscInt nglobal = d.first[d.size];
  d.create_matrix();
  // Rigid-body modes from the owned nodes' coordinates: GAMG's near-nullspace (its counts grow with the
  // mesh without them).
  MatNullSpace nsp = rigid_body_modes(d.comm, d.coords, d.ndof);
  // Plain MPI vectors in the system's layout (a nest's own would be nested vectors).
  check(VecCreateMPI(d.comm, nlocal, nglobal, &d.x), "VecCreateMPI");
  check(VecDuplicate(d.x, &d.b), "VecDuplicate");
  check(VecScatterCreateToAll(d.x, &d.to_all, &d.all), "VecScatterCreateToAll");
  check(KSPCreate(d.comm, &d.ksp), "KSPCreate");
  check(KSPSetType(d.ksp, KSPGMRES), "KSPSetType");
  // GMRES: the follower-pressure tangent is unsymmetric (and the field split's preconditioner too).
  // Right preconditioning: the tolerance is on the true residual ‖b − A x‖/‖b‖, as for the CHOLMOD
  // path's GMRES.
  check(KSPGMRESSetRestart(d.ksp, 200), "KSPGMRESSetRestart");
  // Classical Gram–Schmidt loses orthogonality on these badly scaled systems (κ/G up to 1e5) at tight
  // tolerances: GMRES then stagnates and reports a breakdown at the restart (Cook 6 × 6, K/G = 1e4);
  // refined CGS converges in 53 iterations there.
  check(KSPGMRESSetCGSRefinementType(d.ksp, KSP_GMRES_CGS_REFINE_ALWAYS), "KSPGMRESSetCGSRefinementType");
  check(KSPSetPCSide(d.ksp, PC_RIGHT), "KSPSetPCSide");
  check(KSPSetTolerances(d.ksp, 1e-8, 1e-300, PETSC_DEFAULT, 2000), "KSPSetTolerances");
  PC pc;
  check(KSPGetPC(d.ksp, &pc), "KSPGetPC");
  if (d.saddle() && d.choice.field_split) d.set_field_split(pc, nsp);
  else if (d.bddc) d.set_bddc(pc, nsp);
  else d.set_whole_system_preconditioner(pc, nsp);
  MatNullSpaceDestroy(&nsp);
  set_up_with_options(d.user_options, [&] { check(KSPSetFromOptions(d.ksp), "KSPSetFromOptions"); });
}

void PetscSolver::Data::create_matrix() {
  Data& d = *this;
  const PetscInt nu = d.hi - d.lo;
  const PetscInt nlocal = nu + (d.phi - d.plo);
  const PetscInt nglobal = d.first[d.size];
  // The nest serves the field split alone: another preconditioner (MUMPS's LU, ilu, ...) needs one AIJ
  // matrix, and has no use for the split's augmentation either (a second fill of the element blocks at
  // every tangent: half of the one-process fill time on the tube with MUMPS).
  if (d.bddc) {
    if (!d.subdomains) throw std::logic_error("PetscSolver: BDDC needs the distributed assembly");
    d.local_to_global = d.subdomains->local_to_global(d.comm);
    check(MatCreateIS(d.comm, 3, nlocal, nlocal, nglobal, nglobal, d.local_to_global, d.local_to_global, &d.A), "MatCreateIS");
    Mat local = nullptr;
    check(MatISGetLocalMat(d.A, &local), "MatISGetLocalMat");
    check(MatSeqAIJSetPreallocation(local, 0, d.subdomains->nonzeros().data()), "MatSeqAIJSetPreallocation (subdomain)");
    // A follower-pressure coupling may join two nodes of the subdomain that share none of its elements
    // (Subdomains::adds_coupling): such an entry is allocated at the first fill, and stays in the pattern.
    check(MatSetOption(local, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_FALSE), "MatSetOption (subdomain)");
    check(MatISRestoreLocalMat(d.A, &local), "MatISRestoreLocalMat");
    return;
  }
  if (!d.dnz_p.empty() && d.choice.field_split && d.choice.nested_matrix) {
    std::vector<PetscInt> nu_of(d.size);
    PetscInt mine = nu;
    MPI_Allgather(&mine, 1, MPIU_INT, nu_of.data(), 1, MPIU_INT, d.comm);
    d.nest = std::make_unique<NestedSaddleMatrix>();
    d.nest->create(d.comm, d.rank, d.first, nu_of, d.dnz, d.onz, d.dnz_p, d.onz_p);
    d.A = d.nest->whole();
    check(PetscObjectReference(reinterpret_cast<PetscObject>(d.A)), "PetscObjectReference");
    return;
  }
  std::vector<PetscInt> dnz = d.dnz, onz = d.onz;
  for (std::size_t i = 0; i < d.dnz_p.size(); ++i) {
    dnz[i] += d.dnz_p[i];
    onz[i] += d.onz_p[i];
  }
  check(MatCreate(d.comm, &d.A), "MatCreate");
  check(MatSetSizes(d.A, nlocal, nlocal, nglobal, nglobal), "MatSetSizes");
  check(MatSetType(d.A, MATAIJ), "MatSetType");
  if (!d.saddle()) check(MatSetBlockSize(d.A, 3), "MatSetBlockSize");
  check(MatSeqAIJSetPreallocation(d.A, 0, dnz.data()), "MatSeqAIJSetPreallocation");
  check(MatMPIAIJSetPreallocation(d.A, 0, dnz.data(), 0, onz.data()), "MatMPIAIJSetPreallocation");
  check(MatSetOption(d.A, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_TRUE), "MatSetOption");
}

void PetscSolver::Data::set_field_split(PC pc, MatNullSpace nsp) {
  Data& d = *this;
  const PetscInt nu = d.hi - d.lo;
  std::vector<PetscInt> iu(nu), ip(d.phi - d.plo);
  for (PetscInt i = 0; i < nu; ++i) iu[i] = d.first[d.rank] + i;
  for (PetscInt i = 0; i < d.phi - d.plo; ++i) ip[i] = d.first[d.rank] + nu + i;
  if (d.nest) {
    // The nest's own index sets: the field split then takes its blocks themselves, no copies.
    IS rows[2];
    check(MatNestGetISs(d.A, rows, nullptr), "MatNestGetISs");
    d.is_u = rows[0];
    d.is_p = rows[1];
    check(PetscObjectReference(reinterpret_cast<PetscObject>(d.is_u)), "PetscObjectReference");
    check(PetscObjectReference(reinterpret_cast<PetscObject>(d.is_p)), "PetscObjectReference");
  } else {
    check(ISCreateGeneral(d.comm, nu, iu.data(), PETSC_COPY_VALUES, &d.is_u), "ISCreateGeneral");
    check(ISCreateGeneral(d.comm, PetscInt(ip.size()), ip.data(), PETSC_COPY_VALUES, &d.is_p), "ISCreateGeneral");
  }
  check(ISSetBlockSize(d.is_u, 3), "ISSetBlockSize");
  // The field split hands the near-nullspace composed on the IS to its displacement block.
  check(PetscObjectCompose(reinterpret_cast<PetscObject>(d.is_u), "nearnullspace", reinterpret_cast<PetscObject>(nsp)),
        "PetscObjectCompose");
  check(PCSetType(pc, PCFIELDSPLIT), "PCSetType");
  check(PCFieldSplitSetIS(pc, "u", d.is_u), "PCFieldSplitSetIS");
  check(PCFieldSplitSetIS(pc, "p", d.is_p), "PCFieldSplitSetIS");
  check(PCFieldSplitSetType(pc, PC_COMPOSITE_SCHUR), "PCFieldSplitSetType");
  // Full factorization: one more displacement solve per iteration than the upper one, 1.1–1.7× fewer
  // iterations on Cook's membrane and the tube (BENCHMARKS.md). (The p-multigrid of quadratic tets
  // takes the upper one: kPMultigridDefaults.)
  check(PCFieldSplitSetSchurFactType(pc, PC_FIELDSPLIT_SCHUR_FACT_FULL), "PCFieldSplitSetSchurFactType");
  // The diagonal Schur approximation of the augmented split (PETSc's sparse selfp operator, with Jacobi
  // or with its own AMG, took 1.4–1.6x the iterations or failed: BENCHMARKS.md).
  const PetscInt npl = d.phi - d.plo;
  check(MatCreateAIJ(d.comm, npl, npl, PETSC_DETERMINE, PETSC_DETERMINE, 1, nullptr, 0, nullptr, &d.schur_pre),
        "MatCreateAIJ");
  check(PCFieldSplitSetSchurPre(pc, PC_FIELDSPLIT_SCHUR_PRE_USER, d.schur_pre), "PCFieldSplitSetSchurPre");
}

void PetscSolver::Data::set_bddc(PC pc, MatNullSpace nsp) {
  Data& d = *this;
  check(MatSetNearNullSpace(d.A, nsp), "MatSetNearNullSpace");
  d.rigid_modes = nsp;  // with the faces' fluxes at every fill (set_bddc_constraints)
  check(PetscObjectReference(reinterpret_cast<PetscObject>(nsp)), "PetscObjectReference");
  check(PCSetType(pc, PCBDDC), "PCSetType");
  // The prescribed dofs' rows are the identity (shared among the subdomains holding them): BDDC keeps
  // them out of its interface.
  const std::vector<PetscInt>& fixed = d.subdomains->prescribed();
  IS is_fixed = nullptr;
  check(ISCreateGeneral(PETSC_COMM_SELF, PetscInt(fixed.size()), fixed.data(), PETSC_COPY_VALUES, &is_fixed), "ISCreateGeneral");
  check(PCBDDCSetDirichletBoundariesLocal(pc, is_fixed), "PCBDDCSetDirichletBoundariesLocal");
  ISDestroy(&is_fixed);
}

void PetscSolver::Data::set_whole_system_preconditioner(PC pc, MatNullSpace nsp) {
  Data& d = *this;
  check(MatSetNearNullSpace(d.A, nsp), "MatSetNearNullSpace");
  if (d.choice.preconditioner == Preconditioner::lu) {
    check(PCSetType(pc, PCLU), "PCSetType");
    check(PCFactorSetMatSolverType(pc, MATSOLVERMUMPS), "PCFactorSetMatSolverType");
  } else {
    check(PCSetType(pc, PCGAMG), "PCSetType");  // (an expert -pc_type replaces it below)
  }
}

bool PetscSolver::factorize(const CscMatrix&) {
  const auto t0 = std::chrono::steady_clock::now();
  Data& d = *d_;
  // The element loop has filled the matrix (begin_fill .. end_fill).
  if (!d.distributed) throw std::logic_error("PetscSolver: factorize before distribute");
  check(KSPSetReusePreconditioner(d.ksp, PETSC_FALSE), "KSPSetReusePreconditioner");
  check(KSPSetOperators(d.ksp, d.A, d.A), "KSPSetOperators");
  if (d.modes_pending) {
    set_coarse_modes(d.coarse_current);
    d.modes_pending = false;
  }
  choose_fine_smoother();
  // The multigrid hierarchy or factor of this tangent now (its cost is the "factorization" of this solver).
  set_up_with_options(d.user_options, [&] {
    check(KSPSetUp(d.ksp), "KSPSetUp");
    attach_p_multigrid();
  });
  times_.factorization += petsc_seconds_since(t0);
  ++times_.factorizations;
  times_.factor_nnz = 0.0;
  if (times_.factorizations == 1) account_matrices();
  return true;
}

/// The field split's displacement solver and its preconditioner when that is a PCMG (the user's options
/// may have chosen another), else null.
static KSP displacement_mg(KSP ksp, PC* pu) {
  PC pc;
  PCType type = nullptr;
  check(KSPGetPC(ksp, &pc), "KSPGetPC");
  if (PCGetType(pc, &type) != 0 || !type || std::string(type) != PCFIELDSPLIT) return nullptr;
  PetscInt n = 0;
  KSP* sub = nullptr;
  check(PCFieldSplitGetSubKSP(pc, &n, &sub), "PCFieldSplitGetSubKSP");
  KSP ku = sub[0];
  PetscFree(sub);
  check(KSPGetPC(ku, pu), "KSPGetPC");
  if (PCGetType(*pu, &type) != 0 || !type || std::string(type) != PCMG) return nullptr;
  return ku;
}

void PetscSolver::attach_p_multigrid() {
  Data& d = *d_;
  if (!d.p_multigrid || d.p_interpolation) return;
  PC pu = nullptr;
  KSP ku = displacement_mg(d.ksp, &pu);
  if (!ku) return;
  PetscInt levels = 0;
  check(PCMGGetLevels(pu, &levels), "PCMGGetLevels");
  if (levels != 2) throw InputError("solver.petsc_options", "-fieldsplit_u_pc_mg_levels " + std::to_string(levels),
                                    "the p-multigrid ([solver] petsc_p_multigrid) has two levels");
  // The displacement block numbers the nodes rank by rank, by node_owner.
  PMultigridSpace space = p_multigrid_interpolation(d.comm, d.rank, *d.mesh, d.dofs->eq, d.node_owner);
  d.p_interpolation = space.interpolation;
  check(PCMGSetInterpolation(pu, 1, d.p_interpolation), "PCMGSetInterpolation");
  check(KSPSetUp(ku), "KSPSetUp (p-multigrid)");
  // The coarse Galerkin block now exists: give it the rigid-body modes of the P1 vertices. PCMG keeps
  // that matrix for every later tangent (its product is recomputed in place), so the modes stay with it;
  // this first hierarchy is rebuilt once, with them.
  check(PCMGGetCoarseSolve(pu, &d.coarse_ksp), "PCMGGetCoarseSolve");
  d.coarse_nodes = std::move(space.coarse_nodes);
  set_coarse_modes(space.coarse_coords);
  check(KSPSetUp(d.coarse_ksp), "KSPSetUp (coarse)");
}

bool PetscSolver::can_fall_back_from_p_multigrid() const {
  return d_->ksp && d_->p_multigrid && !d_->user_displacement_solver;
}

bool PetscSolver::fall_back_from_p_multigrid() {
  Data& d = *d_;
  PC pu = nullptr;
  KSP ku = can_fall_back_from_p_multigrid() ? displacement_mg(d.ksp, &pu) : nullptr;
  if (!ku) return false;
  // The database as for a mesh without quadratic tets (kSplitDefaults, then the user's options), and the
  // displacement solver re-read from it: PCSetType replaces the multigrid (and its reference to the
  // interpolation) by BoomerAMG, which the next set-up builds on the P2 block.
  check(PetscOptionsClear(nullptr), "PetscOptionsClear");
  insert_under_user_options(kSplitDefaults, d.user_options);
  set_up_with_options(d.user_options, [&] { check(KSPSetFromOptions(ku), "KSPSetFromOptions (displacement block)"); });
  PC pc = nullptr;
  check(KSPGetPC(d.ksp, &pc), "KSPGetPC");
  if (d.user_options.find("-pc_fieldsplit_schur_fact_type") == std::string::npos)
    check(PCFieldSplitSetSchurFactType(pc, PC_FIELDSPLIT_SCHUR_FACT_FULL), "PCFieldSplitSetSchurFactType");
  if (d.p_interpolation) MatDestroy(&d.p_interpolation);
  d.p_multigrid = false;
  d.coarse_ksp = nullptr;  // went with the multigrid
  d.coarse_nodes.clear();
  d.current_modes = d.modes_pending = false;
  // The augmentation of BoomerAMG on the P2 block (the matrix filled last keeps its γ until the next
  // fill: the condensed operator, and so the solution, does not depend on it).
  d.al_alpha = kSplitAugmentation;
  return true;
}

bool PetscSolver::anisotropic_smoother() const { return d_->anisotropic_smoother; }
double PetscSolver::block_spread() const { return d_->block_spread; }

void PetscSolver::choose_fine_smoother() {
  Data& d = *d_;
  if (!d.p_multigrid || d.user_smoother || d.anisotropic_smoother) return;
  // The displacement rows of this rank: the nest's (u, u) block, or the first rows of its part of the
  // one AIJ matrix (both node by node, three rows each).
  Mat uu = d.nest ? d.nest->block(0, 0) : d.A;
  PetscInt lo = 0;
  check(MatGetOwnershipRange(uu, &lo, nullptr), "MatGetOwnershipRange");
  d.block_spread = nodal_block_spread(d.comm, uu, lo, lo + (d.hi - d.lo));
  // Once a tangent is anisotropic the smoother stays so (and the spread is no longer measured): the
  // fibers' stiffness comes and goes with the load (tension only), and a preconditioner that switches
  // back and forth gains nothing.
  if (d.block_spread <= kAnisotropicBlockSpread) return;
  d.anisotropic_smoother = true;
  // Into the database for a first set-up (the field split reads the smoothers' options when it makes
  // them) and into the smoother itself once it exists.
  check(PetscOptionsSetValue(nullptr, "-fieldsplit_u_mg_levels_pc_type", PCPBJACOBI), "PetscOptionsSetValue");
  check(PetscOptionsSetValue(nullptr, "-fieldsplit_u_mg_levels_ksp_max_it", "2"), "PetscOptionsSetValue");
  PC pu = nullptr;
  if (!d.p_interpolation || !displacement_mg(d.ksp, &pu)) return;
  KSP smoother = nullptr;
  PC spc = nullptr;
  check(PCMGGetSmoother(pu, 1, &smoother), "PCMGGetSmoother");
  check(KSPGetPC(smoother, &spc), "KSPGetPC (smoother)");
  check(PCSetType(spc, PCPBJACOBI), "PCSetType (smoother)");
  check(KSPSetTolerances(smoother, PETSC_DEFAULT, PETSC_DEFAULT, PETSC_DEFAULT, 2), "KSPSetTolerances (smoother)");
}

void PetscSolver::set_coarse_modes(std::vector<double>& coords) {
  Data& d = *d_;
  KSP kc = d.coarse_ksp;
  Mat coarse_op = nullptr, coarse = nullptr;
  check(KSPGetOperators(kc, &coarse_op, &coarse), "KSPGetOperators (coarse)");
  MatNullSpace modes = rigid_body_modes(d.comm, coords);
  check(MatSetNearNullSpace(coarse, modes), "MatSetNearNullSpace (coarse)");
  MatNullSpaceDestroy(&modes);
  // A fresh coarse preconditioner, with the old one's options prefix and operators: GAMG reads the
  // modes at its first set-up only (later ones reuse its copy), and its levels cannot be reset in place
  // to other sizes.
  PC old_pc = nullptr, fresh_pc = nullptr;
  const char* prefix = nullptr;
  check(PetscObjectReference(reinterpret_cast<PetscObject>(coarse_op)), "PetscObjectReference");
  check(PetscObjectReference(reinterpret_cast<PetscObject>(coarse)), "PetscObjectReference");
  check(KSPGetPC(kc, &old_pc), "KSPGetPC (coarse)");
  check(PCGetOptionsPrefix(old_pc, &prefix), "PCGetOptionsPrefix (coarse)");
  check(PCCreate(d.comm, &fresh_pc), "PCCreate (coarse)");
  check(PCSetOptionsPrefix(fresh_pc, prefix), "PCSetOptionsPrefix (coarse)");
  check(KSPSetPC(kc, fresh_pc), "KSPSetPC (coarse)");
  check(KSPSetOperators(kc, coarse_op, coarse), "KSPSetOperators (coarse)");
  check(PCSetFromOptions(fresh_pc), "PCSetFromOptions (coarse)");
  PCDestroy(&fresh_pc);
  MatDestroy(&coarse_op);
  MatDestroy(&coarse);
}

void PetscSolver::set_displacement(const std::vector<double>& u) {
  Data& d = *d_;
  if (!d.current_modes || d.coarse_nodes.empty()) return;
  // BoomerAMG (the default coarse solver) does not read them: no new coarse preconditioner for it.
  const std::string type = d.coarse_pc_type();
  if (type.empty() || type == PCHYPRE) return;
  d.coarse_current.resize(3 * d.coarse_nodes.size());
  for (std::size_t v = 0; v < d.coarse_nodes.size(); ++v) {
    const int n = d.coarse_nodes[v];
    for (int i = 0; i < 3; ++i) d.coarse_current[3 * v + i] = d.mesh->nodes[n][i] + u[3 * std::size_t(n) + i];
  }
  d.modes_pending = true;
}

void PetscSolver::update_operator() {
  Data& d = *d_;
  const auto t0 = std::chrono::steady_clock::now();
  // The operator changes, the preconditioner's own data (hypre's copy and hierarchy, MUMPS's factor,
  // the field split's blocks) stay those of the tangent last set up.
  check(KSPSetReusePreconditioner(d.ksp, PETSC_TRUE), "KSPSetReusePreconditioner");
  check(KSPSetOperators(d.ksp, d.A, d.A), "KSPSetOperators");
  times_.solve += petsc_seconds_since(t0);
}

double PetscSolver::max_over_ranks(double value) const {
  if (d_->size > 1) MPI_Allreduce(MPI_IN_PLACE, &value, 1, MPI_DOUBLE, MPI_MAX, d_->comm);
  return value;
}

PetscMatrixBytes petsc_last_matrix_bytes() { return g_matrix_bytes; }

void PetscSolver::account_matrices() {
  Data& d = *d_;
  MatInfo info;
  // Allocated entries × (value + column index): PETSc 3.18's MatInfo::memory is always 0.
  const double entry = double(sizeof(PetscScalar) + sizeof(PetscInt));
  g_matrix_bytes = {};
  if (d.nest) g_matrix_bytes.system = d.nest->bytes();
  else if (d.bddc) {
    Mat local = nullptr;
    if (MatISGetLocalMat(d.A, &local) == 0 && MatGetInfo(local, MAT_LOCAL, &info) == 0) g_matrix_bytes.system = info.nz_allocated * entry;
    MatISRestoreLocalMat(d.A, &local);
  } else if (MatGetInfo(d.A, MAT_LOCAL, &info) == 0) g_matrix_bytes.system = info.nz_allocated * entry;
  PC pc;
  PCType type;
  if (KSPGetPC(d.ksp, &pc) != 0 || PCGetType(pc, &type) != 0 || !type || std::string(type) != PCFIELDSPLIT) return;
  PetscInt n = 0;
  KSP* sub = nullptr;
  if (PCFieldSplitGetSubKSP(pc, &n, &sub) != 0 || n < 1) return;
  Mat amat = nullptr, pmat = nullptr;
  KSPGetOperators(sub[0], &amat, &pmat);
  if (pmat && (!d.nest || pmat != d.nest->block(0, 0)) && MatGetInfo(pmat, MAT_LOCAL, &info) == 0)
    g_matrix_bytes.split_copy = info.nz_allocated * entry;
  PetscFree(sub);
}

void PetscSolver::solve(const std::vector<double>& b, std::vector<double>& x) {
  const KrylovOutcome o = solve(b, x, 1e-12);
  if (!o.converged) throw std::runtime_error("PETSc: the linear solve did not converge (" + o.reason + ")");
}

KrylovOutcome PetscSolver::solve(const std::vector<double>& b, std::vector<double>& x, double rtol, int max_iterations) {
  const auto t0 = std::chrono::steady_clock::now();
  Data& d = *d_;
  const std::vector<int>& eq = d.dofs->eq;
  PetscScalar* bv;
  check(VecSet(d.b, 0.0), "VecSet");
  check(VecGetArray(d.b, &bv), "VecGetArray");
  for (std::size_t i = 0; i < d.owned_dofs.size(); ++i) bv[i] = eq[d.owned_dofs[i]] >= 0 ? b[eq[d.owned_dofs[i]]] : 0.0;
  check(VecRestoreArray(d.b, &bv), "VecRestoreArray");
  if (d.option_rtol > 0.0) rtol = std::min(rtol, d.option_rtol);
  PetscInt maxit;
  PetscReal r0, a0, dt0;
  KSPGetTolerances(d.ksp, &r0, &a0, &dt0, &maxit);
  check(KSPSetTolerances(d.ksp, rtol, 1e-300, PETSC_DEFAULT, max_iterations > 0 ? std::min<PetscInt>(maxit, max_iterations) : maxit),
        "KSPSetTolerances");
  check(KSPSolve(d.ksp, d.b, d.x), "KSPSolve");
  check(KSPSetTolerances(d.ksp, r0, a0, dt0, maxit), "KSPSetTolerances");
  KrylovOutcome o;
  KSPConvergedReason reason;
  KSPGetConvergedReason(d.ksp, &reason);
  PetscInt its;
  KSPGetIterationNumber(d.ksp, &its);
  o.iterations = int(its);
  o.converged = reason > 0;
  o.reason = KSPConvergedReasons[reason];
  PetscReal rnorm, bnorm;
  KSPGetResidualNorm(d.ksp, &rnorm);
  VecNorm(d.b, NORM_2, &bnorm);
  o.relative_residual = bnorm > 0.0 ? rnorm / bnorm : 0.0;
  // Every rank runs the same Newton iteration: the whole solution to every rank.
  check(VecScatterBegin(d.to_all, d.x, d.all, INSERT_VALUES, SCATTER_FORWARD), "VecScatterBegin");
  check(VecScatterEnd(d.to_all, d.x, d.all, INSERT_VALUES, SCATTER_FORWARD), "VecScatterEnd");
  const PetscScalar* av;
  check(VecGetArrayRead(d.all, &av), "VecGetArrayRead");
  x.assign(d.dof_of_eq.size(), 0.0);
  for (std::size_t k = 0; k < d.dof_of_eq.size(); ++k) x[k] = av[d.gu(d.dof_of_eq[k])];
  check(VecRestoreArrayRead(d.all, &av), "VecRestoreArrayRead");
  times_.solve += petsc_seconds_since(t0);
  ++times_.solves;
  return o;
}

// Distributed assembly: rows rank by rank, [u_r (3 per owned node, ascending node), π_r (the owned
// three-field elements, ascending)]: create_system's index sets of the split are contiguous ranges.
void PetscSolver::distribute(const std::vector<int>& element_owner, const std::vector<int>& node_owner,
                             const std::vector<int>& three_field_elements, const Couplings& couplings) {
  const auto t0 = std::chrono::steady_clock::now();
  Data& d = *d_;
  // BDDC: every element condensed (its pressure is its own), so no pressure rows.
  const std::vector<int> none;
  const std::vector<int>& mixed_elements = d.bddc ? none : three_field_elements;
  d.number_rows(element_owner, node_owner, mixed_elements);
  if (d.bddc)  // the subdomain matrices' own preallocation instead of the rows'
    d.subdomains = std::make_unique<Subdomains>(*d.mesh, element_owner, couplings, d.rank, d.urow, d.dofs->eq);
  else
    d.count_row_entries(element_owner, mixed_elements, couplings);
  create_system();
  times_.analysis += petsc_seconds_since(t0);
}

void PetscSolver::Data::number_rows(const std::vector<int>& element_owner, const std::vector<int>& node_owner,
                                    const std::vector<int>& mixed_elements) {
  Data& d = *this;
  d.distributed = true;
  d.mixed_rows = !mixed_elements.empty();
  d.node_owner = node_owner;
  std::vector<PetscInt> nodes_of(d.size, 0), pressures_of(d.size, 0);
  for (int n = 0; n < d.nnodes; ++n) ++nodes_of[node_owner[n]];
  for (int e : mixed_elements) ++pressures_of[element_owner[e]];
  d.first.assign(d.size + 1, 0);
  for (int r = 0; r < d.size; ++r) d.first[r + 1] = d.first[r] + 3 * nodes_of[r] + pressures_of[r];
  std::vector<PetscInt> next_u(d.first.begin(), d.first.end() - 1), next_p(d.size);
  for (int r = 0; r < d.size; ++r) next_p[r] = d.first[r] + 3 * nodes_of[r];
  d.urow.assign(d.ndof, -1);
  d.owned_dofs.clear();
  d.coords.clear();
  for (int n = 0; n < d.nnodes; ++n) {
    const int r = node_owner[n];
    for (int i = 0; i < 3; ++i) d.urow[3 * n + i] = next_u[r]++;
    if (r != d.rank) continue;
    for (int i = 0; i < 3; ++i) {
      d.owned_dofs.push_back(3 * n + i);
      d.coords.push_back(mesh->nodes[n][i]);
    }
  }
  d.prow.assign(mesh->num_elements(), -1);
  for (int e : mixed_elements) d.prow[e] = next_p[element_owner[e]]++;
  // This rank's row counts: create_system needs nu = hi − lo and phi − plo.
  d.lo = 0;
  d.hi = 3 * nodes_of[d.rank];
  d.plo = 0;
  d.phi = pressures_of[d.rank];
}

void PetscSolver::Data::count_row_entries(const std::vector<int>& element_owner, const std::vector<int>& mixed_elements,
                                          const Couplings& couplings) {
  Data& d = *this;
  const Mesh& mesh = *d.mesh;
  const std::vector<int>& eq = d.dofs->eq;
  const PetscInt nu = d.hi, nlocal = nu + d.phi, row0 = d.first[d.rank];
  // Preallocation: row (n, i) couples to the free dofs of every node sharing an element with n and to
  // the pressures of the three-field elements around n; a prescribed row holds its diagonal alone.
  std::vector<int> local(d.nnodes, -1);
  for (int n = 0, k = 0; n < d.nnodes; ++n)
    if (node_owner[n] == d.rank) local[n] = k++;
  std::vector<std::vector<int>> elems(nu / 3);
  for (int e = 0; e < mesh.num_elements(); ++e) {
    const int* en = mesh.element_nodes(e);
    for (int a = 0; a < mesh.element_size(e); ++a)
      if (local[en[a]] >= 0) elems[local[en[a]]].push_back(e);
  }
  std::vector<std::vector<int>> groups(nu / 3);  // the couplings' groups around each owned node
  for (int g = 0; g < couplings.size(); ++g)
    for (int k = couplings.offsets[g]; k < couplings.offsets[g + 1]; ++k)
      if (local[couplings.nodes[k]] >= 0) groups[local[couplings.nodes[k]]].push_back(g);
  d.dnz.assign(nlocal, 1);
  d.onz.assign(nlocal, 0);
  if (d.mixed_rows) {
    d.dnz_p.assign(nlocal, 0);
    d.onz_p.assign(nlocal, 0);
  }
  std::vector<int> neighbours;
  for (int n = 0; n < d.nnodes; ++n) {
    if (local[n] < 0) continue;
    neighbours.clear();
    PetscInt in = 0, out = 0, in_p = 0, out_p = 0;
    for (int e : elems[local[n]]) {
      const int* en = mesh.element_nodes(e);
      neighbours.insert(neighbours.end(), en, en + mesh.element_size(e));
      if (d.prow[e] >= 0) element_owner[e] == d.rank ? ++in_p : ++out_p;
    }
    for (int g : groups[local[n]])
      neighbours.insert(neighbours.end(), couplings.nodes.begin() + couplings.offsets[g],
                        couplings.nodes.begin() + couplings.offsets[g + 1]);
    std::sort(neighbours.begin(), neighbours.end());
    neighbours.erase(std::unique(neighbours.begin(), neighbours.end()), neighbours.end());
    for (int m : neighbours)
      for (int j = 0; j < 3; ++j)
        if (eq[3 * m + j] >= 0) node_owner[m] == d.rank ? ++in : ++out;
    for (int i = 0; i < 3; ++i)
      if (eq[3 * n + i] >= 0) {
        d.dnz[d.urow[3 * n + i] - row0] = in;
        d.onz[d.urow[3 * n + i] - row0] = out;
        if (d.mixed_rows) {
          d.dnz_p[d.urow[3 * n + i] - row0] = in_p;
          d.onz_p[d.urow[3 * n + i] - row0] = out_p;
        }
      }
  }
  for (int e : mixed_elements) {
    if (element_owner[e] != d.rank) continue;
    PetscInt in = 0, out = 0;
    const int* en = mesh.element_nodes(e);
    for (int a = 0; a < mesh.element_size(e); ++a)
      for (int j = 0; j < 3; ++j)
        if (eq[3 * en[a] + j] >= 0) node_owner[en[a]] == d.rank ? ++in : ++out;
    d.dnz[d.prow[e] - row0] = in;
    d.onz[d.prow[e] - row0] = out;
    d.dnz_p[d.prow[e] - row0] = 1;  // its own diagonal
  }
}

void PetscSolver::accept_new_entries(const Couplings& couplings) {
  Data& d = *d_;
  // The next fill goes through MatSetValues (the direct fill of a final pattern would write into arrays
  // that a new entry reallocates) and, before its assembly, adds explicit zeros on every pair of the
  // couplings' free dofs in this rank's rows: the pattern then holds every entry the couplings may
  // take, also those of points not yet in contact, and the direct fill is safe again after it.
  d.pattern_final = false;
  d.new_couplings = couplings;
  Mat target = d.nest ? d.nest->block(0, 0) : d.A;  // a contribution's entries lie in the displacement block
  if (target) check(MatSetOption(target, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_FALSE), "MatSetOption (new couplings)");
}

void PetscSolver::Data::add_coupling_zeros() {
  Data& d = *this;
  const std::vector<int>& eq = d.dofs->eq;
  std::vector<PetscInt> rows, cols;
  std::vector<PetscScalar> zeros;
  const Couplings& c = d.new_couplings;
  for (int g = 0; g < c.size(); ++g) {
    rows.clear();
    cols.clear();
    for (int k = c.offsets[g]; k < c.offsets[g + 1]; ++k)
      for (int i = 0; i < 3; ++i) {
        const int dof = 3 * c.nodes[k] + i;
        if (eq[dof] < 0) continue;  // prescribed: its row is the identity, its column the predictor's
        cols.push_back(d.urow[dof]);
        if (d.node_owner[c.nodes[k]] == d.rank) rows.push_back(d.urow[dof]);
      }
    zeros.assign(rows.size() * cols.size(), 0.0);
    if (!rows.empty()) d.set_values(PetscInt(rows.size()), rows.data(), PetscInt(cols.size()), cols.data(), zeros.data(), ADD_VALUES);
  }
  d.new_couplings = Couplings{};
}

void PetscSolver::begin_fill() {
  Data& d = *d_;
  if (d.nest) d.nest->zero();
  else check(MatZeroEntries(d.A), "MatZeroEntries");
  d.pending.clear();
  d.begin_direct_fill();
  if (d.bddc && d.bddc_flux) d.flux_weights.assign(std::size_t(d.subdomains->local_dofs()), 0.0);
  d.lagged_fill = d.schur_pre && d.fills[0].active() && !d.lagged_diagonal.empty();
  if (d.lagged_fill) {
    if (!d.gamma_diagonal) check(VecDuplicate(d.x, &d.gamma_diagonal), "VecDuplicate");
    check(VecSet(d.gamma_diagonal, 0.0), "VecSet");
    if (d.size == 1) {
      check(VecGetArray(d.gamma_diagonal, &d.gamma_values), "VecGetArray");
      PetscInt npl = 0;
      check(MatGetLocalSize(d.schur_pre, &npl, nullptr), "MatGetLocalSize");
      d.schur_values.assign(std::size_t(npl), std::numeric_limits<double>::quiet_NaN());
    }
  }
}

bool PetscSolver::concurrent_fill() const {
  const Data& d = *d_;
  return d.size == 1 && d.fills[0].active() && (!d.schur_pre || d.lagged_fill);
}

void PetscSolver::Data::ElementRows::sort_ascending() {
  for (int i = 1; i < nf; ++i)
    for (int j = i; j > 0 && rows[j - 1] > rows[j]; --j) {
      std::swap(rows[j - 1], rows[j]);
      std::swap(pos[j - 1], pos[j]);
    }
}

PetscSolver::Data::ElementRows PetscSolver::Data::element_rows(int nn, const int* nodes) const {
  // The free dofs' rows: the system's, or under BDDC the subdomain's local numbering.
  const std::vector<int>& eq = dofs->eq;
  ElementRows er;
  for (int q = 0; q < 3 * nn; ++q) {
    const int g = 3 * nodes[q / 3] + q % 3;
    if (eq[g] < 0) continue;
    er.pos[er.nf] = q;
    er.rows[er.nf++] = bddc ? subdomains->row(g) : urow[g];
  }
  return er;
}

void PetscSolver::Data::add_subdomain_element(const ElementRows& er, int nd, const double* Ke, const double* dk, double volume) {
  // The condensed element matrix Ke whole into the subdomain's, and V_e d into its flux weights.
  const int nf = er.nf;
  std::array<PetscScalar, 30 * 30> v;
  for (int i = 0; i < nf; ++i)
    for (int j = 0; j < nf; ++j) v[i * nf + j] = Ke[er.pos[i] + nd * er.pos[j]];
  check(MatSetValuesLocal(A, nf, er.rows.data(), nf, er.rows.data(), v.data(), ADD_VALUES), "MatSetValuesLocal");
  if (dk && !flux_weights.empty())
    for (int i = 0; i < nf; ++i) flux_weights[std::size_t(er.rows[i])] += volume * dk[er.pos[i]];
}

void PetscSolver::add_element(int e, int nn, const int* nodes, const double* Ke, const double* dk, double c, double volume) {
  Data& d = *d_;
  const int nd = 3 * nn;
  Data::ElementRows er = d.element_rows(nn, nodes);
  if (er.nf == 0) return;
  if (d.bddc) {
    d.add_subdomain_element(er, nd, Ke, dk, volume);
    return;
  }
  // Ascending rows and columns: PETSc's row insertion then finds each column by a forward search from
  // the previous one instead of a new bisection (the one-process fill took 2x the CSC scatter's time).
  er.sort_ascending();
  const int nf = er.nf;
  std::array<int, 30>& pos = er.pos;
  std::array<PetscInt, 31>& rows = er.rows;
  // A three-field element's distinct free rows and the sums s of d over each (degenerate hexes repeat
  // a node), for its augmentation.
  const bool augmented = dk && d.schur_pre != nullptr;
  Data::PendingElement pe;
  Data::Augmentation aug;
  if (augmented) {
    pe.prow = d.prow[e];
    pe.c = c;
    for (int i = 0; i < nf; ++i) {
      int j = 0;
      while (j < pe.n && pe.rows[j] != rows[i]) ++j;
      if (j == pe.n) {
        pe.rows[pe.n] = rows[i];
        pe.s[pe.n++] = 0.0;
      }
      pe.s[j] += dk[pos[i]];
    }
    if (d.lagged_fill) aug = d.augmentation(pe, d.lagged_diagonal.data(), d.lagged_mean);
  }
  // What leaves the displacement block for the pressure: c, less the part γ kept on u (at once when
  // γ is known, else added in finish_augmented_split).
  const double c_out = d.lagged_fill && augmented ? aug.kept : c;
  std::array<PetscScalar, 31 * 31> v;  // row-major, PETSc's default orientation
  for (int i = 0; i < nf; ++i)
    for (int j = 0; j < nf; ++j) v[i * nf + j] = Ke[pos[i] + nd * pos[j]] - (dk ? c_out * dk[pos[i]] * dk[pos[j]] : 0.0);
  d.add_block(false, nf, rows.data(), false, nf, rows.data(), v.data());
  if (!dk) return;
  double s = 0.0;
  for (int i = 0; i < nf; ++i) s += dk[pos[i]] * dk[pos[i]];
  const double dn = s > 0.0 ? std::sqrt(s) : 1.0;
  pe.dn = dn;
  const PetscInt pr = d.prow[e];
  for (int i = 0; i < nf; ++i) v[i] = dk[pos[i]] / dn;
  d.add_block(false, nf, rows.data(), true, 1, &pr, v.data());
  // With the augmented split the pressure row carries c̃ = c − γ; without the previous diag(A), zeros
  // now (so the pattern survives the first assembly) and the values in finish_augmented_split.
  for (int i = 0; i < nf; ++i) v[i] = !augmented ? c * dn * dk[pos[i]] : d.lagged_fill ? aug.kept * dn * dk[pos[i]] : 0.0;
  v[nf] = -1.0;
  d.add_block(true, 1, &pr, false, nf, rows.data(), v.data());
  d.add_block(true, 1, &pr, true, 1, &pr, &v[nf]);
  if (!augmented) return;
  if (!d.lagged_fill) {
    d.pending.push_back(pe);
    return;
  }
  std::array<PetscScalar, 30> g;
  for (int i = 0; i < pe.n; ++i) g[i] = aug.gamma * pe.s[i] * pe.s[i];
  if (d.gamma_values) {
    for (int i = 0; i < pe.n; ++i) d.gamma_values[pe.rows[i]] += g[i];  // one process: rows from 0
  } else {
    check(VecSetValues(d.gamma_diagonal, pe.n, pe.rows.data(), g.data(), ADD_VALUES), "VecSetValues");
  }
  d.set_schur_diagonal(pe, aug);
}

double PetscSolver::mean_free_diagonal(bool gather, bool without_gamma) {
  Data& d = *d_;
  const std::vector<int>& eq = d.dofs->eq;
  Vec diag;
  check(VecDuplicate(d.x, &diag), "VecDuplicate");
  check(MatGetDiagonal(d.A, diag), "MatGetDiagonal");
  if (without_gamma) check(VecAXPY(diag, -1.0, d.gamma_diagonal), "VecAXPY");
  const PetscScalar* dv;
  check(VecGetArrayRead(diag, &dv), "VecGetArrayRead");
  double sum = 0.0;
  for (std::size_t i = 0; i < d.owned_dofs.size(); ++i)
    if (eq[d.owned_dofs[i]] >= 0) sum += std::abs(dv[i]);
  check(VecRestoreArrayRead(diag, &dv), "VecRestoreArrayRead");
  if (gather) {
    check(VecScatterBegin(d.to_all, diag, d.all, INSERT_VALUES, SCATTER_FORWARD), "VecScatterBegin");
    check(VecScatterEnd(d.to_all, diag, d.all, INSERT_VALUES, SCATTER_FORWARD), "VecScatterEnd");
  }
  VecDestroy(&diag);
  MPI_Allreduce(MPI_IN_PLACE, &sum, 1, MPI_DOUBLE, MPI_SUM, d.comm);
  const int nfree = d.dofs->num_free;
  return nfree > 0 && sum > 0.0 ? sum / nfree : 1.0;
}

void PetscSolver::keep_diagonal(bool without_gamma) {
  Data& d = *d_;
  d.lagged_mean = mean_free_diagonal(true, without_gamma);
  const PetscScalar* da;
  PetscInt n = 0;
  check(VecGetLocalSize(d.all, &n), "VecGetLocalSize");
  check(VecGetArrayRead(d.all, &da), "VecGetArrayRead");
  d.lagged_diagonal.assign(da, da + n);
  check(VecRestoreArrayRead(d.all, &da), "VecRestoreArrayRead");
}

void PetscSolver::finish_augmented_split() {
  Data& d = *d_;
  // diag(A) of the displacement block without volumetric stiffness, on every rank (the elements' rows
  // may belong to a neighbour), and its mean magnitude over the free rows for the floor, as in
  // Data::augmentation; kept for the fills to come.
  keep_diagonal(false);
  // In the element order (the threads of the one-process fill append in any order): the sums of the
  // γ terms are then the same in every run.
  std::sort(d.pending.begin(), d.pending.end(),
            [](const Data::PendingElement& a, const Data::PendingElement& b) { return a.prow < b.prow; });
  std::array<PetscScalar, 30 * 30> v;
  d.begin_direct_fill();
  for (const Data::PendingElement& pe : d.pending) {
    const Data::Augmentation a = d.augmentation(pe, d.lagged_diagonal.data(), d.lagged_mean);
    for (int i = 0; i < pe.n; ++i)
      for (int j = 0; j < pe.n; ++j) v[i * pe.n + j] = a.gamma * pe.s[i] * pe.s[j];
    d.add_block(false, pe.n, pe.rows.data(), false, pe.n, pe.rows.data(), v.data());
    for (int i = 0; i < pe.n; ++i) v[i] = a.kept * pe.dn * pe.s[i];
    d.add_block(true, 1, &pe.prow, false, pe.n, pe.rows.data(), v.data());
    d.set_schur_diagonal(pe, a);
  }
  d.end_direct_fill();
  check(MatAssemblyBegin(d.A, MAT_FINAL_ASSEMBLY), "MatAssemblyBegin");
  check(MatAssemblyEnd(d.A, MAT_FINAL_ASSEMBLY), "MatAssemblyEnd");
  check(MatAssemblyBegin(d.schur_pre, MAT_FINAL_ASSEMBLY), "MatAssemblyBegin");
  check(MatAssemblyEnd(d.schur_pre, MAT_FINAL_ASSEMBLY), "MatAssemblyEnd");
}

void PetscSolver::finish_lagged_augmentation() {
  Data& d = *d_;
  if (d.gamma_values) check(VecRestoreArray(d.gamma_diagonal, &d.gamma_values), "VecRestoreArray");
  d.gamma_values = nullptr;
  if (!d.schur_values.empty()) {
    PetscInt lo = 0;
    check(MatGetOwnershipRange(d.schur_pre, &lo, nullptr), "MatGetOwnershipRange");
    for (std::size_t k = 0; k < d.schur_values.size(); ++k)
      if (!std::isnan(d.schur_values[k])) {
        const PetscInt row = lo + PetscInt(k);
        check(MatSetValue(d.schur_pre, row, row, d.schur_values[k], INSERT_VALUES), "MatSetValue");
      }
    d.schur_values.clear();
  }
  check(VecAssemblyBegin(d.gamma_diagonal), "VecAssemblyBegin");
  check(VecAssemblyEnd(d.gamma_diagonal), "VecAssemblyEnd");
  check(MatAssemblyBegin(d.schur_pre, MAT_FINAL_ASSEMBLY), "MatAssemblyBegin");
  check(MatAssemblyEnd(d.schur_pre, MAT_FINAL_ASSEMBLY), "MatAssemblyEnd");
  keep_diagonal(true);  // diag(A) without this fill's γ terms, for the next one
}

void PetscSolver::add_entry(int row_dof, int col_dof, double v) {
  Data& d = *d_;
  if (d.bddc) {
    if (!d.subdomains->adds_coupling(row_dof / 3, col_dof / 3)) return;
    const PetscInt r = d.subdomains->row(row_dof), c = d.subdomains->row(col_dof);
    check(MatSetValuesLocal(d.A, 1, &r, 1, &c, &v, ADD_VALUES), "MatSetValuesLocal");
    return;
  }
  if (d.node_owner[row_dof / 3] != d.rank) return;
  const PetscInt r = d.urow[row_dof], c = d.urow[col_dof];
  d.set_values(1, &r, 1, &c, &v, ADD_VALUES);
}

void PetscSolver::set_bddc_constraints() {
  Data& d = *d_;
  // The flux weights w of the subdomains' faces: this subdomain's Σ_e ∂v_e/∂u at its own nodes, each
  // node's taken from the rank owning its rows (node_owners: the lowest rank holding it). On a face
  // between two subdomains the two sides' sums differ only in sign (the elements around an interior node
  // sum to zero), so either side's restriction is the face's flux ∫_F u·n da up to sign.
  bool any = std::any_of(d.flux_weights.begin(), d.flux_weights.end(), [](double w) { return w != 0.0; });
  MPI_Allreduce(MPI_IN_PLACE, &any, 1, MPI_C_BOOL, MPI_LOR, d.comm);
  PetscInt n_rigid = 0;
  const Vec* rigid = nullptr;
  check(MatNullSpaceGetVecs(d.rigid_modes, nullptr, &n_rigid, &rigid), "MatNullSpaceGetVecs");
  std::vector<Vec> modes(rigid, rigid + n_rigid);
  Vec flux = nullptr;
  if (any) {  // a three-field element somewhere (a compressible mesh has none: the modes alone)
    check(MatCreateVecs(d.A, &flux, nullptr), "MatCreateVecs");
    PetscInt lo = 0, hi = 0;
    check(VecGetOwnershipRange(flux, &lo, &hi), "VecGetOwnershipRange");
    PetscScalar* owned = nullptr;
    check(VecGetArray(flux, &owned), "VecGetArray");
    for (PetscInt r = 0; r < d.subdomains->local_dofs(); ++r) {
      const PetscInt g = d.subdomains->global_row(r);
      if (g >= lo && g < hi) owned[g - lo] = d.flux_weights[std::size_t(r)];
    }
    check(VecRestoreArray(flux, &owned), "VecRestoreArray");
    // Orthonormal to the (orthonormal) rigid-body modes, as a near-nullspace's vectors must be; the span
    // on every face, hence the constraints, stays the same.
    std::vector<PetscScalar> dots(modes.size());
    check(VecMDot(flux, PetscInt(modes.size()), modes.data(), dots.data()), "VecMDot");
    for (PetscScalar& c : dots) c = -c;
    check(VecMAXPY(flux, PetscInt(modes.size()), dots.data(), modes.data()), "VecMAXPY");
    PetscReal norm = 0.0;
    check(VecNormalize(flux, &norm), "VecNormalize");
    if (norm > 0.0) modes.push_back(flux);
  }
  MatNullSpace space = nullptr;
  check(MatNullSpaceCreate(d.comm, PETSC_FALSE, PetscInt(modes.size()), modes.data(), &space), "MatNullSpaceCreate");
  check(MatSetNearNullSpace(d.A, space), "MatSetNearNullSpace");
  MatNullSpaceDestroy(&space);
  if (flux) VecDestroy(&flux);
}

void PetscSolver::end_fill() {
  Data& d = *d_;
  const std::vector<int>& eq = d.dofs->eq;
  d.end_direct_fill();
  if (!d.new_couplings.empty()) d.add_coupling_zeros();
  auto add_dirichlet = [&](double value) {
    if (d.bddc) {  // shared among the subdomains that hold the node: the sum is the value
      const std::vector<PetscInt>& rows = d.subdomains->prescribed();
      for (std::size_t k = 0; k < rows.size(); ++k) {
        const double share = value * d.subdomains->prescribed_share()[k];
        check(MatSetValuesLocal(d.A, 1, &rows[k], 1, &rows[k], &share, ADD_VALUES), "MatSetValuesLocal");
      }
      return;
    }
    for (PetscInt g : d.owned_dofs)
      if (eq[g] < 0) d.set_values(1, &d.urow[g], 1, &d.urow[g], &value, ADD_VALUES);
  };
  // (The first assembly keeps only the entries set, so the prescribed diagonals are set to 0 first.)
  add_dirichlet(d.diagonal_known ? d.dirichlet_diagonal : 0.0);
  check(MatAssemblyBegin(d.A, MAT_FINAL_ASSEMBLY), "MatAssemblyBegin");
  check(MatAssemblyEnd(d.A, MAT_FINAL_ASSEMBLY), "MatAssemblyEnd");
  if (d.bddc_flux) set_bddc_constraints();
  if (d.diagonal_known) {
    if (d.schur_pre) d.lagged_fill ? finish_lagged_augmentation() : finish_augmented_split();
    d.pattern_final = true;  // again, after a fill that took new entries (accept_new_entries)
    return;
  }
  // The Dirichlet rows' diagonal: the mean free diagonal of the first tangent (as in factorize).
  d.dirichlet_diagonal = mean_free_diagonal(false);
  d.diagonal_known = true;
  add_dirichlet(d.dirichlet_diagonal);
  check(MatAssemblyBegin(d.A, MAT_FINAL_ASSEMBLY), "MatAssemblyBegin");
  check(MatAssemblyEnd(d.A, MAT_FINAL_ASSEMBLY), "MatAssemblyEnd");
  if (d.schur_pre) finish_augmented_split();
  d.pattern_final = true;
}

}  // namespace softhom::fe
