#pragma once
// Compressed-column sparse matrices with a fixed pattern (built once per mesh and constraint set),
// and the sparse direct solvers of SuiteSparse behind one interface. The symbolic analysis is done
// once per pattern and reused by every Newton iteration.
#include <memory>
#include <string>
#include <vector>

#include "softhom/fe/mesh.hpp"

struct cholmod_common_struct;  // CHOLMOD's workspace (cholmod.h)

namespace softhom::fe {

/// Square CSC matrix; row indices sorted within each column.
struct CscMatrix {
  int n = 0;
  std::vector<int> colptr;  ///< n + 1
  std::vector<int> rowind;  ///< nnz
  std::vector<double> values;
  /// Position of the transposed entry (col, row) of every stored entry, or empty when the pattern is
  /// not structurally symmetric (build_pattern fills it). Lets y = A x run row-wise in parallel and
  /// CHOLMOD factorize the symmetric part.
  std::vector<long> mirror;

  long nnz() const { return long(rowind.size()); }
  /// Position of (row, col) in values, or -1 when outside the pattern (binary search).
  long find(int row, int col) const;
  void set_zero();
  /// y = A x (all stored entries); OpenMP-parallel over rows when `mirror` is set.
  void multiply(const double* x, double* y) const;
  /// Fills `mirror` (requires a structurally symmetric pattern; throws otherwise).
  void build_mirror();
};

/// Equation numbers: eq[dof] ≥ 0 for a free dof, −1 for a prescribed one. Free dofs are numbered in
/// increasing dof order, so node-major adjacency yields sorted CSC columns.
struct DofMap {
  std::vector<int> eq;
  int num_free = 0;
  static DofMap from_constrained(int num_dofs, const std::vector<char>& constrained);
};

struct Couplings;  // contribution.hpp

/// Pattern of the stiffness restricted to free dofs: every pair of dofs sharing an element, or (the
/// second form) a group of `couplings` as well.
CscMatrix build_pattern(const Mesh& mesh, const DofMap& dofs);
CscMatrix build_pattern(const Mesh& mesh, const DofMap& dofs, const Couplings& couplings);

/// automatic: CHOLMOD (LU when it fails) below NewtonOptions::petsc_min_dofs free dofs, PETSc above;
/// petsc: Krylov + AMG over MPI (fe/src/petsc_solve.hpp).
enum class SolverKind { automatic, cholmod, umfpack, petsc };
/// The petsc solver's preconditioner ([solver] petsc_preconditioner; NewtonOptions).
enum class PetscPreconditioner { automatic, field_split, lu, bddc };
const char* to_string(SolverKind kind);

/// Times of the last run of each phase, accumulated over calls [s].
struct SolverTimes {
  double analysis = 0.0, factorization = 0.0, solve = 0.0;
  int factorizations = 0, solves = 0;
  double flops = 0.0;       ///< floating-point operations of all numeric factorizations
  double factor_nnz = 0.0;  ///< entries of the last factor (L, or L + U)
};

class LinearSolver {
 public:
  virtual ~LinearSolver() = default;
  /// Symbolic analysis (fill-reducing ordering) of the pattern; called once.
  virtual void analyze(const CscMatrix& A) = 0;
  /// Numeric factorization of A (same pattern as analyze). Returns false when the matrix is not
  /// factorizable by this method (singular; not positive definite for CHOLMOD).
  virtual bool factorize(const CscMatrix& A) = 0;
  /// x = A⁻¹ b with the last factorization (may be called several times per factorization).
  virtual void solve(const std::vector<double>& b, std::vector<double>& x) = 0;
  virtual SolverKind kind() const = 0;
  /// Floating-point operations of one numeric factorization as predicted by the analysis (0: unknown).
  virtual double predicted_flops() const { return 0.0; }
  /// Estimate of the reciprocal condition number of the last factorization (the ratio of its smallest
  /// to largest pivot; 0 for a singular matrix).
  virtual double reciprocal_condition() const = 0;
  const SolverTimes& times() const { return times_; }

 protected:
  SolverTimes times_;
};

/// CHOLMOD (supernodal LLᵀ of the symmetric part (A + Aᵀ)/2, so a nearly symmetric A gives a
/// preconditioner; fill-reducing ordering: the better of AMD and METIS) or UMFPACK (general LU).
std::unique_ptr<LinearSolver> make_linear_solver(SolverKind kind);

/// The CHOLMOD solver's factorization settings (supernodal LLᵀ, the better of AMD and METIS, its
/// supernode amalgamation) on a started workspace, for tools that run CHOLMOD's analysis on softhom's
/// patterns themselves.
void apply_cholmod_settings(cholmod_common_struct& common);

}  // namespace softhom::fe
