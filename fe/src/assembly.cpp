// Assembly of fe::Simulation: one loop over the contributions (the solids first, then those of the
// model), the driver's AssemblySink, and the solids' coloured element loop (residual, tangent,
// Dirichlet predictor right-hand side).
#include "simulation_impl.hpp"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <ctime>
#include <cmath>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <tuple>
#include <type_traits>

#include <Eigen/Dense>

#include "softhom/materials/errors.hpp"

namespace softhom::fe {
using namespace detail;

std::vector<double> Simulation::Impl::begin_assembly(bool tangent, const std::vector<double>& u, Assembly& out) {
  const Mesh& mesh = model_.mesh;
  const int ndof = mesh.num_dofs();
  const bool mixed = !mix_bulk_.empty();
  out.R.assign(ndof, 0.0);
  if (mixed) {
    out.R_true.assign(ndof, 0.0);
    out.R_u.assign(ndof, 0.0);
  } else {
    out.R_true.clear();
    out.R_u.clear();
  }
  if (distributed_) out.cauchy.assign(9 * std::size_t(mesh.num_elements()), 0.0);  // summed at commit
  else out.cauchy.resize(9 * std::size_t(mesh.num_elements()));
  out.volume = 0.0;
  if (model_.cavity) {
    out.a.assign(ndof, 0.0);
    out.g.assign(ndof, 0.0);
  }
  if (tangent) {
    if (petsc_) petsc_->set_displacement(u);
    if (distributed_) petsc_->begin_fill();
    else K_.set_zero();
    ++k_version_;
    ++stats_.tangent_assemblies;
  } else {
    ++stats_.residual_assemblies;
  }
  std::vector<double> du_c;
  if (!out.dirichlet_rhs.empty()) {
    du_c.swap(out.dirichlet_rhs);
    out.dirichlet_rhs.assign(ndof, 0.0);
  }
  return du_c;
}

MaterialStatus Simulation::Impl::assemble(double t, double dt, bool tangent, const std::vector<double>& u, double cavity_p,
                                    Assembly& out) {
  const auto t0 = std::chrono::steady_clock::now();
  const std::vector<double> du_c = begin_assembly(tangent, u, out);
  const Iterate it{t, stiffness_time_ >= 0.0 ? stiffness_time_ : t, dt, &u, cavity_p};
  AssemblyTarget sink(*this, out, du_c, tangent);
  MaterialStatus status = MaterialStatus::ok;
  bool internal_done = false;
  // Internal forces come first (the order of contributions_): the reactions and the force scale's
  // f_int are theirs alone.
  auto finish_internal = [&] {
    out.fint_norm = norm(out.R);
    out.fint = mix_bulk_.empty() ? out.R : out.R_true;
    internal_done = true;
  };
  for (std::size_t k = 0; k < contributions_.size(); ++k) {
    const Contribution* c = contributions_[k];
    sink.external = c->external_force();
    if (sink.external && !internal_done) finish_internal();
    Iterate own = it;  // with the contribution's history slice, when it keeps one
    if (const long off = contribution_state_offset_[k]; off >= 0) {
      own.state_old = contribution_state_old_.data() + off;
      own.state_new = contribution_state_new_.data() + off;
    }
    status = c->assemble(model_.mesh, own, sink);
    if (status != MaterialStatus::ok) break;
  }
  if (status == MaterialStatus::ok) {
    if (!internal_done) finish_internal();
    out.fext_norm = norm(sink.fext);
  }
  if (tangent && distributed_) petsc_->end_fill();  // collective; after a failure the tangent is not used
  stats_.assembly_time += seconds_since(t0);
  return status;
}

MaterialStatus SolidDomain::assemble(const Mesh&, const Iterate& it, AssemblySink& sink) const {
  // The driver's own sink: the element loop scatters into its targets directly (precomputed CSC
  // positions, PETSc's element blocks), without a call per entry.
  AssemblyTarget& target = static_cast<AssemblyTarget&>(sink);
  const auto t_loop = std::chrono::steady_clock::now();
  const double cpu_loop = process_cpu_seconds();
  s_.assemble_elements(it.dt, sink.tangent(), *it.u, target.du_c, target.out);
  s_.stats_.element_loop_time += seconds_since(t_loop);
  s_.stats_.element_loop_cpu += process_cpu_seconds() - cpu_loop;
  s_.reduce_element_sums(target.out);
  return target.out.status;
}

AssemblyTarget::AssemblyTarget(Simulation::Impl& s, Assembly& out, const std::vector<double>& du_c, bool tangent)
    : AssemblySink(tangent), out(out), du_c(du_c), fext(out.R.size(), 0.0), s_(s) {}

void AssemblyTarget::add_residual(int n, const int* dofs, const double* r) {
  const bool mixed = !out.R_true.empty();
  for (int i = 0; i < n; ++i) {
    const int d = dofs[i];
    out.R[d] += r[i];
    if (mixed) {
      out.R_true[d] += r[i];
      out.R_u[d] += r[i];
    }
    if (external) fext[d] -= r[i];
  }
}

namespace {

/// Whether dofs come as whole nodes: (3n, 3n + 1, 3n + 2) runs.
bool node_triples(int n, const int* dofs) {
  if (n % 3 != 0) return false;
  for (int i = 0; i < n; i += 3)
    if (dofs[i] % 3 != 0 || dofs[i + 1] != dofs[i] + 1 || dofs[i + 2] != dofs[i] + 2) return false;
  return true;
}

}  // namespace

void AssemblyTarget::add_tangent(int nr, const int* rows, int nc, const int* cols, const double* k) {
  const std::vector<int>& eq = s_.dofs_.eq;
  const bool predictor = !du_c.empty();
  auto outside = [] { throw std::logic_error("a contribution's tangent entry lies outside its declared couplings"); };
  if (!s_.distributed_ && node_triples(nr, rows) && node_triples(nc, cols)) {
    // Whole nodes on both sides (every element's block): the pattern keeps a node's free rows
    // contiguous and the three columns of a node alike (build_pattern), so one search per node pair
    // places its 3x3 block, as the solids' precomputed offsets do; a search per entry was most of the
    // shells' scatter (324 per triangle).
    double* kv = s_.K_.values.data();
    for (int jb = 0; jb < nc; jb += 3) {
      int any_col = -1;
      for (int j = 0; j < 3 && any_col < 0; ++j) any_col = eq[cols[jb + j]];
      for (int ib = 0; ib < nr; ib += 3) {
        const auto& fr = s_.free_rank_[rows[ib] / 3];
        long offset = -1;  // of the node's first free row within a column of node cols[jb] / 3
        for (int i = 0; i < 3 && offset < 0 && any_col >= 0; ++i)
          if (fr[i] >= 0) {
            const long pos = s_.K_.find(eq[rows[ib + i]], any_col);
            if (pos < 0) outside();
            offset = pos - s_.K_.colptr[any_col] - fr[i];
          }
        for (int j = 0; j < 3; ++j) {
          const int cdof = cols[jb + j];
          const int col = eq[cdof];
          const double* kc = k + ib + std::size_t(nr) * (jb + j);
          if (col >= 0 && offset >= 0) {
            double* column = kv + s_.K_.colptr[col] + offset;
            for (int i = 0; i < 3; ++i)
              if (fr[i] >= 0) column[fr[i]] += kc[i];
          } else if (col < 0 && predictor && du_c[cdof] != 0.0) {
            for (int i = 0; i < 3; ++i)
              if (fr[i] >= 0) out.dirichlet_rhs[rows[ib + i]] += kc[i] * du_c[cdof];
          }
        }
      }
    }
    return;
  }
  for (int j = 0; j < nc; ++j) {
    const int cdof = cols[j];
    const int col = eq[cdof];
    for (int i = 0; i < nr; ++i) {
      const int row = eq[rows[i]];
      if (row < 0) continue;
      const double v = k[i + std::size_t(nr) * j];
      if (col >= 0 && s_.distributed_) {
        s_.petsc_->add_entry(rows[i], cdof, v);
      } else if (col >= 0) {
        const long pos = s_.K_.find(row, col);
        if (pos < 0) outside();
        s_.K_.values[pos] += v;
      } else if (predictor && du_c[cdof] != 0.0) {
        out.dirichlet_rhs[rows[i]] += v * du_c[cdof];
      }
    }
  }
}

void AssemblyTarget::add_border(int n, const int* dofs, const double* dR_dlambda, const double* dc_du) {
  for (int i = 0; i < n; ++i) {
    out.a[dofs[i]] += dR_dlambda[i];
    out.g[dofs[i]] += dc_du[i];
  }
}

void AssemblyTarget::add_constraint_value(double value) { out.volume += value; }

namespace {

/// One thread's part of the solids' element loop: its scratch, and the steps from an element's kernel
/// to its scatter, the same for hex8 and tet10 (NN nodes).
struct ElementPass {
  Simulation::Impl& s;
  Assembly& out;
  const std::vector<double>& u;
  const std::vector<double>& du_c;
  double dt;
  bool tangent, concurrent_fill;
  std::atomic<int>& failed;
  std::atomic<int>& failed_status;
  bool mixed = !s.mix_bulk_.empty();
  bool predictor = !du_c.empty();
  double* R = out.R.data();
  double* Rt = mixed ? out.R_true.data() : nullptr;
  double* Ru = mixed ? out.R_u.data() : nullptr;
  double* drhs = predictor ? out.dirichlet_rhs.data() : nullptr;
  // Per-thread scratch of the element kernels (each pass overwrites them before use).
  Mat3 sigma = Mat3::Zero();
  Vec24 r = Vec24::Zero();
  Mat24 Ke = Mat24::Zero();
  Vec30 r10 = Vec30::Zero();
  Mat30 K10 = Mat30::Zero();

  void claim_failure(int e, MaterialStatus st) {
    int expected = -1;
    if (failed.compare_exchange_strong(expected, e)) failed_status = int(st);
  }

  /// The tangent column by column into K (block: the element's node-pair offsets) and, for a
  /// prescribed column, its increment into the predictor's right-hand side (K_fc Δu_c).
  template <int NN, class KE>
  void scatter_tangent(const std::array<int, 3 * NN>& gdof, const int* nodes, const KE& Kel, const long* block) {
    constexpr int ND = 3 * NN;
    const std::vector<int>& eq = s.dofs_.eq;
    double* kv = s.K_.values.data();
    for (int b = 0; b < NN; ++b)
      for (int j = 0; j < 3; ++j) {
        const int cl = 3 * b + j;
        const int col = eq[gdof[cl]];
        if (col < 0) {
          if (predictor && du_c[gdof[cl]] != 0.0)
            for (int rw = 0; rw < ND; ++rw) drhs[gdof[rw]] += Kel(rw, cl) * du_c[gdof[cl]];
          continue;
        }
        if (s.distributed_) continue;
        double* column = kv + s.K_.colptr[col];
        for (int a = 0; a < NN; ++a) {
          const long o = block[NN * a + b];
          if (o < 0) continue;
          const auto& fr = s.free_rank_[nodes[a]];
          for (int i = 0; i < 3; ++i)
            if (fr[i] >= 0) column[o + fr[i]] += Kel(3 * a + i, cl);
        }
      }
  }

  /// Cauchy stress, the residuals (R, and in the mixed iteration R_true / R_u with the element's volume
  /// shifts) and the tangent: into K_, or on the petsc path into PETSc's matrix.
  template <class Nodes, class RE, class KE, class MV>
  void scatter(int e, const Nodes& nodes, const RE& re, const KE& Kel, const MV* mv, const long* block, double volume) {
    constexpr int NN = int(std::tuple_size_v<Nodes>);
    constexpr int ND = 3 * NN;
    std::array<int, ND> gdof;
    for (int c = 0; c < 9; ++c) out.cauchy[9 * std::size_t(e) + c] = sigma(c / 3, c % 3);
    for (int a = 0; a < NN; ++a)
      for (int i = 0; i < 3; ++i) gdof[3 * a + i] = 3 * nodes[a] + i;
    for (int q = 0; q < ND; ++q) R[gdof[q]] += re[q];
    if (mixed)
      for (int q = 0; q < ND; ++q) {
        Rt[gdof[q]] += re[q] - (mv ? mv->shift * mv->d[q] : 0.0);
        Ru[gdof[q]] += re[q] - (mv ? mv->shift_u * mv->d[q] : 0.0);
      }
    if (!tangent) return;
    scatter_tangent<NN>(gdof, nodes.data(), Kel, block);
    if (!s.distributed_) return;
    // Three-field elements enter uncondensed, c = V_e U″(θ) as in saddle_current.
    const double c = mv ? volume * volumetric_d2U(s.mix_bulk_[e], s.mix_theta_[e]) : 0.0;
    if (concurrent_fill) {
      s.petsc_->add_element(e, NN, nodes.data(), Kel.data(), mv ? mv->d.data() : nullptr, c, volume);
    } else {
#pragma omp critical(softhom_petsc_fill)
      s.petsc_->add_element(e, NN, nodes.data(), Kel.data(), mv ? mv->d.data() : nullptr, c, volume);
    }
  }

  /// One element of either kind: its kernel (hex8_internal_force or tet10_internal_force) from the
  /// committed state, then what it leaves for the iteration (θ_e(u) and ∂θ_e/∂u of a three-field
  /// element) and the scatter. `mv` is the element's fresh mixed-volume record.
  template <class Geometry, class Nodes, class Kernel, class RE, class KE, class MV, class D>
  void element(int e, const Geometry& geometry, const Nodes& nodes, Kernel kernel, RE& re, KE& Kel, MV& mv,
               D& d_of_element, const long* block) {
    const int off = s.state_offset_[e];
    const bool me = mixed && s.mix_bulk_[e] > 0.0;
    if (me) {
      mv.bulk = s.mix_bulk_[e];
      mv.theta = s.mix_theta_[e];
      mv.p = s.mix_p_[e];
    }
    const MaterialStatus st = kernel(geometry, gather(u, nodes), *s.model_.element_material[e],
                                     off >= 0 ? s.state_old_.data() + off : nullptr,
                                     off >= 0 ? s.state_new_.data() + off : nullptr, dt, s.model_.formulation, re,
                                     tangent ? &Kel : nullptr, &sigma, me ? &mv : nullptr);
    if (st != MaterialStatus::ok) {
      claim_failure(e, st);
      return;
    }
    if (me) {
      s.mix_theta_u_[e] = mv.theta_u;
      d_of_element = mv.d;
    }
    scatter(e, nodes, re, Kel, me ? &mv : nullptr, block, geometry.volume);
  }

  void element(int e) {
    const Mesh& mesh = s.model_.mesh;
    const int slot = s.geometry_slot_[e];
    if (mesh.is_tet(e)) {
      const int t = e - mesh.num_hexes();
      Tet10MixedVolume mv;
      element(e, s.tet_geometry_[slot], mesh.tets[t], [](auto&&... a) { return tet10_internal_force(a...); }, r10, K10,
              mv, s.mix_d_tet_[slot], s.tet_block_.empty() ? nullptr : s.tet_block_[t].data());
    } else {
      MixedVolume mv;
      element(e, s.geometry_[slot], mesh.hexes[e], [](auto&&... a) { return hex8_internal_force(a...); }, r, Ke, mv,
              s.mix_d_[slot], s.block_.empty() ? nullptr : s.block_[e].data());
    }
  }
};

}  // namespace

void Simulation::Impl::assemble_elements(double dt, bool tangent, const std::vector<double>& u,
                                         const std::vector<double>& du_c, Assembly& out) {
  // Element residuals (and tangents) scattered colour by colour; the first failed material call
  // (the first to claim it among the threads) is reported in out.failed_element / out.status.
  std::atomic<int> failed{-1};
  std::atomic<int> failed_status{0};
  // Small meshes assemble on one thread: the work per colour is a few microseconds, and on a shared
  // (oversubscribed) 2-core machine every OpenMP barrier of a spinning runtime can cost a time slice
  // (measured 4x slower assembly with 2 threads at load 8 on the 256-element plane-strain tube).
  // Distributed assembly on several ranks: one thread (one rank per core). On one process the threads
  // share the colours; the elements of one colour share no node, hence no matrix entry, so the sums do
  // not depend on the order. The first fill of the PETSc matrix goes through MatSetValues (not
  // thread-safe), one element at a time; the later ones write straight into its values, concurrently.
  const int threads = model_.mesh.num_elements() >= 4000 && !(distributed_ && mpi_ranks_ > 1) ? omp_get_max_threads() : 1;
  const bool concurrent_fill = tangent && distributed_ && petsc_->concurrent_fill();
#pragma omp parallel num_threads(threads)
  {
    ElementPass pass{*this, out, u, du_c, dt, tangent, concurrent_fill, failed, failed_status};
    for (const std::vector<int>& color : colors_) {
      // Elements of one colour share no node: plain (non-atomic) updates are race-free.
#pragma omp for schedule(dynamic, 32)
      for (std::size_t k = 0; k < color.size(); ++k) {
        if (failed.load(std::memory_order_relaxed) >= 0) continue;
        pass.element(color[k]);
      }
    }
  }
  out.failed_element = failed.load();
  out.status = out.failed_element >= 0 ? MaterialStatus(failed_status.load()) : MaterialStatus::ok;
}

}  // namespace softhom::fe
