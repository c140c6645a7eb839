#pragma once
// Element blocks added straight into the values of an assembled PETSc AIJ matrix (sequential or MPI)
// whose pattern is final, instead of through MatSetValues (petsc_solve.cpp). PETSc's insertion searches
// every entry in its row and routes every row through the MPI matrix's ownership tests: on the cPASMO
// 0.5 mesh (tet10, 900 entries per element and a second 900 for the augmentation; one process) it took
// 23 % of the whole run against ≈ 4 % for the element kernels. Here a dense block over sorted global indices finds each column by a bisection only where
// the indices stop being consecutive (a node's free components are adjacent columns of every row that
// holds them), so a tet10 block costs ≈ 10 searches per row.
#include <petscmat.h>

namespace softhom::fe {

class DirectFill {
 public:
  /// Starts adding into M (AIJ, assembled at least once, no new entries to come): takes its local
  /// CSR arrays (the diagonal and, on several ranks, the off-diagonal part with its column map).
  void begin(Mat M);
  /// Adds the nr × nc row-major block v at the global rows and columns given (ascending order is the
  /// fast case; a repeated index adds up). Rows of another rank, and a row with a column outside the
  /// pattern, go through MatSetValues (PETSc's stash, or its error for a new entry). Not thread-safe
  /// for rows of another rank; owned rows touched by one caller at a time are.
  void add(int nr, const PetscInt* rows, int nc, const PetscInt* cols, const PetscScalar* v);
  void add(int n, const PetscInt* idx, const PetscScalar* v) { add(n, idx, n, idx, v); }
  /// Gives the arrays back (before MatAssemblyBegin).
  void end();
  bool active() const { return M_ != nullptr; }

 private:
  struct Part {
    Mat m = nullptr;
    const PetscInt *ia = nullptr, *ja = nullptr;
    PetscScalar* values = nullptr;
  };
  /// Position in part p's row (local row r) of local column c, searching from `from`; −1 if absent.
  static PetscInt find(const Part& p, PetscInt r, PetscInt c, PetscInt from);
  Mat M_ = nullptr;
  Part diag_, off_;
  const PetscInt* garray_ = nullptr;  // off-diagonal part: local column → global column (ascending)
  PetscInt ngarray_ = 0;
  PetscInt rstart_ = 0, rend_ = 0, cstart_ = 0, cend_ = 0;
};

}  // namespace softhom::fe
