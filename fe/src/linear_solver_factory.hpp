#pragma once
// The one object that solves fe::Simulation's linear systems, made from a LinearSolverChoice
// (softhom/fe/linear_solver.hpp): the sparse direct factor of the cholmod and umfpack routes, or the
// PETSc solver of the petsc route (petsc_solve.hpp).
#include <memory>

#include "softhom/fe/linear_solver.hpp"
#include "softhom/fe/mesh.hpp"
#include "softhom/fe/sparse.hpp"

namespace softhom::fe {

/// The factor of the direct routes: CHOLMOD's LLᵀ of the symmetric part (cholmod route) with UMFPACK's
/// LU, made on demand, for the steps where that part is not positive definite; or LU alone (umfpack
/// route). Each factorization analyses its pattern once, at its first use. times() sums both.
class SparseDirectSolver final : public LinearSolver {
 public:
  explicit SparseDirectSolver(LinearRoute route);
  /// A new load step: Cholesky is tried again.
  void begin_step() { lu_this_step_ = false; }
  /// The matrix's pattern changed (a moving contact set): both factorizations analyse it again.
  void new_pattern() { cholesky_analyzed_ = lu_analyzed_ = false; }
  /// The Cholesky analysis (once), so that predicted_flops() knows the first factorization's cost.
  void analyze(const CscMatrix& A) override;
  /// Cholesky of the symmetric part unless this step already fell back to LU; LU where it fails.
  bool factorize(const CscMatrix& A) override;
  void solve(const std::vector<double>& b, std::vector<double>& x) override;
  /// The factorization holding the current factor (the one the next factorize starts with before any).
  SolverKind kind() const override;
  /// CHOLMOD's prediction while Cholesky is in use (after analyze), else 0.
  double predicted_flops() const override;
  double reciprocal_condition() const override;
  /// Flops of the last factorization that produced the current factor (a failed Cholesky not counted).
  double last_factor_flops() const { return last_flops_; }
  /// The last factorize fell back from Cholesky to LU (the symmetric part is indefinite).
  bool fell_back_to_lu() const { return fell_back_; }
  /// Numeric factorizations of the factorization holding the current factor (Cholesky's or LU's).
  int current_factorizations() const { return current_ ? current_->times().factorizations : 0; }

 private:
  bool cholesky_now() const { return cholesky_ && !lu_this_step_; }
  void sum_times();
  std::unique_ptr<LinearSolver> cholesky_, lu_;
  LinearSolver* current_ = nullptr;
  bool cholesky_analyzed_ = false, lu_analyzed_ = false, lu_this_step_ = false, fell_back_ = false;
  double last_flops_ = 0.0;
};

/// The solver of `choice`: a SparseDirectSolver, or a PetscSolver of the mesh and its free dofs (which
/// the caller keeps alive, as the solver refers to them).
std::unique_ptr<LinearSolver> make_macro_linear_solver(const LinearSolverChoice& choice, const Mesh& mesh, const DofMap& dofs);

}  // namespace softhom::fe
