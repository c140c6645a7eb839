#include "petsc_subdomains.hpp"

#include <algorithm>
#include <utility>

#include "petsc_check.hpp"

namespace softhom::fe {

namespace {

/// The rank of every coupling group: the lowest rank whose elements hold all its nodes (a face's: its
/// element's, so the subdomains stay those of the elements), else the lowest holding one of them (0:
/// none does).
std::vector<int> group_owners(const Mesh& mesh, const std::vector<int>& element_owner, const Couplings& couplings) {
  if (couplings.empty()) return {};
  std::vector<std::vector<int>> ranks(mesh.num_nodes());  // the ranks holding each node, ascending
  for (int e = 0; e < mesh.num_elements(); ++e) {
    const int* en = mesh.element_nodes(e);
    for (int a = 0; a < mesh.element_size(e); ++a) ranks[en[a]].push_back(element_owner[e]);
  }
  for (auto& r : ranks) {
    std::sort(r.begin(), r.end());
    r.erase(std::unique(r.begin(), r.end()), r.end());
  }
  std::vector<int> owner(couplings.size(), 0);
  for (int g = 0; g < couplings.size(); ++g) {
    const int* gn = couplings.nodes.data() + couplings.offsets[g];
    const int size = couplings.offsets[g + 1] - couplings.offsets[g];
    int any = -1, all = -1;
    for (int a = 0; a < size; ++a)
      if (!ranks[gn[a]].empty() && (any < 0 || ranks[gn[a]][0] < any)) any = ranks[gn[a]][0];
    for (int r : size > 0 ? ranks[gn[0]] : std::vector<int>{}) {
      bool everywhere = true;
      for (int a = 1; a < size && everywhere; ++a) everywhere = std::binary_search(ranks[gn[a]].begin(), ranks[gn[a]].end(), r);
      if (everywhere) {
        all = r;
        break;
      }
    }
    owner[g] = all >= 0 ? all : std::max(any, 0);
  }
  return owner;
}

}  // namespace

Subdomains::Subdomains(const Mesh& mesh, const std::vector<int>& element_owner, const Couplings& couplings, int rank,
                       const std::vector<PetscInt>& urow, const std::vector<int>& eq)
    : rank_(rank) {
  const int nn = mesh.num_nodes(), ne = mesh.num_elements();
  const std::vector<int> group_owner = group_owners(mesh, element_owner, couplings);
  std::vector<std::pair<int, int>> touch;  // (node, rank) of every element's and group's nodes
  for (int e = 0; e < ne; ++e) {
    const int* en = mesh.element_nodes(e);
    for (int a = 0; a < mesh.element_size(e); ++a) touch.emplace_back(en[a], element_owner[e]);
  }
  for (int g = 0; g < couplings.size(); ++g)
    for (int k = couplings.offsets[g]; k < couplings.offsets[g + 1]; ++k) touch.emplace_back(couplings.nodes[k], group_owner[g]);
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
  for (int g = 0; g < couplings.size(); ++g) {
    if (group_owner[g] != rank) continue;
    const int* gn = couplings.nodes.data() + couplings.offsets[g];
    const int size = couplings.offsets[g + 1] - couplings.offsets[g];
    for (int a = 0; a < size; ++a) around[local_[gn[a]]].insert(around[local_[gn[a]]].end(), gn, gn + size);
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
