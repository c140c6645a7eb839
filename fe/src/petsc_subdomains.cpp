#include "petsc_subdomains.hpp"

#include <algorithm>
#include <utility>

#include "petsc_check.hpp"

namespace softhom::fe {

Subdomains::Subdomains(const Mesh& mesh, const std::vector<int>& element_owner, int rank, const std::vector<PetscInt>& urow,
                       const std::vector<int>& eq)
    : rank_(rank) {
  const int nn = mesh.num_nodes(), ne = mesh.num_elements();
  std::vector<std::pair<int, int>> touch;  // (node, rank) of every element's nodes
  for (int e = 0; e < ne; ++e) {
    const int* en = mesh.element_nodes(e);
    for (int a = 0; a < mesh.element_size(e); ++a) touch.emplace_back(en[a], element_owner[e]);
  }
  std::sort(touch.begin(), touch.end());
  touch.erase(std::unique(touch.begin(), touch.end()), touch.end());
  rank_off_.assign(nn + 1, 0);
  ranks_.reserve(touch.size());
  for (const auto& [n, r] : touch) {
    ++rank_off_[n + 1];
    ranks_.push_back(r);
  }
  for (int n = 0; n < nn; ++n) rank_off_[n + 1] += rank_off_[n];
  local_.assign(nn, -1);
  for (const auto& [n, r] : touch)
    if (r == rank) nodes_.push_back(n);  // ascending: touch is sorted by node
  for (int i = 0; i < int(nodes_.size()); ++i) local_[nodes_[i]] = i;
  blocks_.resize(nodes_.size());
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    const int n = nodes_[i];
    blocks_[i] = urow[3 * std::size_t(n)] / 3;
    for (int c = 0; c < 3; ++c)
      if (eq[3 * std::size_t(n) + c] < 0) {
        prescribed_.push_back(PetscInt(3 * i + c));
        prescribed_share_.push_back(1.0 / (rank_off_[n + 1] - rank_off_[n]));
      }
  }
  // Nonzeros: per local node, the distinct nodes of its own elements, three dofs each.
  std::vector<std::vector<int>> around(nodes_.size());
  for (int e = 0; e < ne; ++e) {
    if (element_owner[e] != rank) continue;
    const int* en = mesh.element_nodes(e);
    for (int a = 0; a < mesh.element_size(e); ++a) around[local_[en[a]]].insert(around[local_[en[a]]].end(), en, en + mesh.element_size(e));
  }
  nnz_.assign(3 * nodes_.size(), 0);
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    std::vector<int>& v = around[i];
    std::sort(v.begin(), v.end());
    const PetscInt distinct = PetscInt(std::unique(v.begin(), v.end()) - v.begin());
    for (int c = 0; c < 3; ++c) nnz_[3 * i + c] = 3 * distinct;
    std::vector<int>().swap(v);
  }
}

bool Subdomains::adds_coupling(int a, int b) const {
  if (local_[a] < 0 || local_[b] < 0) return false;
  // The lowest rank touching both: walk a's ranks in order until one also touches b.
  for (int k = rank_off_[a]; k < rank_off_[a + 1]; ++k) {
    const int r = ranks_[k];
    if (std::binary_search(ranks_.begin() + rank_off_[b], ranks_.begin() + rank_off_[b + 1], r)) return r == rank_;
  }
  return false;
}

ISLocalToGlobalMapping Subdomains::local_to_global(MPI_Comm comm) const {
  ISLocalToGlobalMapping map = nullptr;
  petsc_check(ISLocalToGlobalMappingCreate(comm, 3, PetscInt(blocks_.size()), blocks_.data(), PETSC_COPY_VALUES, &map),
        "ISLocalToGlobalMappingCreate");
  return map;
}

}  // namespace softhom::fe
