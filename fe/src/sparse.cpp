#include "softhom/fe/sparse.hpp"

#include "softhom/fe/contribution.hpp"

#include <algorithm>
#include <chrono>
#include <cstring>
#include <stdexcept>

#include <cholmod.h>
#include <omp.h>
#include <umfpack.h>

namespace softhom::fe {
namespace {

/// CHOLMOD's status codes in words (cholmod_core.h): what a failed call says to the user.
std::string cholmod_status_text(int status) {
  switch (status) {
    case CHOLMOD_OUT_OF_MEMORY: return "out of memory";
    case CHOLMOD_TOO_LARGE: return "the factor is too large for CHOLMOD's 32-bit indices";
    case CHOLMOD_INVALID: return "invalid input";
    case CHOLMOD_NOT_INSTALLED: return "a CHOLMOD module is not installed";
    case CHOLMOD_NOT_POSDEF: return "not positive definite";
    default: return "status " + std::to_string(status);
  }
}

}  // namespace


long CscMatrix::find(int row, int col) const {
  const int* begin = rowind.data() + colptr[col];
  const int* end = rowind.data() + colptr[col + 1];
  const int* it = std::lower_bound(begin, end, row);
  return (it != end && *it == row) ? long(it - rowind.data()) : -1;
}

void CscMatrix::set_zero() { std::fill(values.begin(), values.end(), 0.0); }

void CscMatrix::multiply(const double* x, double* y) const {
  if (!mirror.empty()) {
    // Row r of A is column r's pattern with the mirrored values: no write conflicts between threads.
#pragma omp parallel for schedule(static) if (n >= 50000)
    for (int r = 0; r < n; ++r) {
      double s = 0.0;
      for (int k = colptr[r]; k < colptr[r + 1]; ++k) s += values[mirror[k]] * x[rowind[k]];
      y[r] = s;
    }
    return;
  }
  std::fill(y, y + n, 0.0);
  for (int c = 0; c < n; ++c)
    for (int k = colptr[c]; k < colptr[c + 1]; ++k) y[rowind[k]] += values[k] * x[c];
}

void CscMatrix::build_mirror() {
  mirror.assign(rowind.size(), -1);
  for (int c = 0; c < n; ++c)
    for (int k = colptr[c]; k < colptr[c + 1]; ++k) {
      mirror[k] = find(c, rowind[k]);
      if (mirror[k] < 0) {
        mirror.clear();
        throw std::logic_error("CscMatrix::build_mirror: pattern is not structurally symmetric");
      }
    }
}

DofMap DofMap::from_constrained(int num_dofs, const std::vector<char>& constrained) {
  DofMap m;
  m.eq.assign(num_dofs, -1);
  for (int d = 0; d < num_dofs; ++d)
    if (!constrained[d]) m.eq[d] = m.num_free++;
  return m;
}

CscMatrix build_pattern(const Mesh& mesh, const DofMap& dofs) { return build_pattern(mesh, dofs, Couplings{}); }

CscMatrix build_pattern(const Mesh& mesh, const DofMap& dofs, const Couplings& couplings) {
  const int nn = mesh.num_nodes();
  // Node adjacency through elements and the contributions' coupled groups.
  std::vector<std::vector<int>> adj(nn);
  auto couple = [&](const int* nodes, int size) {
    for (int a = 0; a < size; ++a)
      for (int b = 0; b < size; ++b) adj[nodes[a]].push_back(nodes[b]);
  };
  for (int e = 0; e < mesh.num_elements(); ++e) couple(mesh.element_nodes(e), mesh.element_size(e));
  for (int g = 0; g < couplings.size(); ++g)
    couple(couplings.nodes.data() + couplings.offsets[g], couplings.offsets[g + 1] - couplings.offsets[g]);
  for (auto& v : adj) {
    std::sort(v.begin(), v.end());
    v.erase(std::unique(v.begin(), v.end()), v.end());
  }
  CscMatrix A;
  A.n = dofs.num_free;
  A.colptr.assign(A.n + 1, 0);
  for (int node = 0; node < nn; ++node)
    for (int j = 0; j < 3; ++j) {
      const int col = dofs.eq[3 * node + j];
      if (col < 0) continue;
      int count = 0;
      for (int m : adj[node])
        for (int i = 0; i < 3; ++i) count += dofs.eq[3 * m + i] >= 0;
      A.colptr[col + 1] = count;
    }
  for (int c = 0; c < A.n; ++c) A.colptr[c + 1] += A.colptr[c];
  A.rowind.resize(A.colptr[A.n]);
  for (int node = 0; node < nn; ++node)
    for (int j = 0; j < 3; ++j) {
      const int col = dofs.eq[3 * node + j];
      if (col < 0) continue;
      int k = A.colptr[col];
      for (int m : adj[node])
        for (int i = 0; i < 3; ++i)
          if (dofs.eq[3 * m + i] >= 0) A.rowind[k++] = dofs.eq[3 * m + i];
    }
  A.values.assign(A.rowind.size(), 0.0);
  A.build_mirror();
  return A;
}

const char* to_string(SolverKind kind) {
  switch (kind) {
    case SolverKind::automatic: return "automatic";
    case SolverKind::cholmod: return "cholmod";
    case SolverKind::umfpack: return "umfpack";
    case SolverKind::petsc: return "petsc";
  }
  return "?";
}

void apply_cholmod_settings(cholmod_common& common) {
  // Always supernodal LLᵀ: a simplicial LDLᵀ would silently factorize an indefinite tangent
  // (past a limit point) instead of reporting it, and supernodal is faster on 3D meshes anyway.
  common.supernodal = CHOLMOD_SUPERNODAL;
  // Ordering: the smaller fill of AMD and METIS nested dissection. On tube meshes of 1e5 dofs AMD
  // gives ~9x the flops of METIS (424 vs 48 GFlop per factorization); on small or 2D meshes AMD
  // may win, and both orderings cost little next to one factorization.
  common.nmethods = 2;
  common.method[0].ordering = CHOLMOD_AMD;
  common.method[1].ordering = CHOLMOD_METIS;
  common.postorder = 1;
  // Coarser supernode amalgamation than CHOLMOD's defaults (4/16/48, 0.8/0.1/0.05): fewer, larger
  // dense blocks for the BLAS. Idle 2-core box, 1e5-dof tube pattern (`bench_macro --factor 1e5`,
  // best of 2, two runs): 3.74 / 3.47 s with the defaults, 2.29 / 2.47 s with these.
  const std::size_t nrelax[3] = {16, 64, 192};
  const double zrelax[3] = {0.9, 0.3, 0.15};
  for (int k = 0; k < 3; ++k) {
    common.nrelax[k] = nrelax[k];
    common.zrelax[k] = zrelax[k];
  }
}

namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// CHOLMOD supernodal Cholesky on the upper triangle (stype = 1).
class CholmodSolver final : public LinearSolver {
 public:
  CholmodSolver() {
    cholmod_start(&common_);
    apply_cholmod_settings(common_);
    // "Not positive definite" is an expected outcome (the caller falls back to LU and logs it).
    common_.print = 0;
  }
  ~CholmodSolver() override {
    if (factor_) cholmod_free_factor(&factor_, &common_);
    if (upper_) cholmod_free_sparse(&upper_, &common_);
    cholmod_finish(&common_);
  }
  SolverKind kind() const override { return SolverKind::cholmod; }
  double predicted_flops() const override { return factor_ ? common_.fl : 0.0; }

  void analyze(const CscMatrix& A) override {
    const auto t0 = std::chrono::steady_clock::now();
    // A new pattern (couplings that changed) replaces the last analysis.
    if (factor_) cholmod_free_factor(&factor_, &common_);
    if (upper_) cholmod_free_sparse(&upper_, &common_);
    n_ = A.n;
    // Copy the upper-triangle pattern once; map its entries to positions in A.values (and of their
    // transposes, to factorize the symmetric part).
    map_.clear();
    mirror_.clear();
    std::vector<int> colptr(A.n + 1, 0), rows;
    for (int c = 0; c < A.n; ++c) {
      for (int k = A.colptr[c]; k < A.colptr[c + 1]; ++k)
        if (A.rowind[k] <= c) {
          rows.push_back(A.rowind[k]);
          map_.push_back(k);
          mirror_.push_back(A.mirror.empty() ? A.find(c, A.rowind[k]) : A.mirror[k]);
        }
      colptr[c + 1] = int(rows.size());
    }
    upper_ = cholmod_allocate_sparse(A.n, A.n, rows.size(), 1, 1, 1, CHOLMOD_REAL, &common_);
    if (!upper_) throw std::runtime_error("CHOLMOD: out of memory allocating the matrix");
    std::memcpy(upper_->p, colptr.data(), sizeof(int) * colptr.size());
    std::memcpy(upper_->i, rows.data(), sizeof(int) * rows.size());
    copy_values(A);
    factor_ = cholmod_analyze(upper_, &common_);
    if (!factor_)
      throw std::runtime_error("CHOLMOD: symbolic analysis failed (" + cholmod_status_text(common_.status) + ") for " +
                               std::to_string(A.n) + " unknowns with " + std::to_string(rows.size()) +
                               " stored nonzeros");
    times_.analysis += seconds_since(t0);
  }

  bool factorize(const CscMatrix& A) override {
    const auto t0 = std::chrono::steady_clock::now();
    copy_values(A);
    cholmod_factorize(upper_, factor_, &common_);
    times_.factorization += seconds_since(t0);
    ++times_.factorizations;
    times_.flops += common_.fl;  // set by cholmod_analyze for this pattern
    times_.factor_nnz = common_.lnz;
    const bool ok = common_.status == CHOLMOD_OK && factor_->minor == std::size_t(n_);
    rcond_ = ok ? cholmod_rcond(factor_, &common_) : 0.0;
    return ok;
  }
  double reciprocal_condition() const override { return rcond_; }

  void solve(const std::vector<double>& b, std::vector<double>& x) override {
    const auto t0 = std::chrono::steady_clock::now();
    cholmod_dense* B = cholmod_allocate_dense(n_, 1, n_, CHOLMOD_REAL, &common_);
    std::memcpy(B->x, b.data(), sizeof(double) * n_);
    // One right-hand side: the supernodal sweeps are thousands of small, memory-bound BLAS-2 calls,
    // for which waking a second OpenMP thread per call costs more than it saves (OpenBLAS-OpenMP reads
    // the thread count per call). Idle box, 1e5 dofs: 0.086 s per solve with 2 threads.
    const int threads = omp_get_max_threads();
    omp_set_num_threads(1);
    cholmod_dense* X = cholmod_solve(CHOLMOD_A, factor_, B, &common_);
    omp_set_num_threads(threads);
    x.assign(static_cast<double*>(X->x), static_cast<double*>(X->x) + n_);
    cholmod_free_dense(&X, &common_);
    cholmod_free_dense(&B, &common_);
    times_.solve += seconds_since(t0);
    ++times_.solves;
  }

 private:
  void copy_values(const CscMatrix& A) {
    double* v = static_cast<double*>(upper_->x);
    for (std::size_t k = 0; k < map_.size(); ++k)
      v[k] = mirror_[k] >= 0 ? 0.5 * (A.values[map_[k]] + A.values[mirror_[k]]) : A.values[map_[k]];
  }
  cholmod_common common_{};
  cholmod_sparse* upper_ = nullptr;
  cholmod_factor* factor_ = nullptr;
  std::vector<long> map_, mirror_;
  int n_ = 0;
  double rcond_ = 0.0;
};

/// UMFPACK unsymmetric LU; the symbolic object (column ordering) is computed once.
class UmfpackSolver final : public LinearSolver {
 public:
  UmfpackSolver() {
    umfpack_di_defaults(control_);
  }
  ~UmfpackSolver() override {
    if (numeric_) umfpack_di_free_numeric(&numeric_);
    if (symbolic_) umfpack_di_free_symbolic(&symbolic_);
  }
  SolverKind kind() const override { return SolverKind::umfpack; }
  double reciprocal_condition() const override { return numeric_ ? info_[UMFPACK_RCOND] : 0.0; }

  void analyze(const CscMatrix& A) override {
    const auto t0 = std::chrono::steady_clock::now();
    A_ = &A;
    // METIS nested dissection (via CHOLMOD) instead of AMD on larger systems: ~1.6x fewer flops on
    // 3D meshes of 1e4 dofs, more beyond.
    control_[UMFPACK_ORDERING] = A.n >= 2000 ? UMFPACK_ORDERING_METIS : UMFPACK_ORDERING_AMD;
    if (numeric_) umfpack_di_free_numeric(&numeric_);  // of the pattern analysed before, if any
    if (symbolic_) umfpack_di_free_symbolic(&symbolic_);
    const int status = umfpack_di_symbolic(A.n, A.n, A.colptr.data(), A.rowind.data(), A.values.data(),
                                           &symbolic_, control_, info_);
    if (status != UMFPACK_OK) throw std::runtime_error("UMFPACK: symbolic analysis failed, status " + std::to_string(status));
    times_.analysis += seconds_since(t0);
  }

  bool factorize(const CscMatrix& A) override {
    const auto t0 = std::chrono::steady_clock::now();
    A_ = &A;
    if (numeric_) umfpack_di_free_numeric(&numeric_);
    const int status = umfpack_di_numeric(A.colptr.data(), A.rowind.data(), A.values.data(), symbolic_,
                                          &numeric_, control_, info_);
    times_.factorization += seconds_since(t0);
    ++times_.factorizations;
    if (info_[UMFPACK_FLOPS] > 0) times_.flops += info_[UMFPACK_FLOPS];
    times_.factor_nnz = info_[UMFPACK_LNZ] + info_[UMFPACK_UNZ];
    return status == UMFPACK_OK;  // UMFPACK_WARNING_singular_matrix is > 0: refuse it
  }

  void solve(const std::vector<double>& b, std::vector<double>& x) override {
    const auto t0 = std::chrono::steady_clock::now();
    x.assign(A_->n, 0.0);
    const int status = umfpack_di_solve(UMFPACK_A, A_->colptr.data(), A_->rowind.data(), A_->values.data(),
                                        x.data(), b.data(), numeric_, control_, info_);
    if (status != UMFPACK_OK) throw std::runtime_error("UMFPACK: solve failed, status " + std::to_string(status));
    times_.solve += seconds_since(t0);
    ++times_.solves;
  }

 private:
  double control_[UMFPACK_CONTROL];
  double info_[UMFPACK_INFO];
  void* symbolic_ = nullptr;
  void* numeric_ = nullptr;
  const CscMatrix* A_ = nullptr;
};

}  // namespace

std::unique_ptr<LinearSolver> make_linear_solver(SolverKind kind) {
  if (kind == SolverKind::umfpack) return std::make_unique<UmfpackSolver>();
  return std::make_unique<CholmodSolver>();
}

}  // namespace softhom::fe
