#pragma once
// The one object that solves fe::Simulation's linear systems, made from a LinearSolverChoice
// (softhom/fe/linear_solver.hpp): the sparse direct factor of the cholmod and umfpack routes, or the
// PETSc solver of the petsc route (petsc_solve.hpp).
#include <memory>
#include <string>

#include "softhom/fe/linear_solver.hpp"
#include "softhom/fe/mesh.hpp"
#include "softhom/fe/sparse.hpp"
#include "failure_backoff.hpp"

namespace softhom::fe {

/// The factor of the direct routes: CHOLMOD's LLᵀ of the symmetric part (cholmod route) with, made on
/// demand for the steps where that part is not positive definite, MUMPS's LDLᵀ of the symmetric part
/// where the tangent is symmetric up to kLdltSkew (LinearSolverChoice::symmetric_indefinite) and a
/// factorization succeeded before, else UMFPACK's LU; or LU alone (umfpack route). Each factorization analyses its pattern once, at its first
/// use. times() sums all three.
class SparseDirectSolver final : public LinearSolver {
 public:
  SparseDirectSolver(LinearRoute route, bool symmetric_indefinite);
  /// A new load step: Cholesky is tried again, unless the last steps found the symmetric part
  /// indefinite in a row: after k such steps the next 2^(k−1) − 1 (at most 7) go to the indefinite
  /// factorization at once. A failed supernodal Cholesky costs up to a whole factorization, and through
  /// the fine aneurysm's Gent locking every step's first one failed (28 of 70 factorizations).
  void begin_step();
  /// The matrix's pattern changed (a moving contact set): every factorization analyses it again.
  void new_pattern() { cholesky_analyzed_ = ldlt_analyzed_ = lu_analyzed_ = false; }
  /// The Cholesky analysis (once), so that predicted_flops() knows the first factorization's cost.
  void analyze(const CscMatrix& A) override;
  /// Cholesky of the symmetric part unless this step already found it indefinite; else LDLᵀ of the
  /// symmetric part of a (nearly) symmetric tangent, LU of any other or where LDLᵀ fails.
  bool factorize(const CscMatrix& A) override;
  void solve(const std::vector<double>& b, std::vector<double>& x) override;
  /// The factorization holding the current factor (the one the next factorize starts with before any).
  SolverKind kind() const override;
  /// CHOLMOD's prediction while Cholesky is in use (after analyze), else 0.
  double predicted_flops() const override;
  double reciprocal_condition() const override;
  /// Flops of the last factorization that produced the current factor (a failed Cholesky not counted).
  double last_factor_flops() const { return last_flops_; }
  /// The last factorize fell back from Cholesky to LDLᵀ or LU (the symmetric part is indefinite).
  bool fell_back() const { return fell_back_; }
  /// Numeric factorizations of the factorization holding the current factor.
  int current_factorizations() const { return current_ ? current_->times().factorizations : 0; }
  /// The factorizations used, with their counts, e.g. "cholmod 12 + mumps-ldlt 30" (the run's summary).
  std::string description() const;

 private:
  bool cholesky_now() const { return cholesky_ && !indefinite_this_step_; }
  bool factorize_with(LinearSolver& s, bool& analyzed, const CscMatrix& A);
  void sum_times();
  std::unique_ptr<LinearSolver> cholesky_, ldlt_, lu_;
  LinearSolver* current_ = nullptr;
  bool symmetric_indefinite_ = false;
  bool cholesky_analyzed_ = false, ldlt_analyzed_ = false, lu_analyzed_ = false;
  bool indefinite_this_step_ = false, fell_back_ = false;
  FailureBackoff cholesky_backoff_{1};  ///< steps that start with the indefinite factorization
  bool factorized_ = false;  ///< a factorization succeeded (the first one is never LDLᵀ)
  double last_flops_ = 0.0;
};

/// The largest skew entry |A_ij − A_ji| relative to the largest entry of A under which the cholmod
/// route's indefinite steps factorize the symmetric part by LDLᵀ (GMRES then takes the skew part out in
/// a few iterations): round-off of a follower pressure's load stiffness summed over a surface held on its
/// boundary is ~1e-12 (the fine aneurysm: one GMRES iteration to 8e-11 with the symmetric part's factor).
inline constexpr double kLdltSkew = 1e-8;

/// max |A_ij − A_ji| / max |A_ij| (0 for a zero matrix); A's pattern structurally symmetric.
double relative_skew(const CscMatrix& A);

/// MUMPS's LDLᵀ of the symmetric part (linear_solve_ldlt.cpp).
std::unique_ptr<LinearSolver> make_symmetric_indefinite_solver();

/// The solver of `choice`: a SparseDirectSolver, or a PetscSolver of the mesh and its free dofs (which
/// the caller keeps alive, as the solver refers to them).
std::unique_ptr<LinearSolver> make_macro_linear_solver(const LinearSolverChoice& choice, const Mesh& mesh, const DofMap& dofs);

}  // namespace softhom::fe
