// The PETSc linear solver (petsc_solve.hpp): distributed tangent, GMRES + GAMG with the rigid-body
// near-nullspace, and PETSc's life cycle.
#include "petsc_solve.hpp"

#include <petscksp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <stdexcept>

namespace softhom::fe {
namespace {

bool g_initialised = false, g_finalised = false;

/// A failed PETSc call is a broken build or an exhausted machine, not a user error.
void check(PetscErrorCode code, const char* what) {
  if (code != 0) throw std::runtime_error(std::string("PETSc: ") + what + " failed (error " + std::to_string(int(code)) + ")");
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// Default settings, inserted before the user's options (which override them). Right preconditioning:
/// the tolerance is on the true residual ‖b − A x‖/‖b‖, as for the CHOLMOD path's GMRES. GMRES: the
/// follower-pressure tangent is unsymmetric. GAMG with its Chebyshev/Jacobi smoothers and the rigid-body
/// near-nullspace (measured Krylov counts: BENCHMARKS.md, "Macro solver on PETSc").
constexpr const char* kDefaults =
    "-ksp_type gmres -ksp_gmres_restart 200 -ksp_pc_side right -ksp_max_it 2000 "
    "-pc_type gamg -pc_gamg_agg_nsmooths 1 -pc_gamg_threshold 0.0 -pc_gamg_reuse_interpolation false "
    "-mg_levels_ksp_type chebyshev -mg_levels_pc_type jacobi -mg_levels_ksp_max_it 2";

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

struct PetscSolver::Data {
  MPI_Comm comm = MPI_COMM_NULL;  // PETSC_COMM_WORLD once PETSc is up
  int rank = 0, size = 1;
  PetscInt ndof = 0, lo = 0, hi = 0;  // owned dof range [lo, hi)
  std::vector<int> dof_of_eq;         // free equation → dof
  const DofMap* dofs = nullptr;
  std::vector<double> coords;         // owned nodes' coordinates (near-nullspace)
  Mat A = nullptr;
  KSP ksp = nullptr;
  Vec b = nullptr, x = nullptr, all = nullptr;
  VecScatter to_all = nullptr;
  double dirichlet_diagonal = 1.0;
  double option_rtol = 0.0;  // -ksp_rtol of the options (0: none)
  std::vector<PetscInt> cols;
  std::vector<PetscScalar> vals;
};

PetscSolver::PetscSolver(const Mesh& mesh, const DofMap& dofs, const std::string& options) : d_(std::make_unique<Data>()) {
  petsc_initialize();
  Data& d = *d_;
  d.comm = PETSC_COMM_WORLD;
  MPI_Comm_rank(d.comm, &d.rank);
  MPI_Comm_size(d.comm, &d.size);
  const PetscInt nn = mesh.num_nodes();
  d.ndof = 3 * nn;
  d.lo = 3 * (nn * d.rank / d.size);
  d.hi = 3 * (nn * (d.rank + 1) / d.size);
  d.dofs = &dofs;
  d.dof_of_eq.assign(dofs.num_free, -1);
  for (int k = 0; k < int(dofs.eq.size()); ++k)
    if (dofs.eq[k] >= 0) d.dof_of_eq[dofs.eq[k]] = k;
  for (PetscInt n = d.lo / 3; n < d.hi / 3; ++n)
    for (int i = 0; i < 3; ++i) d.coords.push_back(mesh.nodes[n][i]);
  check(PetscOptionsInsertString(nullptr, kDefaults), "PetscOptionsInsertString (defaults)");
  if (!options.empty() && PetscOptionsInsertString(nullptr, options.c_str()) != 0)
    throw std::invalid_argument("solver.petsc_options: PETSc cannot parse \"" + options + "\"");
  PetscBool set = PETSC_FALSE;
  PetscReal rtol = 0.0;
  PetscOptionsGetReal(nullptr, nullptr, "-ksp_rtol", &rtol, &set);
  if (set && options.find("-ksp_rtol") != std::string::npos) d.option_rtol = rtol;
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
  return std::string(kt ? kt : "?") + " + " + (pt ? pt : "?");
}

void PetscSolver::analyze(const CscMatrix& K) {
  const auto t0 = std::chrono::steady_clock::now();
  Data& d = *d_;
  const std::vector<int>& eq = d.dofs->eq;
  const PetscInt nlocal = d.hi - d.lo;
  // Preallocation per owned row: row r of K is column r's pattern (structurally symmetric).
  std::vector<PetscInt> dnz(nlocal, 1), onz(nlocal, 0);
  for (PetscInt g = d.lo; g < d.hi; ++g) {
    const int r = eq[g];
    if (r < 0) continue;
    PetscInt in = 0, out = 0;
    for (int k = K.colptr[r]; k < K.colptr[r + 1]; ++k) {
      const int c = d.dof_of_eq[K.rowind[k]];
      (c >= d.lo && c < d.hi) ? ++in : ++out;
    }
    dnz[g - d.lo] = in;
    onz[g - d.lo] = out;
  }
  check(MatCreate(d.comm, &d.A), "MatCreate");
  check(MatSetSizes(d.A, nlocal, nlocal, d.ndof, d.ndof), "MatSetSizes");
  check(MatSetType(d.A, MATAIJ), "MatSetType");
  check(MatSetBlockSize(d.A, 3), "MatSetBlockSize");
  check(MatSeqAIJSetPreallocation(d.A, 0, dnz.data()), "MatSeqAIJSetPreallocation");
  check(MatMPIAIJSetPreallocation(d.A, 0, dnz.data(), 0, onz.data()), "MatMPIAIJSetPreallocation");
  check(MatSetOption(d.A, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_TRUE), "MatSetOption");
  // Rigid-body modes from the owned nodes' coordinates: GAMG's near-nullspace (three translations and
  // three rotations; without them smoothed aggregation sees a scalar Laplacian per component and its
  // counts grow with the mesh).
  Vec xyz;
  check(VecCreateMPIWithArray(d.comm, 3, nlocal, d.ndof, d.coords.data(), &xyz), "VecCreateMPIWithArray");
  MatNullSpace nsp;
  check(MatNullSpaceCreateRigidBody(xyz, &nsp), "MatNullSpaceCreateRigidBody");
  check(MatSetNearNullSpace(d.A, nsp), "MatSetNearNullSpace");
  MatNullSpaceDestroy(&nsp);
  VecDestroy(&xyz);
  check(MatCreateVecs(d.A, &d.x, &d.b), "MatCreateVecs");
  check(VecScatterCreateToAll(d.x, &d.to_all, &d.all), "VecScatterCreateToAll");
  check(KSPCreate(d.comm, &d.ksp), "KSPCreate");
  check(KSPSetFromOptions(d.ksp), "KSPSetFromOptions");
  // The Dirichlet rows' diagonal: the mean free diagonal of the first tangent (set in factorize), so
  // the identity rows neither dominate nor vanish in the smoothers.
  times_.analysis += seconds_since(t0);
}

bool PetscSolver::factorize(const CscMatrix& K) {
  const auto t0 = std::chrono::steady_clock::now();
  Data& d = *d_;
  const std::vector<int>& eq = d.dofs->eq;
  if (times_.factorizations == 0) {
    double sum = 0.0;
    for (int c = 0; c < K.n; ++c) {
      const long k = K.find(c, c);
      if (k >= 0) sum += std::abs(K.values[k]);
    }
    d.dirichlet_diagonal = K.n > 0 && sum > 0.0 ? sum / K.n : 1.0;
  }
  for (PetscInt g = d.lo; g < d.hi; ++g) {
    const int r = eq[g];
    if (r < 0) {
      check(MatSetValue(d.A, g, g, d.dirichlet_diagonal, INSERT_VALUES), "MatSetValue");
      continue;
    }
    d.cols.clear();
    d.vals.clear();
    // K(r, c) is stored at the transposed position of column r's entry (c, r).
    for (int k = K.colptr[r]; k < K.colptr[r + 1]; ++k) {
      d.cols.push_back(d.dof_of_eq[K.rowind[k]]);
      d.vals.push_back(K.values[K.mirror.empty() ? K.find(r, K.rowind[k]) : K.mirror[k]]);
    }
    const PetscInt row = g;
    check(MatSetValues(d.A, 1, &row, PetscInt(d.cols.size()), d.cols.data(), d.vals.data(), INSERT_VALUES), "MatSetValues");
  }
  check(MatAssemblyBegin(d.A, MAT_FINAL_ASSEMBLY), "MatAssemblyBegin");
  check(MatAssemblyEnd(d.A, MAT_FINAL_ASSEMBLY), "MatAssemblyEnd");
  check(KSPSetOperators(d.ksp, d.A, d.A), "KSPSetOperators");
  // The multigrid hierarchy of this tangent now (its cost is the "factorization" of this solver).
  check(KSPSetUp(d.ksp), "KSPSetUp");
  times_.factorization += seconds_since(t0);
  ++times_.factorizations;
  times_.factor_nnz = 0.0;
  return true;
}

void PetscSolver::solve(const std::vector<double>& b, std::vector<double>& x) {
  const KrylovOutcome o = solve(b, x, 1e-12);
  if (!o.converged) throw std::runtime_error("PETSc: the linear solve did not converge (" + o.reason + ")");
}

KrylovOutcome PetscSolver::solve(const std::vector<double>& b, std::vector<double>& x, double rtol) {
  const auto t0 = std::chrono::steady_clock::now();
  Data& d = *d_;
  const std::vector<int>& eq = d.dofs->eq;
  PetscScalar* bv;
  check(VecGetArray(d.b, &bv), "VecGetArray");
  for (PetscInt g = d.lo; g < d.hi; ++g) bv[g - d.lo] = eq[g] >= 0 ? b[eq[g]] : 0.0;
  check(VecRestoreArray(d.b, &bv), "VecRestoreArray");
  if (d.option_rtol > 0.0) rtol = std::min(rtol, d.option_rtol);
  PetscInt maxit;
  PetscReal r0, a0, dt0;
  KSPGetTolerances(d.ksp, &r0, &a0, &dt0, &maxit);
  check(KSPSetTolerances(d.ksp, rtol, 1e-300, PETSC_DEFAULT, maxit), "KSPSetTolerances");
  check(KSPSolve(d.ksp, d.b, d.x), "KSPSolve");
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
  for (std::size_t k = 0; k < d.dof_of_eq.size(); ++k) x[k] = av[d.dof_of_eq[k]];
  check(VecRestoreArrayRead(d.all, &av), "VecRestoreArrayRead");
  times_.solve += seconds_since(t0);
  ++times_.solves;
  return o;
}

}  // namespace softhom::fe
