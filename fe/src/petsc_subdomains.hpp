#pragma once
// Non-overlapping subdomains of the element partition for PETSc's BDDC (`-pc_type bddc`): each rank's
// subdomain is the set of elements it owns, its local space the dofs of the nodes those elements touch.
// The system is then a MATIS, the sum of the subdomains' unassembled (Neumann) matrices, of the
// condensed displacement operator: a three-field element's pressure is its own (P0), so its static
// condensation K_e = A_e + c d dᵀ is exact and stays inside one subdomain.
#include <petscmat.h>

#include <vector>

#include "softhom/fe/contribution.hpp"
#include "softhom/fe/mesh.hpp"

namespace softhom::fe {

class Subdomains {
 public:
  /// The subdomain of `rank` under `element_owner`; `urow` is the PETSc row of every mesh dof (3 per
  /// node, a node's rows consecutive from a multiple of 3), `eq` the free equation of every mesh dof
  /// (−1: prescribed). A group of `couplings` (the model's contributions) belongs to the lowest rank
  /// holding one of its nodes (rank 0 when none does), like an element of that rank.
  Subdomains(const Mesh& mesh, const std::vector<int>& element_owner, const Couplings& couplings, int rank,
             const std::vector<PetscInt>& urow, const std::vector<int>& eq);
  /// The local row of mesh dof `dof` (3 node + component) of a node in this subdomain.
  PetscInt row(int dof) const { return 3 * PetscInt(local_[dof / 3]) + dof % 3; }
  /// Whether this rank adds an entry coupling nodes a and b (both must lie in the local space of the
  /// rank that adds it): the lowest rank whose subdomain holds both. Every rank passes every entry.
  bool adds_coupling(int a, int b) const;
  /// The local-to-global map of the local space (block size 3), for MatCreateIS (the caller destroys it).
  ISLocalToGlobalMapping local_to_global(MPI_Comm comm) const;
  /// Nonzeros per local row of the subdomain matrix: the dofs of the nodes sharing an element of it.
  const std::vector<PetscInt>& nonzeros() const { return nnz_; }
  /// Local rows of the subdomain's prescribed dofs (eq < 0), and the share of their identity row this
  /// subdomain holds (1 / the number of subdomains holding the node: the shares sum to the row).
  const std::vector<PetscInt>& prescribed() const { return prescribed_; }
  const std::vector<double>& prescribed_share() const { return prescribed_share_; }
  /// Dofs of the local space (3 per node).
  PetscInt local_dofs() const { return 3 * PetscInt(nodes_.size()); }
  /// The global row of local row `row`.
  PetscInt global_row(PetscInt row) const { return 3 * blocks_[std::size_t(row / 3)] + row % 3; }

 private:
  int rank_ = 0;
  std::vector<int> nodes_, local_;
  std::vector<int> rank_off_, ranks_;  // CSR: the ranks touching each node, ascending
  std::vector<PetscInt> blocks_, nnz_, prescribed_;
  std::vector<double> prescribed_share_;
};

}  // namespace softhom::fe
