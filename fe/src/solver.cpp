#include "softhom/fe/solver.hpp"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <iostream>
#include <sstream>

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

}  // namespace

struct Simulation::Assembly {
  std::vector<double> R;       ///< f_int − f_ext on all dofs
  std::vector<double> a;       ///< cavity unit-pressure vector on all dofs (∂R/∂p)
  std::vector<double> dirichlet_rhs;  ///< K_fc Δu_c on all dofs (predictor only)
  std::vector<double> cauchy;  ///< 9 per element
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

  geometry_.resize(mesh.num_elements());
  int bad = -1;
  for (int e = 0; e < mesh.num_elements(); ++e) {
    Mat83 X;
    for (int a = 0; a < 8; ++a) X.row(a) = mesh.nodes[mesh.hexes[e][a]].transpose();
    geometry_[e] = hex8_geometry(X);
    if (!geometry_[e].valid && bad < 0) bad = e;
  }
  if (bad >= 0) throw InputError("mesh", "element " + std::to_string(bad), "non-positive Jacobian at a Gauss point");

  state_offset_.assign(mesh.num_elements(), -1);
  std::size_t total = 0;
  for (int e = 0; e < mesh.num_elements(); ++e) {
    const int ns = model_.element_material[e]->state_size();
    if (ns > 0) {
      state_offset_[e] = int(total);
      total += 8 * std::size_t(ns);
    }
  }
  state_old_.assign(total, 0.0);
  for (int e = 0; e < mesh.num_elements(); ++e)
    if (state_offset_[e] >= 0) {
      const auto& m = *model_.element_material[e];
      for (int q = 0; q < 8; ++q) m.init_state(state_old_.data() + state_offset_[e] + q * m.state_size());
    }
  state_new_ = state_old_;

  SolverKind kind = options_.solver;
  // A follower pressure makes the tangent unsymmetric; the bordered cavity system is indefinite
  // past a pressure maximum. Both need LU.
  if (kind == SolverKind::automatic)
    kind = (model_.pressures.empty() && !model_.cavity) ? SolverKind::cholmod : SolverKind::umfpack;
  linear_ = make_linear_solver(kind);

  u_.assign(ndof, 0.0);
  u_prev_step_ = u_;
  if (model_.cavity) cavity_v0_ = cavity_volume(mesh.nodes, model_.cavity->faces, model_.cavity->mask);
  if (model_.cavity && !(cavity_v0_ > 0.0))
    throw InputError("cavity", std::to_string(cavity_v0_), "enclosed volume must be positive (check face orientation)");
}

Simulation::~Simulation() = default;

SolverKind Simulation::solver_kind() const { return linear_->kind(); }

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
  out.R.assign(ndof, 0.0);
  out.cauchy.resize(9 * std::size_t(mesh.num_elements()));
  if (tangent) K_.set_zero();
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
  double* drhs = predictor ? out.dirichlet_rhs.data() : nullptr;

#pragma omp parallel
  {
    Vec24 r;
    Mat24 Ke;
    Mat3 sigma;
    std::array<int, 24> gdof;
#pragma omp for schedule(dynamic, 64)
    for (int e = 0; e < mesh.num_elements(); ++e) {
      if (failed.load(std::memory_order_relaxed) >= 0) continue;
      const Hex& hex = mesh.hexes[e];
      const Mat83 ue = gather(u, hex);
      const int off = state_offset_[e];
      const MaterialStatus st = hex8_internal_force(
          geometry_[e], ue, *model_.element_material[e], off >= 0 ? state_old_.data() + off : nullptr,
          off >= 0 ? state_new_.data() + off : nullptr, dt, model_.formulation, r, tangent ? &Ke : nullptr,
          tangent ? &sigma : nullptr);
      if (st != MaterialStatus::ok) {
        int expected = -1;
        if (failed.compare_exchange_strong(expected, e)) failed_status = int(st);
        continue;
      }
      if (tangent)
        for (int k = 0; k < 9; ++k) out.cauchy[9 * std::size_t(e) + k] = sigma(k / 3, k % 3);
      for (int a = 0; a < 8; ++a)
        for (int i = 0; i < 3; ++i) gdof[3 * a + i] = 3 * hex[a] + i;
      for (int k = 0; k < 24; ++k) {
#pragma omp atomic
        R[gdof[k]] += r[k];
      }
      if (!tangent) continue;
      for (int cl = 0; cl < 24; ++cl) {
        const int col = eq[gdof[cl]];
        if (col < 0) {
          // Prescribed column: its increment enters the predictor's right-hand side (K_fc Δu_c).
          if (predictor && du_c[gdof[cl]] != 0.0)
            for (int rw = 0; rw < 24; ++rw) {
#pragma omp atomic
              drhs[gdof[rw]] += Ke(rw, cl) * du_c[gdof[cl]];
            }
          continue;
        }
        for (int rw = 0; rw < 24; ++rw) {
          const int row = eq[gdof[rw]];
          if (row < 0) continue;
          const long pos = K_.find(row, col);
#pragma omp atomic
          kv[pos] += Ke(rw, cl);
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

  // Follower pressures: R += p a(x), K += p ∂a/∂x (unsymmetric load stiffness).
  std::vector<double> fext(ndof, 0.0);
  auto add_faces = [&](const std::vector<Quad>& faces, double p, bool collect) {
    Vec12 a;
    Mat12 da;
    const Vec3 mask = model_.cavity ? model_.cavity->mask : Vec3::Ones();
    for (const Quad& q : faces) {
      Mat43 xe;
      for (int k = 0; k < 4; ++k)
        xe.row(k) = (mesh.nodes[q[k]] + Vec3(u[3 * q[k]], u[3 * q[k] + 1], u[3 * q[k] + 2])).transpose();
      double flux = 0.0;
      quad4_pressure(xe, mask, a, tangent ? &da : nullptr, flux);
      if (collect) out.volume -= flux / mask.sum();
      for (int k = 0; k < 4; ++k)
        for (int i = 0; i < 3; ++i) {
          const int dof = 3 * q[k] + i;
          R[dof] += p * a[3 * k + i];
          fext[dof] -= p * a[3 * k + i];
          if (collect) out.a[dof] += a[3 * k + i];
        }
      if (!tangent || p == 0.0) continue;
      for (int m = 0; m < 4; ++m)
        for (int j = 0; j < 3; ++j) {
          const int col = eq[3 * q[m] + j];
          const int cdof = 3 * q[m] + j;
          for (int k = 0; k < 4; ++k)
            for (int i = 0; i < 3; ++i) {
              const int row = eq[3 * q[k] + i];
              if (row < 0) continue;
              if (col >= 0)
                kv[K_.find(row, col)] += p * da(3 * k + i, 3 * m + j);
              else if (predictor && du_c[cdof] != 0.0)
                drhs[3 * q[k] + i] += p * da(3 * k + i, 3 * m + j) * du_c[cdof];
            }
        }
    }
  };
  for (const auto& load : model_.pressures) add_faces(load.faces, load.pressure(t), false);
  out.volume = 0.0;
  if (model_.cavity) {
    out.a.assign(ndof, 0.0);
    add_faces(model_.cavity->faces, cavity_p, true);
  }
  out.fext_norm = norm(fext);
  stats_.assembly_time += seconds_since(t0);
  return MaterialStatus::ok;
}

bool Simulation::try_step(double t_new, double dt, std::string& why) {
  const int ndof = model_.mesh.num_dofs();
  const int nf = dofs_.num_free;
  std::vector<double> u = u_;
  double p = cavity_pressure_;
  const double v_target = model_.cavity ? model_.cavity->volume_ratio(t_new) * cavity_v0_ : 0.0;

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

  auto fail = [&](const std::string& msg) {
    why = msg;
    return false;
  };
  std::vector<double> rhs(nf), x1(nf), x2(nf), afree(nf);
  std::vector<double> u_base = u, trial;
  double p_base = p, dp = 0.0, alpha = 1.0, s0 = 0.0;
  bool analyzed = linear_->times().analysis > 0;
  double r0 = -1.0, r_prev = 1e300;
  int backtracks = 0;
  for (int it = 0;; ++it) {
    const bool predictor = it == 0 && !du_c.empty();
    if (predictor) as.dirichlet_rhs = du_c;
    else as.dirichlet_rhs.clear();
    MaterialStatus st = assemble(t_new, dt, true, u, p, as);
    // Line search on the full assembly of the trial point (most steps accept α = 1, so no extra
    // residual evaluation): backtrack when the trial is inadmissible (material failure) or, without a
    // cavity constraint, when s(α) = Δu·R(u + αΔu) is not reduced enough (energy criterion).
    while (it > 0 && options_.line_search) {
      bool ok = st == MaterialStatus::ok;
      double s = 0.0;
      if (ok && !model_.cavity && s0 < 0.0) {
        for (int d = 0; d < ndof; ++d)
          if (dofs_.eq[d] >= 0) s += x1[dofs_.eq[d]] * as.R[d];
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
      st = assemble(t_new, dt, true, u, p, as);
    }
    if (st != MaterialStatus::ok)
      return fail(std::string("material call failed (") + to_string(st) + ") in element " +
                  std::to_string(as.failed_element));
    double rn = 0.0;
    for (int d = 0; d < ndof; ++d)
      if (dofs_.eq[d] >= 0) {
        const double v = as.R[d] + (predictor ? as.dirichlet_rhs[d] : 0.0);
        rhs[dofs_.eq[d]] = -v;
        rn += v * v;
      }
    rn = std::sqrt(rn);
    const double scale = std::max({as.fint_norm, as.fext_norm, 1e-300});
    const double vres = model_.cavity ? std::abs(as.volume - v_target) / cavity_v0_ : 0.0;
    if (!std::isfinite(rn)) return fail("non-finite residual");
    if (options_.verbose)
      std::cerr << "    it " << it << " |R| = " << rn << " (scale " << scale << ")"
                << (model_.cavity ? " |dV|/V0 = " + std::to_string(vres) : "") << (alpha < 1 ? " alpha " + std::to_string(alpha) : "") << "\n";
    // Converged: below tolerance, or stagnating within 100× of it (round-off floor of a nearly
    // incompressible tangent, K/G ~ 1e5, where ‖R‖/scale cannot drop much below 1e-8).
    const bool floor = it > 1 && rn <= 100 * options_.tolerance * scale && rn >= 0.5 * r_prev;
    r_prev = rn;
    if (!predictor && it > 0 && (rn <= options_.tolerance * scale || floor) && vres <= 1e-9) {
      u_ = std::move(u);
      cavity_pressure_ = p;
      std::swap(state_old_, state_new_);
      cauchy_.swap(as.cauchy);
      stats_.newton_iterations += it;
      return true;
    }
    // Divergence: the residual grows far above its value after the first correction.
    if (it == 1) r0 = rn;
    if (it >= 2 && rn > 1e4 * std::max(r0, options_.tolerance * scale)) return fail("Newton diverged");
    if (it >= options_.max_iterations) {
      std::ostringstream msg;
      msg << "no convergence in " << options_.max_iterations << " iterations (|R|/scale = " << rn / scale << ")";
      return fail(msg.str());
    }
    if (!analyzed) {
      linear_->analyze(K_);
      analyzed = true;
    }
    if (!linear_->factorize(K_)) {
      if (linear_->kind() != SolverKind::cholmod) return fail("singular tangent");
      stats_.log.push_back("tangent not positive definite at t = " + std::to_string(t_new) +
                           ": switching from CHOLMOD to UMFPACK");
      if (options_.verbose) std::cerr << stats_.log.back() << "\n";
      linear_ = make_linear_solver(SolverKind::umfpack);
      linear_->analyze(K_);
      if (!linear_->factorize(K_)) return fail("singular tangent");
    }
    linear_->solve(rhs, x1);
    dp = 0.0;
    if (model_.cavity) {
      for (int d = 0; d < ndof; ++d)
        if (dofs_.eq[d] >= 0) afree[dofs_.eq[d]] = as.a[d];
      linear_->solve(afree, x2);
      double a1 = 0.0, a2 = 0.0;
      for (int k = 0; k < nf; ++k) {
        a1 += afree[k] * x1[k];
        a2 += afree[k] * x2[k];
      }
      // Bordered system: K Δu + a Δp = −R, −a·Δu = V̄ − V.
      if (a2 == 0.0) return fail("cavity constraint is singular");
      dp = (v_target - as.volume + a1) / a2;
      for (int k = 0; k < nf; ++k) x1[k] -= dp * x2[k];
    }
    s0 = 0.0;
    for (int k = 0; k < nf; ++k) s0 -= x1[k] * rhs[k];  // Δu · R(u)
    u_base = u;
    p_base = p;
    alpha = 1.0;
    backtracks = 0;
    for (int d = 0; d < ndof; ++d) {
      const int k = dofs_.eq[d];
      if (k >= 0) u[d] += x1[k];
      else if (predictor) u[d] += du_c[d];
    }
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
    if (try_step(time_ + dt, dt, why)) {
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
  // Internal force at the converged state (no pressure contribution on these dofs is assumed).
  double sum = 0.0;
  Vec24 r;
  std::vector<char> want(model_.mesh.num_dofs(), 0);
  for (int d : dofs) want[d] = 1;
  for (int e = 0; e < model_.mesh.num_elements(); ++e) {
    const Hex& hex = model_.mesh.hexes[e];
    bool touches = false;
    for (int a = 0; a < 8 && !touches; ++a)
      for (int i = 0; i < 3; ++i) touches |= want[3 * hex[a] + i] != 0;
    if (!touches) continue;
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
#pragma omp parallel for schedule(static)
  for (int e = 0; e < ne; ++e) {
    const Hex& hex = mesh.hexes[e];
    const Mat83 ue = gather(u_, hex);
    const Hex8Kinematics k = hex8_kinematics(geometry_[e], ue, model_.formulation);
    if (!k.ok) continue;
    f.J[e] = k.theta;
    const Material& m = *model_.element_material[e];
    Mat3 sigma = Mat3::Zero(), Fmean = Mat3::Zero();
    for (int q = 0; q < 8; ++q) Fmean += (geometry_[e].w[q] / geometry_[e].volume) * k.F[q];
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
