// Assembly of fe::Simulation: the coloured element loop (residual, tangent, Dirichlet predictor
// right-hand side) and the loads (follower pressures, nodal forces, cavity).
#include "simulation_impl.hpp"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <ctime>
#include <cmath>
#include <iostream>
#include <sstream>
#include <tuple>
#include <type_traits>

#include <Eigen/Dense>

#include "softhom/materials/errors.hpp"

namespace softhom::fe {
using namespace detail;

MaterialStatus Simulation::Impl::assemble(double t, double dt, bool tangent, const std::vector<double>& u, double cavity_p,
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
  if (distributed_) out.cauchy.assign(9 * std::size_t(mesh.num_elements()), 0.0);  // summed at commit
  else out.cauchy.resize(9 * std::size_t(mesh.num_elements()));
  if (tangent) {
    if (petsc_) petsc_->set_displacement(u);
    if (distributed_) petsc_->begin_fill();
    else K_.set_zero();
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
  const auto t_loop = std::chrono::steady_clock::now();
  const double cpu_loop = process_cpu_seconds();
  assemble_elements(dt, tangent, u, du_c, out);
  stats_.element_loop_time += seconds_since(t_loop);
  stats_.element_loop_cpu += process_cpu_seconds() - cpu_loop;
  reduce_element_sums(out);
  if (out.status != MaterialStatus::ok) {
    if (tangent && distributed_) petsc_->end_fill();  // collective; the tangent is not used
    stats_.assembly_time += seconds_since(t0);
    return out.status;
  }
  out.fint_norm = norm(out.R);
  out.fint = mixed ? out.R_true : out.R;  // before the loads: the internal forces alone

  assemble_loads(t, tangent, u, cavity_p, du_c, out);
  if (tangent && distributed_) petsc_->end_fill();
  stats_.assembly_time += seconds_since(t0);
  return MaterialStatus::ok;
}

void Simulation::Impl::assemble_elements(double dt, bool tangent, const std::vector<double>& u,
                                         const std::vector<double>& du_c, Assembly& out) {
  // Element residuals (and tangents) scattered colour by colour; the first failed material call
  // (the first to claim it among the threads) is reported in out.failed_element / out.status.
  const Mesh& mesh = model_.mesh;
  const bool mixed = !mix_bulk_.empty();
  const bool predictor = !du_c.empty();
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
  // Distributed assembly on several ranks: one thread (one rank per core). On one process the threads
  // share the colours; the elements of one colour share no node, hence no matrix entry, so the sums do
  // not depend on the order. The first fill of the PETSc matrix goes through MatSetValues (not
  // thread-safe), one element at a time; the later ones write straight into its values, concurrently.
  const int threads = mesh.num_elements() >= 4000 && !(distributed_ && mpi_ranks_ > 1) ? omp_get_max_threads() : 1;
  const bool concurrent_fill = tangent && distributed_ && petsc_->concurrent_fill();
#pragma omp parallel num_threads(threads)
  {
    Vec24 r;
    Mat24 Ke;
    Mat3 sigma;
    Vec30 r10;
    Mat30 K10;
    // The steps after the element kernel, the same for hex8 and tet10 (NN nodes): Cauchy stress, the
    // residuals (R, and in the mixed iteration R_true / R_u with the element's volume shifts), the
    // tangent scattered column by column into K (block: the element's node-pair offsets) and, for a
    // prescribed column, its increment into the predictor's right-hand side (K_fc Δu_c).
    auto scatter = [&](int e, const auto& nodes, const auto& re, const auto& Kel, const auto* mv, const long* block,
                       double volume) {
      constexpr int NN = int(std::tuple_size_v<std::decay_t<decltype(nodes)>>);
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
      for (int b = 0; b < NN; ++b)
        for (int j = 0; j < 3; ++j) {
          const int cl = 3 * b + j;
          const int col = eq[gdof[cl]];
          if (col < 0) {
            if (predictor && du_c[gdof[cl]] != 0.0)
              for (int rw = 0; rw < ND; ++rw) drhs[gdof[rw]] += Kel(rw, cl) * du_c[gdof[cl]];
            continue;
          }
          if (distributed_) continue;
          double* column = kv + K_.colptr[col];
          for (int a = 0; a < NN; ++a) {
            const long o = block[NN * a + b];
            if (o < 0) continue;
            const auto& fr = free_rank_[nodes[a]];
            for (int i = 0; i < 3; ++i)
              if (fr[i] >= 0) column[o + fr[i]] += Kel(3 * a + i, cl);
          }
        }
      if (distributed_) {
        // Three-field elements enter uncondensed, c = V_e U″(θ) as in saddle_current.
        const double c = mv ? volume * volumetric_d2U(mix_bulk_[e], mix_theta_[e]) : 0.0;
        if (concurrent_fill) {
          petsc_->add_element(e, NN, nodes.data(), Kel.data(), mv ? mv->d.data() : nullptr, c, volume);
        } else {
#pragma omp critical(softhom_petsc_fill)
          petsc_->add_element(e, NN, nodes.data(), Kel.data(), mv ? mv->d.data() : nullptr, c, volume);
        }
      }
    };
    auto claim_failure = [&](int e, MaterialStatus st) {
      int expected = -1;
      if (failed.compare_exchange_strong(expected, e)) failed_status = int(st);
    };
    // One element of either kind: its kernel (hex8_internal_force or tet10_internal_force) from the
    // committed state, then what it leaves for the iteration (θ_e(u) and ∂θ_e/∂u of a three-field
    // element) and the scatter. `mv` is the element's fresh mixed-volume record.
    auto element = [&](int e, const auto& geometry, const auto& nodes, auto kernel, auto& re, auto& Kel, auto& mv,
                       auto& d_of_element, const long* block) {
      const int off = state_offset_[e];
      const bool me = mixed && mix_bulk_[e] > 0.0;
      if (me) {
        mv.bulk = mix_bulk_[e];
        mv.theta = mix_theta_[e];
        mv.p = mix_p_[e];
      }
      const MaterialStatus st = kernel(geometry, gather(u, nodes), *model_.element_material[e],
                                       off >= 0 ? state_old_.data() + off : nullptr,
                                       off >= 0 ? state_new_.data() + off : nullptr, dt, model_.formulation, re,
                                       tangent ? &Kel : nullptr, &sigma, me ? &mv : nullptr);
      if (st != MaterialStatus::ok) {
        claim_failure(e, st);
        return;
      }
      if (me) {
        mix_theta_u_[e] = mv.theta_u;
        d_of_element = mv.d;
      }
      scatter(e, nodes, re, Kel, me ? &mv : nullptr, block, geometry.volume);
    };
    const auto hex_kernel = [](auto&&... a) { return hex8_internal_force(a...); };
    const auto tet_kernel = [](auto&&... a) { return tet10_internal_force(a...); };
    for (const std::vector<int>& color : colors_) {
      // Elements of one colour share no node: plain (non-atomic) updates are race-free.
#pragma omp for schedule(dynamic, 32)
      for (std::size_t k = 0; k < color.size(); ++k) {
        const int e = color[k];
        if (failed.load(std::memory_order_relaxed) >= 0) continue;
        if (mesh.is_tet(e)) {
          const int t = e - mesh.num_hexes();
          Tet10MixedVolume mv;
          element(e, tet_geometry_[geometry_slot_[e]], mesh.tets[t], tet_kernel, r10, K10, mv, mix_d_tet_[geometry_slot_[e]],
                  tet_block_[t].data());
        } else {
          MixedVolume mv;
          element(e, geometry_[geometry_slot_[e]], mesh.hexes[e], hex_kernel, r, Ke, mv, mix_d_[geometry_slot_[e]], block_[e].data());
        }
      }
    }
  }
  out.failed_element = failed.load();
  out.status = out.failed_element >= 0 ? MaterialStatus(failed_status.load()) : MaterialStatus::ok;
}

void Simulation::Impl::assemble_loads(double t, bool tangent, const std::vector<double>& u, double cavity_p,
                                      const std::vector<double>& du_c, Assembly& out) {
  const Mesh& mesh = model_.mesh;
  const int ndof = mesh.num_dofs();
  const bool mixed = !mix_bulk_.empty();
  const bool predictor = !du_c.empty();
  const std::vector<int>& eq = dofs_.eq;
  double* kv = K_.values.data();
  double* R = out.R.data();
  double* Rt = mixed ? out.R_true.data() : nullptr;
  double* Ru = mixed ? out.R_u.data() : nullptr;
  double* drhs = predictor ? out.dirichlet_rhs.data() : nullptr;
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
              if (col >= 0 && distributed_)
                petsc_->add_entry(3 * q[k] + i, cdof, pk * da(3 * k + i, 3 * m + j));
              else if (col >= 0)
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
}

}  // namespace softhom::fe
