#pragma once
// Non-overlapping subdomains of the element partition for PETSc's BDDC (`-pc_type bddc`): each rank's
// subdomain is the set of elements it owns, its local space the dofs of the nodes those elements touch.
// The system is then a MATIS, the sum of the subdomains' unassembled (Neumann) matrices, of the
// condensed displacement operator: a three-field element's pressure is its own (P0), so its static
// condensation K_e = A_e + c d dᵀ is exact and stays inside one subdomain.
#include <petscmat.h>

#include <vector>

#include "softhom/fe/mesh.hpp"

namespace softhom::fe {

class Subdomains {
 public:
  /// The subdomain of `rank` under `element_owner`; `urow` is the PETSc row of every mesh dof (3 per
  /// node, a node's rows consecutive from a multiple of 3).
  Subdomains(const Mesh& mesh, const std::vector<int>& element_owner, int rank, const std::vector<PetscInt>& urow);
  /// Nodes of the subdomain (ascending).
  int size() const { return int(nodes_.size()); }
  /// The node's place in the local space (−1: not in this subdomain).
  int local(int node) const { return local_[node]; }
  /// The ranks whose subdomains contain the node.
  int multiplicity(int node) const { return rank_off_[node + 1] - rank_off_[node]; }
  /// Whether this rank adds an entry coupling nodes a and b (both must lie in the local space of the
  /// rank that adds it): the lowest rank whose subdomain holds both. Every rank passes every entry.
  bool adds_coupling(int a, int b) const;
  /// The local-to-global map of the local space (block size 3), for MatCreateIS (the caller destroys it).
  ISLocalToGlobalMapping local_to_global(MPI_Comm comm) const;
  /// Nonzeros per local row of the subdomain matrix: the dofs of the nodes sharing an element of it.
  const std::vector<PetscInt>& nonzeros() const { return nnz_; }
  /// Local dof indices of the subdomain's prescribed dofs (eq < 0).
  std::vector<PetscInt> prescribed(const std::vector<int>& eq) const;

 private:
  int rank_ = 0;
  std::vector<int> nodes_, local_;
  std::vector<int> rank_off_, ranks_;  // CSR: the ranks touching each node, ascending
  std::vector<PetscInt> blocks_, nnz_;
};

}  // namespace softhom::fe
