#include "petsc_p_multigrid.hpp"

#include <array>
#include <cmath>

#include <Eigen/Dense>

#include "petsc_check.hpp"
#include "softhom/fe/tet10.hpp"

namespace softhom::fe {

PMultigridSpace p_multigrid_interpolation(MPI_Comm comm, int rank, const Mesh& mesh, const std::vector<int>& eq,
                                          const std::vector<int>& node_owner) {
  const int nn = mesh.num_nodes();
  int ranks = 1;
  MPI_Comm_size(comm, &ranks);
  // Every node's P1 parents: itself for a vertex (a tet corner or any hex node), the two ends of its
  // edge for a mid-edge node. Mesh and owners are replicated: every rank computes the same numbering.
  constexpr int kNone = -1;
  std::vector<std::array<int, 2>> parents(std::size_t(nn), {kNone, kNone});
  std::vector<char> vertex(std::size_t(nn), 0);
  for (const Hex& h : mesh.hexes)
    for (int a : h) vertex[a] = 1;
  for (const Tet10& t : mesh.tets)
    for (int a = 0; a < 4; ++a) vertex[t[a]] = 1;
  for (int n = 0; n < nn; ++n)
    if (vertex[n]) parents[n] = {n, kNone};
  for (const Tet10& t : mesh.tets)
    for (int j = 0; j < 6; ++j) {
      const int m = t[4 + j];
      if (!vertex[m] && parents[m][0] == kNone) parents[m] = {t[kTet10Edges[j][0]], t[kTet10Edges[j][1]]};
    }
  // Row numbering (the displacement block's) and column numbering (vertex components), rank by rank.
  std::vector<PetscInt> rows_of(std::size_t(ranks) + 1, 0), cols_of(std::size_t(ranks) + 1, 0);
  for (int n = 0; n < nn; ++n) {
    rows_of[node_owner[n] + 1] += 3;
    if (vertex[n]) cols_of[node_owner[n] + 1] += 3;
  }
  for (int r = 0; r < ranks; ++r) {
    rows_of[r + 1] += rows_of[r];
    cols_of[r + 1] += cols_of[r];
  }
  std::vector<PetscInt> next_row(rows_of.begin(), rows_of.end() - 1), next_col(cols_of.begin(), cols_of.end() - 1);
  std::vector<PetscInt> row(3 * std::size_t(nn), -1), col(3 * std::size_t(nn), -1);
  for (int n = 0; n < nn; ++n)
    for (int i = 0; i < 3; ++i) {
      row[3 * n + i] = next_row[node_owner[n]]++;
      if (vertex[n]) col[3 * n + i] = next_col[node_owner[n]]++;
    }
  const PetscInt local_rows = rows_of[rank + 1] - rows_of[rank], local_cols = cols_of[rank + 1] - cols_of[rank];
  // This rank's entries (row, column, weight), then the preallocation counted from them.
  struct Entry {
    PetscInt row, col;
    double weight;
  };
  std::vector<Entry> entries;
  PMultigridSpace space;
  for (int n = 0; n < nn; ++n) {
    if (node_owner[n] != rank) continue;
    if (vertex[n]) {
      space.coarse_nodes.push_back(n);
      for (int i = 0; i < 3; ++i) space.coarse_coords.push_back(mesh.nodes[n][i]);
    }
    const double w = parents[n][1] == kNone ? 1.0 : 0.5;
    for (int i = 0; i < 3; ++i) {
      // Free rows from free parents, prescribed rows from prescribed ones.
      const bool free = eq[3 * n + i] >= 0;
      for (int p : parents[n])
        if (p != kNone && (eq[3 * p + i] >= 0) == free) entries.push_back({row[3 * n + i], col[3 * p + i], w});
    }
  }
  std::vector<PetscInt> dnz(std::size_t(local_rows), 0), onz(std::size_t(local_rows), 0);
  for (const Entry& e : entries)
    ++(e.col >= cols_of[rank] && e.col < cols_of[rank + 1] ? dnz : onz)[e.row - rows_of[rank]];
  Mat& P = space.interpolation;
  petsc_check(MatCreate(comm, &P), "MatCreate (p-multigrid interpolation)");
  petsc_check(MatSetSizes(P, local_rows, local_cols, PETSC_DETERMINE, PETSC_DETERMINE), "MatSetSizes (p-multigrid)");
  // Block size 3 in rows and columns: the Galerkin product PᵀAP inherits the columns' one.
  petsc_check(MatSetBlockSizes(P, 3, 3), "MatSetBlockSizes (p-multigrid)");
  petsc_check(MatSetType(P, MATAIJ), "MatSetType (p-multigrid)");
  petsc_check(MatSeqAIJSetPreallocation(P, 0, dnz.data()), "MatSeqAIJSetPreallocation (p-multigrid)");
  petsc_check(MatMPIAIJSetPreallocation(P, 0, dnz.data(), 0, onz.data()), "MatMPIAIJSetPreallocation (p-multigrid)");
  for (const Entry& e : entries)
    petsc_check(MatSetValue(P, e.row, e.col, e.weight, INSERT_VALUES), "MatSetValue (p-multigrid)");
  petsc_check(MatAssemblyBegin(P, MAT_FINAL_ASSEMBLY), "MatAssemblyBegin (p-multigrid)");
  petsc_check(MatAssemblyEnd(P, MAT_FINAL_ASSEMBLY), "MatAssemblyEnd (p-multigrid)");
  return space;
}

double nodal_block_spread(MPI_Comm comm, Mat A, PetscInt lo, PetscInt hi) {
  double log_sum = 0.0, count = 0.0;
  for (PetscInt node = lo; node + 2 < hi; node += 3) {
    Eigen::Matrix3d block = Eigen::Matrix3d::Zero();
    bool prescribed = false;
    for (int i = 0; i < 3 && !prescribed; ++i) {
      PetscInt n = 0;
      const PetscInt* cols = nullptr;
      const PetscScalar* vals = nullptr;
      petsc_check(MatGetRow(A, node + i, &n, &cols, &vals), "MatGetRow");
      prescribed = n <= 1;
      for (PetscInt k = 0; k < n; ++k)
        if (cols[k] >= node && cols[k] < node + 3) block(i, int(cols[k] - node)) = vals[k];
      petsc_check(MatRestoreRow(A, node + i, &n, &cols, &vals), "MatRestoreRow");
    }
    if (prescribed) continue;
    const Eigen::Vector3d e = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(0.5 * (block + block.transpose()),
                                                                            Eigen::EigenvaluesOnly).eigenvalues();
    if (!(e(0) > 0.0)) continue;
    log_sum += std::log(e(2) / e(0));
    count += 1.0;
  }
  double local[2] = {log_sum, count}, total[2] = {0.0, 0.0};
  MPI_Allreduce(local, total, 2, MPI_DOUBLE, MPI_SUM, comm);
  return total[1] > 0.0 ? std::exp(total[0] / total[1]) : 1.0;
}

}  // namespace softhom::fe
