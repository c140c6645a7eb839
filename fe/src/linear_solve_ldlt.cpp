// The symmetric indefinite factorization of the direct routes: MUMPS's multifrontal LDLᵀ (1×1 and 2×2
// pivots) of the tangent's symmetric part, through PETSc on this process alone. The cholmod route takes it
// where CHOLMOD's LLᵀ finds that part indefinite and the tangent is symmetric up to round-off (a follower
// pressure on a surface held on its boundary): half the flops of UMFPACK's LU, and no unsymmetric pivoting.
#include <petscmat.h>

#include <chrono>
#include <stdexcept>
#include <vector>

#include "linear_solver_factory.hpp"
#include "petsc_check.hpp"
#include "softhom/fe/petsc.hpp"

namespace softhom::fe {

namespace {

double ldlt_seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// MUMPS's LDLᵀ of (A + Aᵀ)/2 held as PETSc's SBAIJ (upper triangle by rows = A's lower triangle by
/// columns, so the CSC pattern maps without sorting).
class MumpsLdltSolver final : public LinearSolver {
 public:
  MumpsLdltSolver() { petsc_initialize(); }
  ~MumpsLdltSolver() override { release(); }
  MumpsLdltSolver(const MumpsLdltSolver&) = delete;
  MumpsLdltSolver& operator=(const MumpsLdltSolver&) = delete;

  /// A factor of the symmetric part, as CHOLMOD's: exact where the tangent is symmetric.
  SolverKind kind() const override { return SolverKind::cholmod; }
  double predicted_flops() const override { return flops_; }
  /// MUMPS gives no condition estimate without extra solves: 1 for a factor without null pivots.
  double reciprocal_condition() const override { return factored_ ? 1.0 : 0.0; }

  void analyze(const CscMatrix& A) override {
    const auto t0 = std::chrono::steady_clock::now();
    release();
    n_ = A.n;
    rowptr_.assign(std::size_t(n_) + 1, 0);
    cols_.clear();
    map_.clear();
    mirror_.clear();
    for (int c = 0; c < n_; ++c) {
      for (int k = A.colptr[c]; k < A.colptr[c + 1]; ++k)
        if (A.rowind[k] >= c) {
          cols_.push_back(A.rowind[k]);
          map_.push_back(k);
          mirror_.push_back(A.mirror.empty() ? A.find(c, A.rowind[k]) : A.mirror[k]);
        }
      rowptr_[std::size_t(c) + 1] = PetscInt(cols_.size());
    }
    values_.assign(cols_.size(), 0.0);
    copy_values(A);
    petsc_check(MatCreateSeqSBAIJWithArrays(PETSC_COMM_SELF, 1, n_, n_, rowptr_.data(), cols_.data(), values_.data(), &S_),
                "MatCreateSeqSBAIJWithArrays");
    petsc_check(MatGetFactor(S_, MATSOLVERMUMPS, MAT_FACTOR_CHOLESKY, &F_), "MatGetFactor(mumps, cholesky)");
    // METIS's nested dissection (as the CHOLMOD and UMFPACK factors of these patterns); quiet MUMPS.
    petsc_check(MatMumpsSetIcntl(F_, 7, 5), "MatMumpsSetIcntl(7)");
    petsc_check(MatMumpsSetIcntl(F_, 4, 0), "MatMumpsSetIcntl(4)");
    MatFactorInfo info;
    petsc_check(MatFactorInfoInitialize(&info), "MatFactorInfoInitialize");
    petsc_check(MatCholeskyFactorSymbolic(F_, S_, nullptr, &info), "MatCholeskyFactorSymbolic");
    PetscReal flops = 0.0;
    petsc_check(MatMumpsGetRinfog(F_, 1, &flops), "MatMumpsGetRinfog(1)");
    flops_ = double(flops);
    petsc_check(VecCreateSeqWithArray(PETSC_COMM_SELF, 1, n_, nullptr, &b_), "VecCreateSeqWithArray");
    petsc_check(VecCreateSeqWithArray(PETSC_COMM_SELF, 1, n_, nullptr, &x_), "VecCreateSeqWithArray");
    times_.analysis += ldlt_seconds_since(t0);
  }

  bool factorize(const CscMatrix& A) override {
    const auto t0 = std::chrono::steady_clock::now();
    copy_values(A);
    // New values in the arrays PETSc shares: its matrix's state moves on with an assembly.
    petsc_check(MatAssemblyBegin(S_, MAT_FINAL_ASSEMBLY), "MatAssemblyBegin");
    petsc_check(MatAssemblyEnd(S_, MAT_FINAL_ASSEMBLY), "MatAssemblyEnd");
    MatFactorInfo info;
    petsc_check(MatFactorInfoInitialize(&info), "MatFactorInfoInitialize");
    petsc_check(MatCholeskyFactorNumeric(F_, S_, &info), "MatCholeskyFactorNumeric");
    MatFactorError error = MAT_FACTOR_NOERROR;
    petsc_check(MatFactorGetError(F_, &error), "MatFactorGetError");
    factored_ = error == MAT_FACTOR_NOERROR;
    times_.factorization += ldlt_seconds_since(t0);
    ++times_.factorizations;
    PetscReal flops = 0.0;
    petsc_check(MatMumpsGetRinfog(F_, 3, &flops), "MatMumpsGetRinfog(3)");  // this elimination's flops
    times_.flops += double(flops);
    PetscInt entries = 0;
    petsc_check(MatMumpsGetInfog(F_, 29, &entries), "MatMumpsGetInfog(29)");
    times_.factor_nnz = double(entries);
    return factored_;
  }

  void solve(const std::vector<double>& b, std::vector<double>& x) override {
    const auto t0 = std::chrono::steady_clock::now();
    x.assign(std::size_t(n_), 0.0);
    petsc_check(VecPlaceArray(b_, b.data()), "VecPlaceArray");
    petsc_check(VecPlaceArray(x_, x.data()), "VecPlaceArray");
    petsc_check(MatSolve(F_, b_, x_), "MatSolve");
    petsc_check(VecResetArray(b_), "VecResetArray");
    petsc_check(VecResetArray(x_), "VecResetArray");
    times_.solve += ldlt_seconds_since(t0);
    ++times_.solves;
  }

 private:
  void copy_values(const CscMatrix& A) {
    for (std::size_t k = 0; k < map_.size(); ++k)
      values_[k] = mirror_[k] >= 0 ? 0.5 * (A.values[map_[k]] + A.values[mirror_[k]]) : A.values[map_[k]];
  }
  void release() {
    if (F_) MatDestroy(&F_);
    if (S_) MatDestroy(&S_);
    if (b_) VecDestroy(&b_);
    if (x_) VecDestroy(&x_);
    factored_ = false;
  }
  Mat S_ = nullptr, F_ = nullptr;
  Vec b_ = nullptr, x_ = nullptr;
  std::vector<PetscInt> rowptr_, cols_;
  std::vector<PetscScalar> values_;
  std::vector<long> map_, mirror_;  ///< positions in A.values of each stored entry and of its transpose
  int n_ = 0;
  double flops_ = 0.0;
  bool factored_ = false;
};

}  // namespace

std::unique_ptr<LinearSolver> make_symmetric_indefinite_solver() { return std::make_unique<MumpsLdltSolver>(); }

}  // namespace softhom::fe
