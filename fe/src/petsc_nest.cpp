#include "petsc_nest.hpp"
#include "petsc_check.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace softhom::fe {
namespace {

constexpr auto nest_check = petsc_check;

}  // namespace

NestedSaddleMatrix::~NestedSaddleMatrix() {
  PetscBool finalized = PETSC_FALSE;
  PetscFinalized(&finalized);
  if (finalized) return;  // PETSc's objects went with PetscFinalize
  if (nest_) MatDestroy(&nest_);
  for (Mat& b : blocks_)
    if (b) MatDestroy(&b);
}

void NestedSaddleMatrix::create(MPI_Comm comm, int rank, const std::vector<PetscInt>& first,
                                const std::vector<PetscInt>& nu, const std::vector<PetscInt>& u_diag,
                                const std::vector<PetscInt>& u_off, const std::vector<PetscInt>& p_diag,
                                const std::vector<PetscInt>& p_off) {
  const int size = int(nu.size());
  first_ = first;
  nu_ = nu;
  ufirst_.assign(size + 1, 0);
  pfirst_.assign(size + 1, 0);
  for (int r = 0; r < size; ++r) {
    ufirst_[r + 1] = ufirst_[r] + nu[r];
    pfirst_[r + 1] = pfirst_[r] + (first[r + 1] - first[r] - nu[r]);
  }
  const PetscInt n[2] = {nu[rank], first[rank + 1] - first[rank] - nu[rank]};
  const PetscInt N[2] = {ufirst_[size], pfirst_[size]};
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) {
      // Row i's counts in column block j: u rows are the first n[0] entries of the per-row arrays.
      const std::vector<PetscInt>& dz = j == 0 ? u_diag : p_diag;
      const std::vector<PetscInt>& oz = j == 0 ? u_off : p_off;
      std::vector<PetscInt> d(dz.begin() + (i == 0 ? 0 : n[0]), dz.begin() + (i == 0 ? n[0] : n[0] + n[1]));
      std::vector<PetscInt> o(oz.begin() + (i == 0 ? 0 : n[0]), oz.begin() + (i == 0 ? n[0] : n[0] + n[1]));
      for (PetscInt k = 0; k < PetscInt(d.size()); ++k) {  // PETSc wants counts within the block's sizes
        d[k] = std::min(d[k], n[j]);
        o[k] = std::min(o[k], N[j] - n[j]);
      }
      Mat& b = blocks_[2 * i + j];
      nest_check(MatCreate(comm, &b), "MatCreate");
      nest_check(MatSetSizes(b, n[i], n[j], N[i], N[j]), "MatSetSizes");
      nest_check(MatSetType(b, MATAIJ), "MatSetType");
      // The displacement block in nodal blocks of 3, as the field split's extracted block had it
      // (BoomerAMG takes the block size as its number of functions).
      if (i == 0 && j == 0) nest_check(MatSetBlockSize(b, 3), "MatSetBlockSize");
      nest_check(MatSeqAIJSetPreallocation(b, 0, d.data()), "MatSeqAIJSetPreallocation");
      nest_check(MatMPIAIJSetPreallocation(b, 0, d.data(), 0, o.data()), "MatMPIAIJSetPreallocation");
      nest_check(MatSetOption(b, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_TRUE), "MatSetOption");
    }
  nest_check(MatCreateNest(comm, 2, nullptr, 2, nullptr, blocks_, &nest_), "MatCreateNest");
  for (int k = 0; k < 2; ++k) {
    row_idx_[k].reserve(64);
    col_idx_[k].reserve(64);
  }
}

bool NestedSaddleMatrix::is_pressure(PetscInt g, PetscInt& local_index) const {
  const int r = int(std::upper_bound(first_.begin(), first_.end(), g) - first_.begin()) - 1;
  const PetscInt offset = g - first_[r];
  if (offset < nu_[r]) {
    local_index = ufirst_[r] + offset;
    return false;
  }
  local_index = pfirst_[r] + offset - nu_[r];
  return true;
}

void NestedSaddleMatrix::add(PetscInt nr, const PetscInt* rows, PetscInt nc, const PetscInt* cols,
                             const PetscScalar* v, InsertMode mode) {
  for (int k = 0; k < 2; ++k) {
    row_idx_[k].clear();
    row_pos_[k].clear();
    col_idx_[k].clear();
    col_pos_[k].clear();
  }
  PetscInt b = 0;
  for (PetscInt i = 0; i < nr; ++i) {
    const int k = is_pressure(rows[i], b) ? 1 : 0;
    row_idx_[k].push_back(b);
    row_pos_[k].push_back(i);
  }
  for (PetscInt j = 0; j < nc; ++j) {
    const int k = is_pressure(cols[j], b) ? 1 : 0;
    col_idx_[k].push_back(b);
    col_pos_[k].push_back(j);
  }
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) {
      const std::size_t mr = row_idx_[i].size(), mc = col_idx_[j].size();
      if (mr == 0 || mc == 0) continue;
      sub_.resize(mr * mc);
      for (std::size_t a = 0; a < mr; ++a)
        for (std::size_t c = 0; c < mc; ++c) sub_[a * mc + c] = v[row_pos_[i][a] * nc + col_pos_[j][c]];
      nest_check(MatSetValues(blocks_[2 * i + j], PetscInt(mr), row_idx_[i].data(), PetscInt(mc), col_idx_[j].data(),
                         sub_.data(), mode),
            "MatSetValues");
    }
}

void NestedSaddleMatrix::zero() {
  for (Mat b : blocks_) nest_check(MatZeroEntries(b), "MatZeroEntries");
}

void NestedSaddleMatrix::assemble() {
  for (Mat b : blocks_) nest_check(MatAssemblyBegin(b, MAT_FINAL_ASSEMBLY), "MatAssemblyBegin");
  for (Mat b : blocks_) nest_check(MatAssemblyEnd(b, MAT_FINAL_ASSEMBLY), "MatAssemblyEnd");
  nest_check(MatAssemblyBegin(nest_, MAT_FINAL_ASSEMBLY), "MatAssemblyBegin");
  nest_check(MatAssemblyEnd(nest_, MAT_FINAL_ASSEMBLY), "MatAssemblyEnd");
}

double NestedSaddleMatrix::bytes() const {
  double total = 0.0;
  for (Mat b : blocks_) {
    MatInfo info;
    if (b && MatGetInfo(b, MAT_LOCAL, &info) == 0) total += info.nz_allocated * (sizeof(PetscScalar) + sizeof(PetscInt));
  }
  return total;
}

}  // namespace softhom::fe
