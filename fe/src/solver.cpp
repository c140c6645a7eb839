#include "softhom/fe/solver.hpp"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <sstream>
#include <tuple>
#include <type_traits>

#include <Eigen/Dense>

#include "softhom/materials/errors.hpp"

namespace softhom::fe {
namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

double norm(const std::vector<double>& v) {
  double s = 0.0;
  for (double x : v) s += x * x;
  return std::sqrt(s);
}

Mat83 gather(const std::vector<double>& u, const Hex& hex) {
  Mat83 ue;
  for (int a = 0; a < 8; ++a)
    for (int i = 0; i < 3; ++i) ue(a, i) = u[3 * hex[a] + i];
  return ue;
}

Tet10Coords gather(const std::vector<double>& u, const Tet10& tet) {
  Tet10Coords ue;
  for (int a = 0; a < 10; ++a)
    for (int i = 0; i < 3; ++i) ue(a, i) = u[3 * tet[a] + i];
  return ue;
}

/// Gauss points per element (history blocks).
int gauss_points(const Mesh& mesh, int e) { return mesh.is_tet(e) ? 4 : 8; }

}  // namespace

struct Simulation::Assembly {
  std::vector<double> R;       ///< f_int − f_ext on all dofs (condensed three-field residual: Newton's rhs)
  std::vector<double> R_true;  ///< the F-bar residual (convergence test); empty without three-field elements
  std::vector<double> R_u;     ///< u-row of the three-field residual r_rest + V p d (line search); idem
  std::vector<double> a;       ///< cavity unit-pressure vector on all dofs (∂R/∂p)
  std::vector<double> g;       ///< cavity volume gradient on all dofs (∂V/∂u; −a when the faces close the cavity)
  std::vector<double> dirichlet_rhs;  ///< K_fc Δu_c on all dofs (predictor only)
  std::vector<double> cauchy;  ///< 9 per element
  std::vector<double> fint;    ///< internal forces on all dofs (F-bar), for reactions at the converged state
  double fint_norm = 0.0, fext_norm = 0.0, volume = 0.0;
  MaterialStatus status = MaterialStatus::ok;
  int failed_element = -1;
};

Simulation::Simulation(FeModel model, NewtonOptions options) : model_(std::move(model)), options_(options) {
  model_.validate();
  const Mesh& mesh = model_.mesh;
  const int ndof = mesh.num_dofs();
  std::vector<char> constrained(ndof, 0);
  for (const auto& g : model_.dirichlet)
    for (int d : g.dofs) constrained[d] = 1;
  dofs_ = DofMap::from_constrained(ndof, constrained);
  if (dofs_.num_free == 0) throw InputError("boundary", "", "every degree of freedom is prescribed");
  K_ = build_pattern(mesh, dofs_);

  geometry_.resize(mesh.num_hexes());
  int bad = -1;
  for (int e = 0; e < mesh.num_hexes(); ++e) {
    Mat83 X;
    for (int a = 0; a < 8; ++a) X.row(a) = mesh.nodes[mesh.hexes[e][a]].transpose();
    geometry_[e] = hex8_geometry(X);
    if (!geometry_[e].valid && bad < 0) bad = e;
  }
  tet_geometry_.resize(mesh.tets.size());
  for (std::size_t t = 0; t < mesh.tets.size(); ++t) {
    Tet10Coords X;
    for (int a = 0; a < 10; ++a) X.row(a) = mesh.nodes[mesh.tets[t][a]].transpose();
    tet_geometry_[t] = tet10_geometry(X);
    if (!tet_geometry_[t].valid && bad < 0) bad = mesh.num_hexes() + int(t);
  }
  if (bad >= 0) throw InputError("mesh", "element " + std::to_string(bad), "non-positive Jacobian at a Gauss point");

  state_offset_.assign(mesh.num_elements(), -1);
  std::size_t total = 0;
  for (int e = 0; e < mesh.num_elements(); ++e) {
    const int ns = model_.element_material[e]->state_size();
    if (ns > 0) {
      state_offset_[e] = int(total);
      total += gauss_points(mesh, e) * std::size_t(ns);
    }
  }
  state_old_.assign(total, 0.0);
  for (int e = 0; e < mesh.num_elements(); ++e)
    if (state_offset_[e] >= 0) {
      const auto& m = *model_.element_material[e];
      for (int q = 0; q < gauss_points(mesh, e); ++q) m.init_state(state_old_.data() + state_offset_[e] + q * m.state_size());
    }
  state_new_ = state_old_;

  SolverKind kind = options_.solver;
  // Automatic: Cholesky of the symmetric part (exact without follower pressure, a GMRES
  // preconditioner with it); refactor() switches to LU if that part is not positive definite.
  if (kind == SolverKind::automatic) kind = SolverKind::cholmod;
  if (kind == SolverKind::umfpack) lu_ = make_linear_solver(SolverKind::umfpack);
  else chol_ = make_linear_solver(SolverKind::cholmod);
  linear_ = chol_ ? chol_.get() : lu_.get();

  // Greedy element colouring: elements of one colour share no node, so assembly needs no atomics.
  {
    std::vector<std::vector<int>> node_elems(mesh.num_nodes());
    for (int e = 0; e < mesh.num_elements(); ++e)
      for (int a = 0; a < mesh.element_size(e); ++a) node_elems[mesh.element_nodes(e)[a]].push_back(e);
    std::vector<int> color(mesh.num_elements(), -1), mark;
    for (int e = 0; e < mesh.num_elements(); ++e) {
      for (int a = 0; a < mesh.element_size(e); ++a)
        for (int o : node_elems[mesh.element_nodes(e)[a]])
          if (color[o] >= 0) {
            if (int(mark.size()) <= color[o]) mark.resize(color[o] + 1, -1);
            mark[color[o]] = e;
          }
      int c = 0;
      while (c < int(mark.size()) && mark[c] == e) ++c;
      color[e] = c;
      if (int(colors_.size()) <= c) colors_.resize(c + 1);
      colors_[c].push_back(e);
    }
  }
  // Scatter positions: build_pattern stores the rows of the three columns of node b identically
  // (node-major, components ascending), so one offset per node pair locates a 3x3 block.
  free_rank_.resize(mesh.num_nodes());
  for (int n = 0; n < mesh.num_nodes(); ++n) {
    signed char r = 0;
    for (int i = 0; i < 3; ++i) free_rank_[n][i] = dofs_.eq[3 * n + i] >= 0 ? r++ : -1;
  }
  // Per element type: block[n * a + b] for the n nodes of the element.
  auto block_offsets = [&](const int* nodes, int n, long* block) {
    for (int b = 0; b < n; ++b) {
      int col = -1;  // any free column of node b
      for (int j = 0; j < 3 && col < 0; ++j) col = dofs_.eq[3 * nodes[b] + j];
      for (int a = 0; a < n; ++a) {
        long pos = -1;
        if (col >= 0)
          for (int i = 0; i < 3 && pos < 0; ++i) {
            const int row = dofs_.eq[3 * nodes[a] + i];
            if (row >= 0) pos = K_.find(row, col) - free_rank_[nodes[a]][i] - K_.colptr[col];
          }
        block[n * a + b] = pos;  // offset within the column
      }
    }
  };
  block_.resize(mesh.num_hexes());
  for (int e = 0; e < mesh.num_hexes(); ++e) block_offsets(mesh.hexes[e].data(), 8, block_[e].data());
  tet_block_.resize(mesh.tets.size());
  for (std::size_t t = 0; t < mesh.tets.size(); ++t) block_offsets(mesh.tets[t].data(), 10, tet_block_[t].data());
  if (model_.formulation == Formulation::fbar && options_.mixed) {
    mix_bulk_.assign(mesh.num_elements(), 0.0);
    bool any = false;
    for (int e = 0; e < mesh.num_elements(); ++e) {
      mix_bulk_[e] = model_.element_material[e]->volumetric_modulus();
      any |= mix_bulk_[e] > 0.0;
    }
    if (!any) {
      mix_bulk_.clear();
    } else {
      mix_theta_conv_.assign(mesh.num_elements(), 1.0);
      mix_p_conv_.assign(mesh.num_elements(), 0.0);
      mix_theta_ = mix_theta_conv_;
      mix_p_ = mix_p_conv_;
      mix_theta_u_ = mix_theta_conv_;
      mix_d_.assign(mesh.num_hexes(), Vec24::Zero());
      mix_d_tet_.assign(mesh.tets.size(), Vec30::Zero());
      // Element pressure unknowns of the uncondensed Krylov space (linear_solve).
      sad_off_.push_back(0);
      for (int e = 0; e < mesh.num_elements(); ++e) {
        if (mix_bulk_[e] <= 0.0) continue;
        sad_elem_.push_back(e);
        const int* en = mesh.element_nodes(e);
        for (int a = 0; a < mesh.element_size(e); ++a)
          for (int i = 0; i < 3; ++i) sad_eq_.push_back(dofs_.eq[3 * en[a] + i]);
        sad_off_.push_back(int(sad_eq_.size()));
      }
      // The element colouring carried over to them: race-free parallel scatters of Σ_e d_e a_e.
      std::vector<int> index(mesh.num_elements(), -1);
      for (std::size_t k = 0; k < sad_elem_.size(); ++k) index[sad_elem_[k]] = int(k);
      for (const auto& color : colors_) {
        sad_colors_.emplace_back();
        for (int e : color)
          if (index[e] >= 0) sad_colors_.back().push_back(index[e]);
      }
    }
  }

  u_.assign(ndof, 0.0);
  u_prev_step_ = u_;
  u_prev2_step_ = u_;
  if (model_.cavity)
    cavity_v0_ = cavity_volume(mesh.nodes, model_.cavity->faces, model_.cavity->mask, model_.cavity->tris);
  if (model_.cavity && !(cavity_v0_ > 0.0))
    throw InputError("cavity", std::to_string(cavity_v0_), "enclosed volume must be positive (check face orientation)");
}

Simulation::~Simulation() = default;

SolverKind Simulation::solver_kind() const { return linear_->kind(); }

MaterialStatus Simulation::element_force(int e, const Tet10Coords& u, Vec30& r, Mat30* K) const {
  const int off = state_offset_[e];
  std::vector<double> scratch(off >= 0 ? 4 * model_.element_material[e]->state_size() : 0);
  return tet10_internal_force(tet_geometry_[e - model_.mesh.num_hexes()], u, *model_.element_material[e],
                              off >= 0 ? state_old_.data() + off : nullptr, off >= 0 ? scratch.data() : nullptr,
                              last_dt_, model_.formulation, r, K);
}

MaterialStatus Simulation::element_force(int e, const Mat83& u, Vec24& r, Mat24* K) const {
  const int off = state_offset_[e];
  std::vector<double> scratch(off >= 0 ? 8 * model_.element_material[e]->state_size() : 0);
  return hex8_internal_force(geometry_[e], u, *model_.element_material[e], off >= 0 ? state_old_.data() + off : nullptr,
                             off >= 0 ? scratch.data() : nullptr, last_dt_, model_.formulation, r, K);
}

std::vector<Vec3> Simulation::current_positions() const {
  std::vector<Vec3> x(model_.mesh.nodes);
  for (std::size_t n = 0; n < x.size(); ++n) x[n] += Vec3(u_[3 * n], u_[3 * n + 1], u_[3 * n + 2]);
  return x;
}

MaterialStatus Simulation::assemble(double t, double dt, bool tangent, const std::vector<double>& u, double cavity_p,
                                    Assembly& out) {
  const auto t0 = std::chrono::steady_clock::now();
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
  out.cauchy.resize(9 * std::size_t(mesh.num_elements()));
  if (tangent) {
    K_.set_zero();
    ++k_version_;
    ++stats_.tangent_assemblies;
  } else {
    ++stats_.residual_assemblies;
  }
  const bool predictor = !out.dirichlet_rhs.empty();
  std::vector<double> du_c;
  if (predictor) {
    du_c.swap(out.dirichlet_rhs);
    out.dirichlet_rhs.assign(ndof, 0.0);
  }
  std::atomic<int> failed{-1};
  std::atomic<int> failed_status{0};
  const std::vector<int>& eq = dofs_.eq;
  double* kv = K_.values.data();
  double* R = out.R.data();
  double* Rt = mixed ? out.R_true.data() : nullptr;
  double* Ru = mixed ? out.R_u.data() : nullptr;
  double* drhs = predictor ? out.dirichlet_rhs.data() : nullptr;

  // Small meshes assemble on one thread: the work per colour is a few microseconds, and on a shared
  // (oversubscribed) 2-core machine every OpenMP barrier of a spinning runtime can cost a time slice
  // (measured 4x slower assembly with 2 threads at load 8 on the 256-element plane-strain tube).
  const int threads = mesh.num_elements() >= 4000 ? omp_get_max_threads() : 1;
#pragma omp parallel num_threads(threads)
  {
    Vec24 r;
    Mat24 Ke;
    Mat3 sigma;
    std::array<int, 24> gdof;
    // Tet10 elements: the steps of the hex8 body below with 10 nodes (tet10_element.hpp).
    Vec30 r10;
    Mat30 K10;
    std::array<int, 30> gdof10;
    auto tet_element = [&](int e) {
      const int t = e - mesh.num_hexes();
      const Tet10& tet = mesh.tets[t];
      const Tet10Coords ue = gather(u, tet);
      const int off = state_offset_[e];
      Tet10MixedVolume mv;
      const bool me = mixed && mix_bulk_[e] > 0.0;
      if (me) {
        mv.bulk = mix_bulk_[e];
        mv.theta = mix_theta_[e];
        mv.p = mix_p_[e];
      }
      const MaterialStatus st = tet10_internal_force(
          tet_geometry_[t], ue, *model_.element_material[e], off >= 0 ? state_old_.data() + off : nullptr,
          off >= 0 ? state_new_.data() + off : nullptr, dt, model_.formulation, r10, tangent ? &K10 : nullptr,
          &sigma, me ? &mv : nullptr);
      if (st != MaterialStatus::ok) {
        int expected = -1;
        if (failed.compare_exchange_strong(expected, e)) failed_status = int(st);
        return;
      }
      if (me) {
        mix_theta_u_[e] = mv.theta_u;
        mix_d_tet_[t] = mv.d;
      }
      for (int c = 0; c < 9; ++c) out.cauchy[9 * std::size_t(e) + c] = sigma(c / 3, c % 3);
      for (int a = 0; a < 10; ++a)
        for (int i = 0; i < 3; ++i) gdof10[3 * a + i] = 3 * tet[a] + i;
      for (int q = 0; q < 30; ++q) R[gdof10[q]] += r10[q];
      if (mixed)
        for (int q = 0; q < 30; ++q) {
          Rt[gdof10[q]] += r10[q] - (me ? mv.shift * mv.d[q] : 0.0);
          Ru[gdof10[q]] += r10[q] - (me ? mv.shift_u * mv.d[q] : 0.0);
        }
      if (!tangent) return;
      for (int b = 0; b < 10; ++b)
        for (int j = 0; j < 3; ++j) {
          const int cl = 3 * b + j;
          const int col = eq[gdof10[cl]];
          if (col < 0) {
            if (predictor && du_c[gdof10[cl]] != 0.0)
              for (int rw = 0; rw < 30; ++rw) drhs[gdof10[rw]] += K10(rw, cl) * du_c[gdof10[cl]];
            continue;
          }
          double* column = kv + K_.colptr[col];
          for (int a = 0; a < 10; ++a) {
            const long o = tet_block_[t][10 * a + b];
            if (o < 0) continue;
            const auto& fr = free_rank_[tet[a]];
            for (int i = 0; i < 3; ++i)
              if (fr[i] >= 0) column[o + fr[i]] += K10(3 * a + i, cl);
          }
        }
    };
    for (const std::vector<int>& color : colors_) {
      // Elements of one colour share no node: plain (non-atomic) updates are race-free.
#pragma omp for schedule(dynamic, 32)
      for (std::size_t k = 0; k < color.size(); ++k) {
        const int e = color[k];
        if (failed.load(std::memory_order_relaxed) >= 0) continue;
        if (mesh.is_tet(e)) {
          tet_element(e);
          continue;
        }
        const Hex& hex = mesh.hexes[e];
        const Mat83 ue = gather(u, hex);
        const int off = state_offset_[e];
        MixedVolume mv;
        const bool me = mixed && mix_bulk_[e] > 0.0;
        if (me) {
          mv.bulk = mix_bulk_[e];
          mv.theta = mix_theta_[e];
          mv.p = mix_p_[e];
        }
        const MaterialStatus st = hex8_internal_force(
            geometry_[e], ue, *model_.element_material[e], off >= 0 ? state_old_.data() + off : nullptr,
            off >= 0 ? state_new_.data() + off : nullptr, dt, model_.formulation, r, tangent ? &Ke : nullptr,
            &sigma, me ? &mv : nullptr);
        if (st != MaterialStatus::ok) {
          int expected = -1;
          if (failed.compare_exchange_strong(expected, e)) failed_status = int(st);
          continue;
        }
        if (me) {
          mix_theta_u_[e] = mv.theta_u;
          mix_d_[e] = mv.d;
        }
        for (int c = 0; c < 9; ++c) out.cauchy[9 * std::size_t(e) + c] = sigma(c / 3, c % 3);
        for (int a = 0; a < 8; ++a)
          for (int i = 0; i < 3; ++i) gdof[3 * a + i] = 3 * hex[a] + i;
        for (int q = 0; q < 24; ++q) R[gdof[q]] += r[q];
        if (mixed) {
          if (me) {
            for (int q = 0; q < 24; ++q) {
              Rt[gdof[q]] += r[q] - mv.shift * mv.d[q];
              Ru[gdof[q]] += r[q] - mv.shift_u * mv.d[q];
            }
          } else {
            for (int q = 0; q < 24; ++q) {
              Rt[gdof[q]] += r[q];
              Ru[gdof[q]] += r[q];
            }
          }
        }
        if (!tangent) continue;
        for (int b = 0; b < 8; ++b)
          for (int j = 0; j < 3; ++j) {
            const int cl = 3 * b + j;
            const int col = eq[gdof[cl]];
            if (col < 0) {
              // Prescribed column: its increment enters the predictor's right-hand side (K_fc Δu_c).
              if (predictor && du_c[gdof[cl]] != 0.0)
                for (int rw = 0; rw < 24; ++rw) drhs[gdof[rw]] += Ke(rw, cl) * du_c[gdof[cl]];
              continue;
            }
            double* column = kv + K_.colptr[col];
            for (int a = 0; a < 8; ++a) {
              const long o = block_[e][8 * a + b];
              if (o < 0) continue;
              const auto& fr = free_rank_[hex[a]];
              for (int i = 0; i < 3; ++i)
                if (fr[i] >= 0) column[o + fr[i]] += Ke(3 * a + i, cl);
            }
          }
      }
    }
  }
  out.failed_element = failed.load();
  out.status = out.failed_element >= 0 ? MaterialStatus(failed_status.load()) : MaterialStatus::ok;
  if (out.status != MaterialStatus::ok) {
    stats_.assembly_time += seconds_since(t0);
    return out.status;
  }
  out.fint_norm = norm(out.R);
  out.fint = mixed ? out.R_true : out.R;  // before the loads: the internal forces alone

  // Follower pressures: R += p a(x), K += p ∂a/∂x (unsymmetric load stiffness).
  std::vector<double> fext(ndof, 0.0);
  // Quads (bilinear) and 6-node triangles (tet faces): the same steps with nf nodes per face.
  auto add_faces = [&](const auto& faces, double p, bool collect, double pk) {
    constexpr int nf = std::tuple_size_v<typename std::decay_t<decltype(faces)>::value_type>;
    static_assert(nf == 4 || nf == 6);
    std::conditional_t<nf == 4, Vec12, Vec18> a, dflux;
    std::conditional_t<nf == 4, Mat12, Mat18> da;
    const Vec3 mask = model_.cavity ? model_.cavity->mask : Vec3::Ones();
    for (const auto& q : faces) {
      std::conditional_t<nf == 4, Mat43, Mat63> xe;
      for (int k = 0; k < nf; ++k)
        xe.row(k) = (mesh.nodes[q[k]] + Vec3(u[3 * q[k]], u[3 * q[k] + 1], u[3 * q[k] + 2])).transpose();
      double flux = 0.0;
      if constexpr (nf == 4) quad4_pressure(xe, mask, a, tangent ? &da : nullptr, flux, collect ? &dflux : nullptr);
      else tri6_pressure(xe, mask, a, tangent ? &da : nullptr, flux, collect ? &dflux : nullptr);
      if (collect) out.volume -= flux / mask.sum();
      for (int k = 0; k < nf; ++k)
        for (int i = 0; i < 3; ++i) {
          const int dof = 3 * q[k] + i;
          R[dof] += p * a[3 * k + i];
          if (Rt) {
            Rt[dof] += p * a[3 * k + i];
            Ru[dof] += p * a[3 * k + i];
          }
          fext[dof] -= p * a[3 * k + i];
          if (collect) {
            out.a[dof] += a[3 * k + i];
            out.g[dof] -= dflux[3 * k + i] / mask.sum();
          }
        }
      if (!tangent || pk == 0.0) continue;
      for (int m = 0; m < nf; ++m)
        for (int j = 0; j < 3; ++j) {
          const int col = eq[3 * q[m] + j];
          const int cdof = 3 * q[m] + j;
          for (int k = 0; k < nf; ++k)
            for (int i = 0; i < 3; ++i) {
              const int row = eq[3 * q[k] + i];
              if (row < 0) continue;
              if (col >= 0)
                kv[K_.find(row, col)] += pk * da(3 * k + i, 3 * m + j);
              else if (predictor && du_c[cdof] != 0.0)
                drhs[3 * q[k] + i] += pk * da(3 * k + i, 3 * m + j) * du_c[cdof];
            }
        }
    }
  };
  for (const auto& load : model_.pressures) {
    // The load stiffness takes the pressure at stiffness_time_ when set (the first iteration of a step
    // started at the converged state: see try_step), else the residual's.
    const double pk = load.pressure(stiffness_time_ >= 0.0 ? stiffness_time_ : t);
    add_faces(load.faces, load.pressure(t), false, pk);
    add_faces(load.tris, load.pressure(t), false, pk);
  }
  for (const auto& load : model_.nodal_loads) {
    const double v = load.value(t);
    for (std::size_t k = 0; k < load.dofs.size(); ++k) {
      const double f = load.scale[k] * v;
      R[load.dofs[k]] -= f;
      if (Rt) {
        Rt[load.dofs[k]] -= f;
        Ru[load.dofs[k]] -= f;
      }
      fext[load.dofs[k]] += f;
    }
  }
  out.volume = 0.0;
  if (model_.cavity) {
    out.a.assign(ndof, 0.0);
    out.g.assign(ndof, 0.0);
    add_faces(model_.cavity->faces, cavity_p, true, cavity_p);
    add_faces(model_.cavity->tris, cavity_p, true, cavity_p);
  }
  out.fext_norm = norm(fext);
  stats_.assembly_time += seconds_since(t0);
  return MaterialStatus::ok;
}

namespace {
/// Runs a scope with one OpenMP thread (so one BLAS thread with OpenBLAS-OpenMP): small supernodes
/// gain nothing from threads, and a threaded BLAS on a loaded machine spins (measured 7x slower
/// factorizations of a 1152-dof tube at load 8 on 2 cores).
/// Factorizations below this many flops run on one thread. With the coarse supernodes of
/// fe::CholmodSolver a second BLAS thread does not pay below ~50 GFlop on the 2-core box (idle,
/// passive wait policy, `bench_macro --factor`): 3e4-dof tube (5.9 GFlop) 0.39 s on 1 thread vs
/// 0.53 s on 2; 1e5 dofs (52 GFlop) 2.29 s on 1 vs 2.29–2.47 s on 2; 1e6 (5.6 TFlop) 39 GFlop/s on 2.
constexpr double kThreadedFactorFlops = 2e10;
struct ThreadScope {
  int saved;
  explicit ThreadScope(bool one) : saved(omp_get_max_threads()) {
    if (one) omp_set_num_threads(1);
  }
  ~ThreadScope() { omp_set_num_threads(saved); }
};
}  // namespace

bool Simulation::refactor(std::string& why) {
  // The first factorization has no measured cost yet: take CHOLMOD's estimate from the analysis (a
  // 1e5-dof tube's first factorization otherwise ran on one thread).
  if (last_factor_flops_ == 0.0 && chol_ && !lu_this_step_) {
    if (!chol_analyzed_) {
      chol_->analyze(K_);
      chol_analyzed_ = true;
    }
    last_factor_flops_ = chol_->predicted_flops();
  }
  const ThreadScope scope(last_factor_flops_ < kThreadedFactorFlops);
  const auto t0 = std::chrono::steady_clock::now();
  // Is K symmetric (no follower pressure, hyperelastic law)? Then a Cholesky factor is exact.
  double asym = 0.0, big = 0.0;
  for (long k = 0; k < K_.nnz(); ++k) {
    big = std::max(big, std::abs(K_.values[k]));
    asym = std::max(asym, std::abs(K_.values[k] - K_.values[K_.mirror[k]]));
  }
  bool ok = false;
  double flops_before = 0.0;
  if (chol_ && !lu_this_step_) {
    if (!chol_analyzed_) {
      chol_->analyze(K_);
      chol_analyzed_ = true;
    }
    flops_before = chol_->times().flops;
    ok = chol_->factorize(K_);
    linear_ = chol_.get();
    if (!ok) {
      // Symmetric part not positive definite (an iterate past a limit point or near a buckling
      // mode): LU for the rest of this step; Cholesky is tried again in the next one.
      lu_this_step_ = true;
      stats_.log.push_back("tangent not positive definite at t = " + std::to_string(time_) + ": UMFPACK LU for this step");
      if (options_.verbose) std::cerr << stats_.log.back() << "\n";
    }
  }
  if (!ok) {
    if (!lu_) lu_ = make_linear_solver(SolverKind::umfpack);
    if (!lu_analyzed_) {
      lu_->analyze(K_);
      lu_analyzed_ = true;
    }
    flops_before = lu_->times().flops;
    ok = lu_->factorize(K_);
    linear_ = lu_.get();
  }
  last_factor_flops_ = linear_->times().flops - flops_before;
  // The uncondensed preconditioner inverts the saddle system of the factorized tangent: keep its d_e, c_e
  // (only where factors are lagged: > lag_flops, see linear_solve).
  if (ok && saddle_lagged()) saddle_current();
  if (ok && sad_b_version_ == k_version_) {
    sad_da_ = sad_db_;
    sad_ca_ = sad_cb_;
    sad_a_valid_ = true;
  } else {
    sad_a_valid_ = false;
  }
  factor_valid_ = ok;
  factor_stale_ = false;
  factor_version_ = k_version_;
  factor_exact_ = linear_->kind() == SolverKind::umfpack || asym <= 1e-13 * big;
  last_factor_time_ = seconds_since(t0);
  if (!ok) why = "singular tangent";
  return ok;
}

bool Simulation::linear_solve(const std::vector<double>& b, std::vector<double>& x, double tol, std::string& why) {
  const int n = dofs_.num_free;
  const double bnorm = norm(b);
  x.assign(n, 0.0);
  if (bnorm == 0.0) return true;
  const ThreadScope scope(last_factor_flops_ < kThreadedFactorFlops);
  if (saddle_lagged()) saddle_current();
  // A cheap factorization (< 2 GFlop, well under a second) is simply redone for every new tangent:
  // a lagged one saves little there and costs GMRES iterations. Larger systems keep the factor.
  const bool cheap = last_factor_flops_ < options_.lag_flops;
  if (!factor_valid_ || factor_stale_ || (cheap && factor_version_ != k_version_))
    if (!refactor(why)) return false;
  // A factorization of this very tangent (LU, or Cholesky of a symmetric one) is a direct solve.
  // Near a limit point K is nearly singular and its solutions are inaccurate along the null vector;
  // the cavity's bordered elimination cancels that component, so no residual check here.
  auto direct = [&]() {
    linear_->solve(b, x);
    return true;
  };
  if (factor_version_ == k_version_ && factor_exact_) return direct();
  // Restarted GMRES(m), right-preconditioned by the lagged or symmetric-part factorization M ≈ K:
  // minimizes ‖b − K M⁻¹ y‖.
  //
  // Three-field iteration (saddle_krylov): the condensed tangent is K_c = A + Σ_e c_e d_e d_eᵀ with
  // c_e = V_e U″(θ) ~ V_e κ, κ/G ≈ 1.2e5 for the ecoflex tube, and d_e = ∂θ_e/∂u moves with the geometry:
  // a strain change δ moves K_c by ≈ κ δ ≫ G, so a factor of K_c at another iterate is a poor
  // preconditioner of K_c (GMRES rates 0.25–0.65 per iteration, BENCHMARKS session 4). The uncondensed
  // system in (u, t_e), t_e = c_e d_eᵀu − p_e,
  //     [ K_c u − Σ_e d_e t_e ]   [ b ]        (u-row: A u + Σ d_e p_e)
  //     [ w_e t_e             ] = [ 0 ]        (element row: the scaled constraint residual)
  // has the same u (t = 0, K_c u = b), but its blocks move only by O(δ) relative to themselves. Its lagged
  // version M_a (d_a, c_a of the factorized tangent) is inverted exactly with one solve of the lagged
  // condensed factor S_a = K_c,a:  x = S_a⁻¹(f + Σ d_a,e g_e / w_e),  t_e = c_a,e d_a,eᵀ x − g_e / w_e.
  // GMRES builds its Krylov space on the uncondensed system but minimizes the condensed residual
  // b − K_c x_u = P r, P r = r_u + Σ_e d_e r_e / w_e (row weights w_e = |d_e|), through the Gram matrix of
  // P V (see the least squares below). Measured on the 1e5-dof tube: with the previous step's factor,
  // iteration 0 of a step (a residual dominated by the predictor's volume mismatch) reaches 2e-5 in 10–18
  // GMRES iterations where the condensed iteration stalls at 1e-3 after 30; later iterations, whose
  // residuals load the Q1/P0 pressure modes (weakly controlled by the inf-sup condition, so M_a⁻¹ is
  // not bounded there), still need a factor of the same step — hence refactor_each_step.
  const bool saddle = options_.saddle_krylov && !sad_elem_.empty() && sad_a_valid_ && sad_b_version_ == k_version_;
  const int np = saddle ? int(sad_elem_.size()) : 0;
  const int N = n + np;
  std::vector<double> wgt;
  if (saddle) {
    wgt.resize(np);
    for (int k = 0; k < np; ++k) {
      double s = 0.0;
      for (int q = sad_off_[k]; q < sad_off_[k + 1]; ++q) s += sad_db_[q] * sad_db_[q];
      wgt[k] = s > 0.0 ? std::sqrt(s) : 1.0;
    }
  }
  auto dot_e = [&](const std::vector<double>& d, int k, const double* v) {
    double s = 0.0;
    for (int q = sad_off_[k]; q < sad_off_[k + 1]; ++q)
      if (sad_eq_[q] >= 0) s += d[q] * v[sad_eq_[q]];
    return s;
  };
  // out[k] = c[k] · d_kᵀ v − sub[k] (c, sub optional), in parallel over the elements.
  auto dots = [&](const std::vector<double>& d, const double* c, const double* v, const double* sub, double* out) {
#pragma omp parallel for schedule(static) if (np >= 4000)
    for (int k = 0; k < np; ++k) out[k] = (c ? c[k] : 1.0) * dot_e(d, k, v) - (sub ? sub[k] : 0.0);
  };
  // v += Σ_k a[k] d_k, colour by colour (elements of one colour share no dof).
  auto scatter = [&](const std::vector<double>& d, const double* a, double* v) {
#pragma omp parallel if (np >= 4000)
    for (const std::vector<int>& color : sad_colors_) {
#pragma omp for schedule(static)
      for (std::size_t i = 0; i < color.size(); ++i) {
        const int k = color[i];
        for (int q = sad_off_[k]; q < sad_off_[k + 1]; ++q)
          if (sad_eq_[q] >= 0) v[sad_eq_[q]] += a[k] * d[q];
      }
    }
  };
  std::vector<double> ek(np), tk(np);  // element work vectors
  // m = 30: a lagged factor may be given up to ~30 iterations (below), which GMRES(20) would restart.
  const int m = 30;
  // The Krylov basis is kept between solves (31 vectors of N: 27 MB at 1e5 dofs) and grown lazily.
  std::vector<std::vector<double>>& V = krylov_basis_;
  if (V.size() != std::size_t(m + 1)) V.assign(m + 1, {});
  std::vector<double> w(N), r(N), zu, fu;
  Eigen::MatrixXd Hm = Eigen::MatrixXd::Zero(m + 1, m), Gm = Eigen::MatrixXd::Zero(m + 1, m + 1);
  std::vector<std::vector<double>>& Z = krylov_preconditioned_;  // M⁻¹ V
  if (Z.size() != std::size_t(m)) Z.assign(m, {});
  std::vector<std::vector<double>>& Wc = krylov_condensed_;  // condensed residuals P V of the basis (saddle)
  if (saddle && Wc.size() != std::size_t(m + 1)) Wc.assign(m + 1, {});
  const auto t0 = std::chrono::steady_clock::now();
  double pre = 0.0;
  auto condensed_matvec = [&](const double* in, double* out) {
    // Row-parallel product only where it pays: on a loaded 2-core machine an OpenMP barrier can cost
    // a scheduler time slice.
    if (n >= 50000 && !K_.mirror.empty()) {
      K_.multiply(in, out);
      return;
    }
    for (int row = 0; row < n; ++row) {
      double sum = 0.0;
      for (int k = K_.colptr[row]; k < K_.colptr[row + 1]; ++k) sum += K_.values[K_.mirror[k]] * in[K_.rowind[k]];
      out[row] = sum;
    }
  };
  auto precond = [&](const std::vector<double>& in, std::vector<double>& out) {
    const auto tp = std::chrono::steady_clock::now();
    out.resize(N);
    if (!saddle) {
      linear_->solve(in, out);
      pre += seconds_since(tp);
      return;
    }
    fu.assign(in.begin(), in.begin() + n);
    for (int k = 0; k < np; ++k) ek[k] = in[n + k] / wgt[k];
    scatter(sad_da_, ek.data(), fu.data());
    linear_->solve(fu, zu);
    std::copy(zu.begin(), zu.end(), out.begin());
    dots(sad_da_, sad_ca_.data(), zu.data(), ek.data(), out.data() + n);
    pre += seconds_since(tp);
  };
  auto matvec = [&](const std::vector<double>& in, std::vector<double>& out) {
    condensed_matvec(in.data(), out.data());
    if (!saddle) return;
    dots(sad_db_, sad_cb_.data(), in.data(), in.data() + n, tk.data());  // t_e = c_e d_eᵀ u − t-unknown
    for (int k = 0; k < np; ++k) {
      out[n + k] = wgt[k] * tk[k];
      tk[k] = -tk[k];
    }
    scatter(sad_db_, tk.data(), out.data());
  };
  // Condensed residual b − K_c x_u of a saddle residual r: P r = r_u + Σ d_e r_e / w_e.
  auto condensed_of = [&](const std::vector<double>& res, std::vector<double>& c) {
    c.assign(res.begin(), res.begin() + n);
    for (int k = 0; k < np; ++k) ek[k] = res[n + k] / wgt[k];
    scatter(sad_db_, ek.data(), c.data());
  };
  std::vector<double> cres;
  auto condensed_residual = [&](const std::vector<double>& res) {
    if (!saddle) return norm(res);
    condensed_of(res, cres);
    return norm(cres);
  };
  auto dot = [](const std::vector<double>& a, const std::vector<double>& c) {
    double s = 0.0;
    for (std::size_t k = 0; k < a.size(); ++k) s += a[k] * c[k];
    return s;
  };
  std::vector<double> xs(N, 0.0);
  int total = 0;
  for (int attempt = 0; attempt < 2; ++attempt) {
    std::fill(xs.begin(), xs.end(), 0.0);
    std::fill(r.begin(), r.end(), 0.0);
    std::copy(b.begin(), b.end(), r.begin());
    double beta = bnorm;
    bool done = false;
    int its = 0;
    const auto t_attempt = std::chrono::steady_clock::now();
    // A lagged factor gets as many iterations as cost 90 % of a fresh factorization (measured; at 1e5
    // dofs a factorization is 3 s and an iteration 0.09 s, ~30 iterations), at least 15.
    const bool lagged = factor_version_ != k_version_;
    int max_its = options_.krylov_max;
    if (lagged) {
      const int affordable = iteration_time_ > 0.0 ? int(0.9 * last_factor_time_ / iteration_time_) : 15;
      max_its = std::clamp(affordable, 15, std::min(options_.krylov_max, m));
    }
    double checkpoint = 1.0;  // |r|/|b| at the last rate check
    double rc = bnorm;        // condensed residual of the current iterate
    while (!done && its < max_its) {
      V[0].resize(N);
      for (int i = 0; i < N; ++i) V[0][i] = r[i] / beta;
      if (saddle) {
        condensed_of(V[0], Wc[0]);
        Gm(0, 0) = dot(Wc[0], Wc[0]);
      }
      int j = 0;
      Eigen::VectorXd y;
      while (j < m && its < max_its) {
        precond(V[j], Z[j]);  // kept: the update x += Σ y_j M⁻¹v_j then needs no extra triangular solve
        matvec(Z[j], w);
        for (int i = 0; i <= j; ++i) {  // modified Gram–Schmidt
          double h = 0.0;
          for (int k = 0; k < N; ++k) h += w[k] * V[i][k];
          for (int k = 0; k < N; ++k) w[k] -= h * V[i][k];
          Hm(i, j) = h;
        }
        const double hn = norm(w);
        Hm(j + 1, j) = hn;
        V[j + 1].resize(N);
        if (hn > 0.0)
          for (int k = 0; k < N; ++k) V[j + 1][k] = w[k] / hn;
        else
          std::fill(V[j + 1].begin(), V[j + 1].end(), 0.0);
        ++j;
        ++its;
        // Least squares over the Krylov space: min_y ‖P (β e₁ − H̄ y)‖ with P V the condensed residuals of
        // the basis (saddle; Gram matrix G = (PV)ᵀ(PV) = RᵀR), or min_y ‖β e₁ − H̄ y‖ (plain GMRES, P = I).
        const Eigen::MatrixXd Hj = Hm.topLeftCorner(j + 1, j);
        Eigen::VectorXd e1 = Eigen::VectorXd::Zero(j + 1);
        e1[0] = beta;
        double res;
        if (saddle) {
          condensed_of(V[j], Wc[j]);
          for (int i = 0; i <= j; ++i) Gm(i, j) = Gm(j, i) = dot(Wc[i], Wc[j]);
          Eigen::MatrixXd G = Gm.topLeftCorner(j + 1, j + 1);
          // The condensed residuals of the basis can be nearly dependent: a tiny diagonal shift keeps the
          // Cholesky factor defined without changing the minimizer measurably.
          G.diagonal().array() += 1e-14 * G.diagonal().maxCoeff();
          const Eigen::MatrixXd R = G.llt().matrixU();
          const Eigen::MatrixXd A = R * Hj;
          const Eigen::VectorXd rhs = R * e1;
          y = A.colPivHouseholderQr().solve(rhs);
          res = (rhs - A * y).norm();
        } else {
          y = Hj.colPivHouseholderQr().solve(e1);
          res = (e1 - Hj * y).norm();
        }
        if (res <= tol * bnorm || hn == 0.0) break;
        // A lagged factor whose convergence rate would not reach the tolerance within the budget (the
        // early Newton iterations of a step, where the tangent still moves a lot): refactorize now
        // instead of after the whole budget of wasted triangular solves (1e5 dofs: 0.09 s each).
        // Checked every 5 iterations with the rate of the last 5 (GMRES with a lagged factor slows down).
        if (lagged && its % 5 == 0) {
          const double ratio = res / bnorm;
          const double rate = std::pow(ratio / checkpoint, 0.2);
          checkpoint = ratio;
          if (!(rate < 1.0) || its + std::log(tol / ratio) / std::log(rate) > max_its) max_its = its;
        }
      }
      // xs += M⁻¹ V y = Σ y_i Z_i.
      for (int i = 0; i < j; ++i)
        for (int k = 0; k < N; ++k) xs[k] += y[i] * Z[i][k];
      // True residual (restart vector; guards against loss of orthogonality).
      matvec(xs, w);
      for (int k = 0; k < N; ++k) r[k] = (k < n ? b[k] : 0.0) - w[k];
      beta = norm(r);
      rc = condensed_residual(r);
      done = rc <= 1.01 * tol * bnorm;  // else restart from the true residual
      if (!done && beta == 0.0) break;
    }
    std::copy(xs.begin(), xs.begin() + n, x.begin());
    total += its;
    stats_.krylov_iterations += its;
    if (its > 0) {  // running mean of the cost of one iteration (preconditioner solve + product + basis)
      const double t = seconds_since(t_attempt) / its;
      iteration_time_ = iteration_time_ > 0.0 ? 0.7 * iteration_time_ + 0.3 * t : t;
    }
    if (options_.verbose)
      std::cerr << "      gmres" << (saddle ? " (u,p)" : "") << " " << its << " its, |r|/|b| = " << rc / bnorm
                << (factor_version_ == k_version_ ? " (fresh factor)" : " (lagged factor)") << "\n";
    if (done) {
      stats_.krylov_time += seconds_since(t0) - pre;
      // Refresh a lagged factor once its iterations cost 3/4 of a factorization (measured), or in any case
      // after 3 × `refactor_after` iterations.
      if (its > 3 * options_.refactor_after || (its > 2 && its * iteration_time_ > 0.75 * last_factor_time_)) {
        factor_stale_ = true;
        if (options_.verbose)
          std::cerr << "      factor stale: " << its << " iterations of " << iteration_time_ << " s vs factorization "
                    << last_factor_time_ << " s\n";
      }
      return true;
    }
    // Lagged factor too far off: refactorize with the current tangent and retry once.
    if (attempt == 0) {
      if (options_.verbose) std::cerr << "      lagged factor failed: refactorize\n";
      if (!refactor(why)) break;
      if (factor_exact_) {
        stats_.krylov_time += seconds_since(t0) - pre;
        return direct();
      }
    }
  }
  stats_.krylov_time += seconds_since(t0) - pre;
  if (why.empty()) why = "linear solver: GMRES did not converge with a fresh factorization";
  return false;
}

void Simulation::saddle_current() {
  // d_e and c_e = V_e U″(θ) of the last tangent assembly (θ the iterate it used: mixed_update has not run
  // yet when the linear solver is called). Only needed when a factor may be lagged.
  if (sad_b_version_ == k_version_) return;
  const Mesh& mesh = model_.mesh;
  const int np = int(sad_elem_.size());
  sad_db_.resize(sad_eq_.size());
  sad_cb_.resize(np);
#pragma omp parallel for schedule(static) if (np >= 4000)
  for (int k = 0; k < np; ++k) {
    const int e = sad_elem_[k];
    const bool tet = mesh.is_tet(e);
    const double* de = tet ? mix_d_tet_[e - mesh.num_hexes()].data() : mix_d_[e].data();
    std::copy(de, de + (sad_off_[k + 1] - sad_off_[k]), sad_db_.begin() + sad_off_[k]);
    const double V = tet ? tet_geometry_[e - mesh.num_hexes()].volume : geometry_[e].volume;
    sad_cb_[k] = V * volumetric_d2U(mix_bulk_[e], mix_theta_[e]);
  }
  sad_b_version_ = k_version_;
}

void Simulation::mixed_update(const std::vector<double>& du, double alpha) {
  // Newton increments of the condensed element unknowns (see MixedVolume):
  // Δθ = d·Δu_e + θ_e(u) − θ,  Δp = U″(θ) Δθ + U′(θ) − p, taken with the line-search factor α.
  const Mesh& mesh = model_.mesh;
  const int ne = mesh.num_elements();
  if (!du.empty()) {
#pragma omp parallel for schedule(static) if (ne >= 4000)
    for (int e = 0; e < ne; ++e) {
      mix_theta_base_[e] = mix_theta_[e];
      mix_p_base_[e] = mix_p_[e];
      if (mix_bulk_[e] <= 0.0) continue;
      double s = 0.0;
      const int* en = mesh.element_nodes(e);
      const double* de = mesh.is_tet(e) ? mix_d_tet_[e - mesh.num_hexes()].data() : mix_d_[e].data();
      for (int a = 0; a < mesh.element_size(e); ++a)
        for (int i = 0; i < 3; ++i) s += de[3 * a + i] * du[3 * en[a] + i];
      const double th = mix_theta_[e], K = mix_bulk_[e];
      mix_dtheta_[e] = s + mix_theta_u_[e] - th;
      mix_dp_[e] = volumetric_d2U(K, th) * mix_dtheta_[e] + volumetric_dU(K, th) - mix_p_[e];
    }
  }
#pragma omp parallel for schedule(static) if (ne >= 4000)
  for (int e = 0; e < ne; ++e) {
    if (mix_bulk_[e] <= 0.0) continue;
    mix_theta_[e] = mix_theta_base_[e] + alpha * mix_dtheta_[e];
    mix_p_[e] = mix_p_base_[e] + alpha * mix_dp_[e];
  }
}

bool Simulation::try_step(double t_new, double dt, std::string& why) {
  const int ndof = model_.mesh.num_dofs();
  const int nf = dofs_.num_free;
  const bool mixed = !mix_bulk_.empty();
  std::vector<double> u = u_;
  double p = cavity_pressure_;
  const double v_target = model_.cavity ? model_.cavity->volume_ratio(t_new) * cavity_v0_ : 0.0;
  lu_this_step_ = false;
  if (mixed) {
    mix_theta_ = mix_theta_conv_;
    mix_p_ = mix_p_conv_;
    const int ne = model_.mesh.num_elements();
    mix_theta_base_.assign(ne, 1.0);
    mix_p_base_.assign(ne, 0.0);
    mix_dtheta_.assign(ne, 0.0);
    mix_dp_.assign(ne, 0.0);
  }

  Assembly as;
  // Predictor: linearize about the converged state with the new prescribed values,
  // K_ff Δu_f = −R_f − K_fc Δu_c, which keeps boundary layers from being crushed by a jump.
  std::vector<double> du_c(ndof, 0.0);
  bool any_jump = false;
  for (const auto& g : model_.dirichlet)
    for (std::size_t k = 0; k < g.dofs.size(); ++k) {
      const double target = (g.scale.empty() ? 1.0 : g.scale[k]) * g.value(t_new);
      du_c[g.dofs[k]] = target - u[g.dofs[k]];
      any_jump |= target != u[g.dofs[k]];
    }
  if (!any_jump) du_c.clear();

  // Secant predictor: start from u_n + ρ (u_n − u_{n−1}), ρ the ratio of this step's load increment to
  // the last one's (the load vector of pressures and nodal forces, so a ramp gives ρ = dt/dt_n and a hold
  // gives no extrapolation). Newton then starts O(Δ²) from the solution instead of O(Δ): the F-bar
  // residual after the first correction (dominated by the O(K ε²) volume mismatch of the step) drops,
  // and the tube steps need one Newton iteration fewer. Only without prescribed-displacement jumps (the
  // Dirichlet predictor covers those) and cavity control; advance_to retries a failed step without it.
  extrapolated_ = false;
  if (options_.extrapolate && extrapolate_step_ && !any_jump && !model_.cavity && time_ > prev_step_time_) {
    std::vector<double> l_new, l_now, l_old;
    auto loads = [&](double t, std::vector<double>& out) {
      out.clear();
      for (const auto& load : model_.pressures) out.push_back(load.pressure(t));
      for (const auto& load : model_.nodal_loads) out.push_back(load.value(t));
    };
    loads(t_new, l_new);
    loads(time_, l_now);
    loads(prev_step_time_, l_old);
    double num = 0.0, den = 0.0, nn = 0.0;
    for (std::size_t k = 0; k < l_new.size(); ++k) {
      num += (l_new[k] - l_now[k]) * (l_now[k] - l_old[k]);
      den += (l_now[k] - l_old[k]) * (l_now[k] - l_old[k]);
      nn += (l_new[k] - l_now[k]) * (l_new[k] - l_now[k]);
    }
    // Proportional load increments only (cosine > 0.999), and at most a doubling of the last one.
    if (den > 0.0 && num > 0.999 * std::sqrt(nn * den)) {
      extrapolated_ = true;
      const double rho = std::min(num / den, 2.0);
      // Quadratic extrapolation (Lagrange through the last three converged states, in the load parameter
      // s along the last increment, s = 0 at u_{n−1} and 1 at u_n): the predictor error drops from O(Δ²)
      // to O(Δ³). At K/G ~ 1e5 the predictor's volume mismatch θ_e(u) − θ (O(Δ²) for the secant) is what
      // the first Newton correction spends itself on, and the force error left after it sets the number
      // of further iterations.
      double a = 0.0;
      if (options_.extrapolate_order >= 2 && stored_steps_ >= 2 && prev2_step_time_ < prev_step_time_) {
        std::vector<double> l_old2;
        loads(prev2_step_time_, l_old2);
        double num2 = 0.0, nn2 = 0.0;
        for (std::size_t k = 0; k < l_new.size(); ++k) {
          num2 += (l_old[k] - l_old2[k]) * (l_now[k] - l_old[k]);
          nn2 += (l_old[k] - l_old2[k]) * (l_old[k] - l_old2[k]);
        }
        if (nn2 > 0.0 && num2 > 0.999 * std::sqrt(nn2 * den)) a = -num2 / den;  // s of u_{n−2}
        if (a < -4.0 || a > -0.25) a = 0.0;  // very uneven steps: secant
      }
      if (a < 0.0) {
        const double tau = 1.0 + rho;
        // Lagrange weights of u_{n−1} (s = 0) and u_{n−2} (s = a) at s = τ; u_n's is 1 minus both.
        const double c1 = (tau - a) * (tau - 1.0) / a, c2 = tau * (tau - 1.0) / (a * (a - 1.0));
        for (int d = 0; d < ndof; ++d)
          if (dofs_.eq[d] >= 0) u[d] += c1 * (u_prev_step_[d] - u_[d]) + c2 * (u_prev2_step_[d] - u_[d]);
      } else {
        for (int d = 0; d < ndof; ++d)
          if (dofs_.eq[d] >= 0) u[d] += rho * (u_[d] - u_prev_step_[d]);
      }
    }
  }

  auto fail = [&](const std::string& msg) {
    why = msg;
    return false;
  };
  std::vector<double> rhs(nf), x1(nf), x2(nf), afree(nf), du_full;
  std::vector<double> u_base = u, trial;
  double p_base = p, dp = 0.0, alpha = 1.0, s0 = 0.0;
  double r0 = -1.0, r_prev = 1e300, last_du = 1e300, u_max = 0.0;
  int backtracks = 0;
  const auto force_scale = [](const Assembly& a) { return std::max({a.fint_norm, a.fext_norm, 1e-300}); };
  const auto volume_residual = [&](const Assembly& a) {
    return model_.cavity ? std::abs(a.volume - v_target) / cavity_v0_ : 0.0;
  };
  // Newton's convergence test on the residual norm rc of assembly `a` at iteration `iter`: below
  // tolerance, or stagnating within 100× of it (round-off floor of a nearly incompressible tangent,
  // K/G ~ 1e5, where ‖R‖/scale cannot drop much below 1e-8), or the last correction was at round-off
  // level of the displacement (the residual then only measures the noise of K·(J − 1) in double
  // precision); and the cavity volume on target.
  const auto converged_at = [&](double rc, const Assembly& a, int iter) {
    const double scale = force_scale(a);
    const bool floor = iter > 1 && ((rc <= 100 * options_.tolerance * scale && rc >= 0.5 * r_prev) ||
                                    (rc <= 1e-4 * scale && last_du <= 1e-10 * u_max));
    return std::isfinite(rc) && (rc <= options_.tolerance * scale || floor) && volume_residual(a) <= 1e-9;
  };
  for (int it = 0;; ++it) {
    const bool predictor = it == 0 && !du_c.empty();
    if (predictor) as.dirichlet_rhs = du_c;
    else as.dirichlet_rhs.clear();
    // A step started at the converged state u_n linearizes there with the load stiffness of the converged
    // pressure p_n: K(u_n, p_n) is the tangent of an equilibrium and so positive definite on a stable path,
    // while the new pressure on the old stress field (K(u_n, p_{n+1})) is indefinite for a slender soft
    // tube (bending modes of stiffness ~ G (t/L)² against p: the capped ecoflex tube at p/G = 0.03), which
    // forced UMFPACK LU for the whole first step. From a secant start the new pressure belongs there.
    stiffness_time_ = (it == 0 && !extrapolated_) ? time_ : -1.0;
    // Late iterations (it ≥ 2, where most steps converge) first evaluate the residual alone: the element
    // tangent and its scatter are ~85 % of an assembly (hex8 kernel 12 µs with the tangent, 1.6 µs
    // without), and the converging iteration needs no tangent. When the residual does not pass, the
    // tangent assembly follows at the same point (the residual pass is then ~15 % extra).
    bool converged_early = false;
    if (options_.residual_first && it >= 2 && !predictor) {
      if (assemble(t_new, dt, false, u, p, as) == MaterialStatus::ok) {
        double r2 = 0.0;
        for (int d = 0; d < ndof; ++d)
          if (dofs_.eq[d] >= 0) {
            const double v = mixed ? as.R_true[d] : as.R[d];
            r2 += v * v;
          }
        converged_early = converged_at(std::sqrt(r2), as, it);
      }
    }
    MaterialStatus st = converged_early ? MaterialStatus::ok : assemble(t_new, dt, true, u, p, as);
    stiffness_time_ = -1.0;
    // Line search on the full assembly of the trial point (most steps accept α = 1, so no extra
    // residual evaluation): backtrack when the trial is inadmissible (material failure) or, without a
    // cavity constraint, when s(α) = Δu·R(u + αΔu) is not reduced enough (energy criterion).
    while (it > 0 && options_.line_search) {
      bool ok = st == MaterialStatus::ok;
      double s = 0.0;
      // Three-field iteration: backtrack only on inadmissible trials. Its steps are full Newton steps
      // of the saddle-point system; an energy or residual criterion on u alone cuts good steps (one
      // to two extra iterations per load step on the capped tube).
      if (ok && !model_.cavity && s0 < 0.0 && !mixed) {
        // Three-field: the u-row residual, free of the O(K ε²) volume-mismatch term that the condensed
        // residual carries after a large step (that term is the constraint's, which Newton fixes).
        const std::vector<double>& Rl = mixed ? as.R_u : as.R;
        for (int d = 0; d < ndof; ++d)
          if (dofs_.eq[d] >= 0) s += x1[dofs_.eq[d]] * Rl[d];
        ok = std::abs(s) <= 0.9 * std::abs(s0);
      }
      if (ok || backtracks >= 6 || alpha < 0.05) break;
      ++backtracks;
      ++stats_.line_search_backtracks;
      double next = 0.5 * alpha;
      if (st == MaterialStatus::ok && s > 0.0) next = std::clamp(alpha * s0 / (s0 - s), 0.1 * alpha, 0.5 * alpha);
      alpha = next;
      for (int d = 0; d < ndof; ++d) {
        const int k = dofs_.eq[d];
        if (k >= 0) u[d] = u_base[d] + alpha * x1[k];
      }
      p = p_base + alpha * dp;
      if (mixed) mixed_update({}, alpha);
      st = assemble(t_new, dt, true, u, p, as);
    }
    if (st != MaterialStatus::ok)
      return fail(std::string("material call failed (") + to_string(st) + ") in element " +
                  std::to_string(as.failed_element));
    double rn = 0.0, rn_true = 0.0;
    for (int d = 0; d < ndof; ++d)
      if (dofs_.eq[d] >= 0) {
        const double v = as.R[d] + (predictor ? as.dirichlet_rhs[d] : 0.0);
        rhs[dofs_.eq[d]] = -v;
        rn += v * v;
        if (mixed) rn_true += as.R_true[d] * as.R_true[d];
      }
    rn = std::sqrt(rn);
    // Convergence is judged on the F-bar residual itself, so the converged state is the F-bar
    // solution whatever the iteration (the condensed residual differs by O(K (θ_e − θ)²)).
    const double rc = mixed ? std::sqrt(rn_true) : rn;
    const double scale = force_scale(as);
    const double vres = volume_residual(as);
    if (!std::isfinite(rn) || !std::isfinite(rc)) return fail("non-finite residual");
    if (options_.verbose)
      std::cerr << "    it " << it << " |R| = " << rc << (mixed ? " (condensed " + std::to_string(rn) + ")" : "")
                << " scale " << scale << (model_.cavity ? " |dV|/V0 = " + std::to_string(vres) : "")
                << (alpha < 1 ? " alpha " + std::to_string(alpha) : "") << "\n";
    const bool converged = !predictor && it > 0 && converged_at(rc, as, it);
    const double rc_last = r_prev;
    r_prev = rc;
    if (converged) {
      if (options_.extrapolate_order >= 2) {
        u_prev2_step_.swap(u_prev_step_);
        prev2_step_time_ = prev_step_time_;
      }
      u_prev_step_.swap(u_);
      prev_step_time_ = time_;
      stored_steps_ = std::min(stored_steps_ + 1, 2);
      u_ = std::move(u);
      cavity_pressure_ = p;
      std::swap(state_old_, state_new_);
      cauchy_.swap(as.cauchy);
      fint_.swap(as.fint);
      if (mixed) {
        // Restart the next step from the consistent pair θ = θ_e(u), p = U′(θ).
        for (std::size_t e = 0; e < mix_bulk_.size(); ++e)
          if (mix_bulk_[e] > 0.0) {
            mix_theta_conv_[e] = mix_theta_u_[e];
            mix_p_conv_[e] = volumetric_dU(mix_bulk_[e], mix_theta_u_[e]);
          }
      }
      stats_.newton_iterations += it;
      return true;
    }
    // Divergence: the residual grows far above its value after the first correction.
    if (it == 1) r0 = rc;
    if (it >= 2 && rc > 1e4 * std::max(r0, options_.tolerance * scale)) return fail("Newton diverged");
    if (it >= options_.max_iterations) {
      std::ostringstream msg;
      msg << "no convergence in " << options_.max_iterations << " iterations (|R|/scale = " << rc / scale << ")";
      return fail(msg.str());
    }
    // Inexact Newton: the linear tolerance follows the residual (superlinear convergence), but is never
    // tighter than the next iterate needs: r_{k+1} ≈ η r_k + O(r_k²), so η = 0.1 tol·scale / r_k already
    // puts the next residual a decade below the tolerance (Kelley's safeguard). Without it the last
    // iteration of a step asked 1e-10 of a lagged-factor GMRES and paid a refactorization for it.
    const double eta_fast = std::clamp(1e-2 * rc / scale, 1e-10, 1e-4);
    // (Not under cavity control: its pressure increment comes from the same solves, and the volume
    // tolerance 1e-9 needs them accurate.)
    const double eta = model_.cavity ? eta_fast
                                     : std::max(eta_fast, std::min(0.1, options_.forcing_safeguard * options_.tolerance * scale / std::max(rn, rc)));
    std::string lwhy;
    // A lagged factor that failed at the first iteration of the last step (the tangent moved too far
    // over a load step) is not tried again there: its wasted GMRES iterations (5 to 30 at 1e5 dofs)
    // cost up to a factorization. Every fourth step it is tried again, in case the steps got smaller.
    if (it == 0 && refactor_first_ && (stats_.steps % 4) != 0 && factor_valid_ && factor_version_ != k_version_)
      factor_stale_ = true;
    // From a (quadratic) extrapolated start the tangent of iteration 0 is within the predictor error of the
    // step's solution: its fresh factor solves iteration 0 directly and preconditions the remaining two or
    // three corrections in a few GMRES iterations each, while the previous step's factor needs 10–30
    // there and fails at iteration 1 (κ/G ~ 1e5: the tangent moves by κ × the strain of a load step).
    if (it == 0 && extrapolated_ && options_.refactor_each_step && factor_valid_ && factor_version_ != k_version_)
      factor_stale_ = true;
    // Nor while Newton is far from its quadratic phase (the residual did not halve: the tangent still
    // moves a lot, e.g. the first load step of the tube, whose lagged GMRES ran 15 iterations per solve
    // before refactorizing anyway).
    if (it > 0 && rc > 0.5 * rc_last && factor_valid_ && factor_version_ != k_version_) factor_stale_ = true;
    const int factorizations_before = linear_->times().factorizations;
    const bool lagged_before = factor_valid_ && !factor_stale_ && factor_version_ != k_version_;
    if (!linear_solve(rhs, x1, eta, lwhy)) return fail(lwhy);
    if (it == 0 && last_factor_flops_ >= options_.lag_flops) {
      if (lagged_before && linear_->times().factorizations > factorizations_before) refactor_first_ = true;
      else if (lagged_before) refactor_first_ = false;
    }
    dp = 0.0;
    if (model_.cavity) {
      for (int d = 0; d < ndof; ++d)
        if (dofs_.eq[d] >= 0) afree[dofs_.eq[d]] = as.a[d];
      if (!linear_solve(afree, x2, eta, lwhy)) return fail(lwhy);
      // Bordered system: K Δu + a Δp = −R, g·Δu = V̄ − V (− g_c·Δu_c of a prescribed jump), with g = ∂V/∂u
      // the exact gradient of the volume formula. On faces that close the cavity (up to fixed symmetry
      // planes) g = −a and the system is symmetric; an open end that moves (an uncapped tube's free end,
      // closed by the moving plane z = z_end through the mask) makes g ≠ −a, and using −a there left
      // Newton linear (tests/macro/test_cavity_newton.cpp: 54 iterations for 5 steps of the uncapped
      // tube, 30 with g).
      double g1 = 0.0, g2 = 0.0, jump = 0.0;
      for (int d = 0; d < ndof; ++d) {
        const int k = dofs_.eq[d];
        if (k >= 0) {
          g1 += as.g[d] * x1[k];
          g2 += as.g[d] * x2[k];
        } else if (predictor) {
          jump += as.g[d] * du_c[d];
        }
      }
      if (g2 == 0.0) return fail("cavity constraint is singular");
      dp = (g1 - (v_target - as.volume - jump)) / g2;
      for (int k = 0; k < nf; ++k) x1[k] -= dp * x2[k];
    }
    last_du = 0.0;
    for (int k = 0; k < nf; ++k) last_du = std::max(last_du, std::abs(x1[k]));
    s0 = 0.0;
    if (mixed) {
      for (int d = 0; d < ndof; ++d)
        if (dofs_.eq[d] >= 0) s0 += x1[dofs_.eq[d]] * as.R_u[d];
    } else {
      for (int k = 0; k < nf; ++k) s0 -= x1[k] * rhs[k];  // Δu · R(u)
    }
    u_base = u;
    p_base = p;
    alpha = 1.0;
    backtracks = 0;
    if (mixed) du_full.assign(ndof, 0.0);
    for (int d = 0; d < ndof; ++d) {
      const int k = dofs_.eq[d];
      if (k >= 0) {
        u[d] += x1[k];
        if (mixed) du_full[d] = x1[k];
      } else if (predictor) {
        u[d] += du_c[d];
        if (mixed) du_full[d] = du_c[d];
      }
    }
    if (mixed) mixed_update(du_full, 1.0);
    u_max = 0.0;
    for (double v : u) u_max = std::max(u_max, std::abs(v));
    if (predictor) {
      // The prescribed jump is never backtracked: α scales only the free part of the predictor.
      u_base = u;
      for (int d = 0; d < ndof; ++d)
        if (dofs_.eq[d] >= 0) u_base[d] -= x1[dofs_.eq[d]];
      s0 = 0.0;
    }
    p += dp;
  }
}

void Simulation::advance_to(double t_end) {
  const double interval = t_end - time_;
  if (!(interval > 0.0)) return;
  const double dt_max = interval / std::max(1, options_.initial_substeps);
  // Start at the nominal step unless the last interval needed cut-backs (then resume where it was).
  double dt = (last_dt_ > 0.0 && recent_cutback_) ? std::min(2.0 * last_dt_, dt_max) : dt_max;
  recent_cutback_ = false;
  int halvings = 0, successes = 0;
  while (time_ < t_end - 1e-12 * interval) {
    dt = std::min(dt, t_end - time_);
    if (t_end - time_ - dt < 1e-9 * interval) dt = t_end - time_;
    std::string why;
    extrapolate_step_ = true;
    bool ok = try_step(time_ + dt, dt, why);
    if (!ok && extrapolated_) {
      // The secant start may overshoot where the response stiffens or softens abruptly: retry the same
      // step from the converged state before cutting it back.
      stats_.log.push_back("t = " + std::to_string(time_) + " + " + std::to_string(dt) + ": " + why +
                           " from the secant predictor; retried from the converged state");
      if (options_.verbose) std::cerr << stats_.log.back() << "\n";
      extrapolate_step_ = false;
      why.clear();
      ok = try_step(time_ + dt, dt, why);
    }
    if (ok) {
      time_ += dt;
      last_dt_ = dt;
      ++stats_.steps;
      halvings = 0;
      if (++successes >= 2) dt = std::min(1.5 * dt, dt_max);
      continue;
    }
    // try_step leaves u_, history and pressure at the last converged state.
    successes = 0;
    recent_cutback_ = true;
    ++stats_.cutbacks;
    std::ostringstream s;
    s << "cut-back at t = " << time_ << " + " << dt << ": " << why;
    stats_.log.push_back(s.str());
    if (options_.verbose) std::cerr << s.str() << "\n";
    if (++halvings > options_.max_cutbacks)
      throw ConvergenceError("step failed after " + std::to_string(options_.max_cutbacks) + " cut-backs at t = " +
                             std::to_string(time_) + ": " + why);
    dt *= 0.5;
  }
  time_ = t_end;
}

double Simulation::reaction(const std::vector<int>& dofs) const {
  // Internal force at the converged state (no pressure contribution on these dofs is assumed), taken
  // from the assembly that passed the convergence test. Re-evaluating the elements here would run the
  // material from the converged history over another time step: for a viscoelastic (QLV) law that is
  // one relaxation interval too many (the QLV plate's reaction then lagged the material point).
  double sum = 0.0;
  if (!fint_.empty()) {
    for (int d : dofs) sum += fint_[d];
    return sum;
  }
  // Before the first step: the undeformed state (no history has been advanced yet, state_old_ is the
  // initial one and the elements' stress is that of u = 0).
  Vec24 r;
  std::vector<char> want(model_.mesh.num_dofs(), 0);
  for (int d : dofs) want[d] = 1;
  for (int e = 0; e < model_.mesh.num_elements(); ++e) {
    const int* en = model_.mesh.element_nodes(e);
    const int nen = model_.mesh.element_size(e);
    bool touches = false;
    for (int a = 0; a < nen && !touches; ++a)
      for (int i = 0; i < 3; ++i) touches |= want[3 * en[a] + i] != 0;
    if (!touches) continue;
    if (model_.mesh.is_tet(e)) {
      Vec30 r10;
      const Tet10& tet = model_.mesh.tets[e - model_.mesh.num_hexes()];
      if (element_force(e, gather(u_, tet), r10, nullptr) != MaterialStatus::ok) continue;
      for (int a = 0; a < 10; ++a)
        for (int i = 0; i < 3; ++i)
          if (want[3 * tet[a] + i]) sum += r10[3 * a + i];
      continue;
    }
    const Hex& hex = model_.mesh.hexes[e];
    if (element_force(e, gather(u_, hex), r, nullptr) != MaterialStatus::ok) continue;
    for (int a = 0; a < 8; ++a)
      for (int i = 0; i < 3; ++i)
        if (want[3 * hex[a] + i]) sum += r[3 * a + i];
  }
  return sum;
}

ElementFields Simulation::element_fields() const {
  const Mesh& mesh = model_.mesh;
  const int ne = mesh.num_elements();
  ElementFields f;
  f.cauchy.assign(9 * std::size_t(ne), 0.0);
  f.von_mises.assign(ne, 0.0);
  f.J.assign(ne, 1.0);
  f.fiber.assign(3 * std::size_t(ne), 0.0);
#pragma omp parallel for schedule(static) if (ne >= 4000)
  for (int e = 0; e < ne; ++e) {
    Mat3 Fmean = Mat3::Zero();
    if (mesh.is_tet(e)) {
      const int t = e - mesh.num_hexes();
      const Tet10Kinematics k = tet10_kinematics(tet_geometry_[t], gather(u_, mesh.tets[t]), model_.formulation);
      if (!k.ok) continue;
      f.J[e] = k.theta;
      for (int q = 0; q < 4; ++q) Fmean += (tet_geometry_[t].w[q] / tet_geometry_[t].volume) * k.F[q];
    } else {
      const Hex8Kinematics k = hex8_kinematics(geometry_[e], gather(u_, mesh.hexes[e]), model_.formulation);
      if (!k.ok) continue;
      f.J[e] = k.theta;
      for (int q = 0; q < 8; ++q) Fmean += (geometry_[e].w[q] / geometry_[e].volume) * k.F[q];
    }
    const Material& m = *model_.element_material[e];
    Mat3 sigma = Mat3::Zero();
    if (!cauchy_.empty())
      for (int c = 0; c < 9; ++c) sigma(c / 3, c % 3) = cauchy_[9 * std::size_t(e) + c];
    for (int c = 0; c < 9; ++c) f.cauchy[9 * std::size_t(e) + c] = sigma(c / 3, c % 3);
    const Mat3 dev = sigma - sigma.trace() / 3.0 * Mat3::Identity();
    f.von_mises[e] = std::sqrt(1.5 * (dev.array() * dev.array()).sum());
    const auto dirs = m.fiber_directions();
    if (!dirs.empty()) {
      const Vec3 a = (Fmean * dirs[0]).normalized();
      for (int i = 0; i < 3; ++i) f.fiber[3 * std::size_t(e) + i] = a[i];
    }
  }
  return f;
}

}  // namespace softhom::fe
