#pragma once
// The uncondensed (u, p) system of the three-field elements as a PETSc MATNEST of four AIJ blocks
// (petsc_solve.cpp, distributed assembly). The field split then takes its displacement block as that
// block itself (MatCreateSubMatrix of a nest returns the block for the nest's index set) instead of
// extracting a copy of it: one tangent-sized matrix less (≈ 1.2 GiB at 1.2e6 dofs). The entries are
// given in the rows and columns of the whole system (rank by rank: u_r then π_r) and routed here to
// their block.
#include <petscmat.h>

#include <vector>

namespace softhom::fe {

class NestedSaddleMatrix {
 public:
  NestedSaddleMatrix() = default;
  ~NestedSaddleMatrix();
  NestedSaddleMatrix(const NestedSaddleMatrix&) = delete;
  NestedSaddleMatrix& operator=(const NestedSaddleMatrix&) = delete;

  /// first[r]: rank r's first row of the whole system; nu[r]: its displacement rows (its pressure rows
  /// follow them up to first[r + 1]). Per owned row (u rows, then p rows): its columns in the u block
  /// (u_diag, u_off: on and off this rank) and in the p block (p_diag, p_off).
  void create(MPI_Comm comm, int rank, const std::vector<PetscInt>& first, const std::vector<PetscInt>& nu,
              const std::vector<PetscInt>& u_diag, const std::vector<PetscInt>& u_off,
              const std::vector<PetscInt>& p_diag, const std::vector<PetscInt>& p_off);
  /// The nest (the system's matrix) and block (i, j) (0: u, 1: p).
  Mat whole() const { return nest_; }
  Mat block(int i, int j) const { return blocks_[2 * i + j]; }
  /// MatSetValues of an nr × nc row-major array in the whole system's numbering.
  void add(PetscInt nr, const PetscInt* rows, PetscInt nc, const PetscInt* cols, const PetscScalar* v, InsertMode mode);
  /// The index of row (or column) g of the whole system in its block's rows (columns).
  PetscInt block_index(PetscInt g) const {
    PetscInt b = 0;
    is_pressure(g, b);
    return b;
  }
  void zero();
  void assemble();
  /// Bytes of the four blocks' entries on this rank: allocated entries (PETSc's MatGetInfo) × (value +
  /// column index); PETSc 3.18 no longer reports the memory itself.
  double bytes() const;

 private:
  bool is_pressure(PetscInt g, PetscInt& local_index) const;
  std::vector<PetscInt> first_, nu_, ufirst_, pfirst_;
  Mat blocks_[4] = {nullptr, nullptr, nullptr, nullptr};
  Mat nest_ = nullptr;
  // Scratch of add (one caller at a time: the one-process fill takes turns).
  std::vector<PetscInt> row_idx_[2], col_idx_[2], row_pos_[2], col_pos_[2];
  std::vector<PetscScalar> sub_;
};

}  // namespace softhom::fe
