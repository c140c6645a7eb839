#include "petsc_direct_fill.hpp"
#include "petsc_check.hpp"

#include <algorithm>
#include <array>
#include <stdexcept>

namespace softhom::fe {
namespace {

constexpr auto fill_check = petsc_check;
constexpr int kMaxBlock = 32;  // a hex8 or tet10 element's free rows (24, 30), and one pressure column

}  // namespace

void DirectFill::begin(Mat M) {
  if (M_) end();
  PetscBool mpi = PETSC_FALSE, seq = PETSC_FALSE;
  fill_check(PetscObjectTypeCompare(reinterpret_cast<PetscObject>(M), MATMPIAIJ, &mpi), "PetscObjectTypeCompare");
  fill_check(PetscObjectTypeCompare(reinterpret_cast<PetscObject>(M), MATSEQAIJ, &seq), "PetscObjectTypeCompare");
  if (!mpi && !seq) return;  // another storage: MatSetValues
  fill_check(MatGetOwnershipRange(M, &rstart_, &rend_), "MatGetOwnershipRange");
  fill_check(MatGetOwnershipRangeColumn(M, &cstart_, &cend_), "MatGetOwnershipRangeColumn");
  diag_ = {};
  off_ = {};
  garray_ = nullptr;
  ngarray_ = 0;
  if (mpi) {
    fill_check(MatMPIAIJGetSeqAIJ(M, &diag_.m, &off_.m, &garray_), "MatMPIAIJGetSeqAIJ");
    fill_check(MatGetLocalSize(off_.m, nullptr, &ngarray_), "MatGetLocalSize");
  } else {
    diag_.m = M;
  }
  for (Part* p : {&diag_, &off_}) {
    if (!p->m) continue;
    PetscInt rows = 0;
    PetscBool done = PETSC_FALSE;
    fill_check(MatGetRowIJ(p->m, 0, PETSC_FALSE, PETSC_FALSE, &rows, &p->ia, &p->ja, &done), "MatGetRowIJ");
    if (!done || rows != rend_ - rstart_) throw std::runtime_error("PETSc: MatGetRowIJ gave no CSR arrays for the direct fill");
    fill_check(MatSeqAIJGetArray(p->m, &p->values), "MatSeqAIJGetArray");
  }
  M_ = M;
}

void DirectFill::end() {
  if (!M_) return;
  for (Part* p : {&diag_, &off_}) {
    if (!p->m) continue;
    PetscInt rows = 0;
    PetscBool done = PETSC_FALSE;
    fill_check(MatSeqAIJRestoreArray(p->m, &p->values), "MatSeqAIJRestoreArray");
    fill_check(MatRestoreRowIJ(p->m, 0, PETSC_FALSE, PETSC_FALSE, &rows, &p->ia, &p->ja, &done), "MatRestoreRowIJ");
  }
  M_ = nullptr;
}

PetscInt DirectFill::find(const Part& p, PetscInt r, PetscInt c, PetscInt from) {
  // The fast case: the column after the last one found (the next component of the same node).
  if (from >= p.ia[r] && from < p.ia[r + 1] && p.ja[from] == c) return from;
  const PetscInt* first = p.ja + p.ia[r];
  const PetscInt* last = p.ja + p.ia[r + 1];
  const PetscInt* at = std::lower_bound(first, last, c);
  return at != last && *at == c ? PetscInt(at - p.ja) : -1;
}

void DirectFill::add(int nr, const PetscInt* rows, int nc, const PetscInt* cols, const PetscScalar* v) {
  if (nc > kMaxBlock) {
    fill_check(MatSetValues(M_, nr, rows, nc, cols, v, ADD_VALUES), "MatSetValues");
    return;
  }
  // The off-diagonal part's local column of each column (−1: a column of this rank), found once per
  // block; consecutive global columns are mostly consecutive there too.
  std::array<PetscInt, kMaxBlock> off_col;
  bool columns_known = true;
  for (int j = 0; j < nc; ++j) {
    off_col[j] = -1;
    if (cols[j] >= cstart_ && cols[j] < cend_) continue;
    if (j > 0 && off_col[j - 1] >= 0 && off_col[j - 1] + 1 < ngarray_ && garray_[off_col[j - 1] + 1] == cols[j]) {
      off_col[j] = off_col[j - 1] + 1;
      continue;
    }
    const PetscInt* g = garray_ ? std::lower_bound(garray_, garray_ + ngarray_, cols[j]) : nullptr;
    if (!g || g == garray_ + ngarray_ || *g != cols[j]) columns_known = false;
    else off_col[j] = PetscInt(g - garray_);
  }
  auto part_of = [&](int j) -> const Part& { return off_col[j] < 0 ? diag_ : off_; };
  auto column_of = [&](int j) { return off_col[j] < 0 ? cols[j] - cstart_ : off_col[j]; };
  std::array<PetscInt, kMaxBlock> pos, shifted;  // each column's position in its part's values
  bool previous_found = false;
  for (int i = 0; i < nr; ++i) {
    const PetscInt row = rows[i];
    bool found = columns_known && row >= rstart_ && row < rend_;
    const PetscInt r = row - rstart_;
    // The next row of the same node has the same columns: the previous row's positions, shifted by
    // the row starts, checked entry by entry instead of searched.
    bool shift = found && previous_found && i > 0 && row == rows[i - 1] + 1;
    for (int j = 0; j < nc && shift; ++j) {
      const Part& p = part_of(j);
      const PetscInt q = pos[j] + p.ia[r] - p.ia[r - 1];
      shift = q >= p.ia[r] && q < p.ia[r + 1] && p.ja[q] == column_of(j);
      shifted[j] = q;
    }
    if (shift) {
      pos = shifted;
    } else if (found) {
      PetscInt next_d = -1, next_o = -1;  // one past the last position found in each part
      for (int j = 0; j < nc && found; ++j) {
        PetscInt& next = off_col[j] < 0 ? next_d : next_o;
        pos[j] = find(part_of(j), r, column_of(j), next);
        next = pos[j] + 1;
        found = pos[j] >= 0;
      }
    }
    previous_found = found;
    const PetscScalar* vi = v + std::size_t(i) * nc;
    if (!found) {
      // Another rank's row (PETSc's stash), or an entry outside the pattern (PETSc reports it).
      fill_check(MatSetValues(M_, 1, &row, nc, cols, vi, ADD_VALUES), "MatSetValues");
      continue;
    }
    for (int j = 0; j < nc; ++j) (off_col[j] < 0 ? diag_.values : off_.values)[pos[j]] += vi[j];
  }
}

}  // namespace softhom::fe
