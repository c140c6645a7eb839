// Linear algebra of fe::Simulation: factorizations (CHOLMOD of the symmetric part; past a limit point
// MUMPS's LDLᵀ of it or UMFPACK LU), the right-preconditioned GMRES solves and the three-field element
// updates.
#include "simulation_impl.hpp"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <iostream>
#include <sstream>
#include <tuple>
#include <type_traits>

#include <Eigen/Dense>

#include "softhom/core/krylov.hpp"
#include "softhom/materials/errors.hpp"

namespace softhom::fe {
using namespace detail;

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

namespace {
/// Whether K is symmetric to round-off (no follower pressure, hyperelastic law): then a Cholesky factor is
/// exact.
bool symmetric(const CscMatrix& K) { return relative_skew(K) <= 1e-13; }
}  // namespace

bool Simulation::Impl::refactor(std::string& why) {
  // The first factorization has no measured cost yet: take CHOLMOD's estimate from the analysis (a
  // 1e5-dof tube's first factorization otherwise ran on one thread).
  if (last_factor_flops_ == 0.0) {
    direct_->analyze(K_);
    last_factor_flops_ = direct_->predicted_flops();
  }
  const ThreadScope scope(last_factor_flops_ < kThreadedFactorFlops);
  const auto t0 = std::chrono::steady_clock::now();
  const bool exact_cholesky = symmetric(K_);
  const bool ok = direct_->factorize(K_);
  // Expected past a pressure maximum: noted once, not per step.
  if (direct_->fell_back() && !first_factorization_)
    note_once("tangent indefinite", "the tangent's symmetric part is not positive definite from t = " + format_number(time_) +
                                        " on (past a pressure maximum, near a buckling mode, or a Newton iterate off the path): "
                                        "MUMPS's LDLᵀ of a symmetric tangent, UMFPACK's LU of another, for such steps (noted once)");
  last_factor_flops_ = direct_->last_factor_flops();
  keep_saddle_of_factor(ok);
  factor_valid_ = ok;
  factor_stale_ = false;
  factor_version_ = k_version_;
  factor_exact_ = direct_->kind() == SolverKind::umfpack || exact_cholesky;
  last_factor_time_ = seconds_since(t0);
  return check_first_factorization(ok, why);
}

void Simulation::Impl::keep_saddle_of_factor(bool ok) {
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
}

bool Simulation::Impl::check_first_factorization(bool ok, std::string& why) {
  // The first factorization is of the tangent at the undeformed (or converged) state: a singular or
  // nearly singular one (a zero pivot, or pivots 13 decades apart) is a system that no step size can
  // solve — a part of the body that is not held, a mechanism, a material without stiffness.
  const bool first = first_factorization_;
  first_factorization_ = false;
  const double rcond = ok ? direct_->reciprocal_condition() : 0.0;
  if (first && (!ok || rcond < 1e-13)) {
    factor_valid_ = false;
    singular_system_ = true;
    why = "the stiffness is singular at the first factorization (CHOLMOD: not positive definite; UMFPACK: " +
          std::string(ok ? "pivot ratio " + format_number(rcond) : "singular") +
          "): a part of the body is not held (a mechanism or a disconnected part) or a material has no stiffness";
    return false;
  }
  if (!ok) why = "singular tangent";
  return ok;
}

namespace {
/// The element operations of the uncondensed (u, p_e) space: per mixed element k, its free equations
/// eq[off[k] .. off[k+1]) and the row weight w_k = |d_k| of the current tangent.
struct SaddleSpace {
  int n = 0, np = 0;
  const std::vector<int>& off;
  const std::vector<int>& eq;
  const std::vector<std::vector<int>>& colors;
  std::vector<double> wgt;

  double dot_e(const std::vector<double>& d, int k, const double* v) const {
    double s = 0.0;
    for (int q = off[k]; q < off[k + 1]; ++q)
      if (eq[q] >= 0) s += d[q] * v[eq[q]];
    return s;
  }
  /// out[k] = c[k] · d_kᵀ v − sub[k] (c, sub optional), in parallel over the elements.
  void dots(const std::vector<double>& d, const double* c, const double* v, const double* sub, double* out) const {
#pragma omp parallel for schedule(static) if (np >= 4000)
    for (int k = 0; k < np; ++k) out[k] = (c ? c[k] : 1.0) * dot_e(d, k, v) - (sub ? sub[k] : 0.0);
  }
  /// v += Σ_k a[k] d_k, colour by colour (elements of one colour share no dof).
  void scatter(const std::vector<double>& d, const double* a, double* v) const {
#pragma omp parallel if (np >= 4000)
    for (const std::vector<int>& color : colors) {
#pragma omp for schedule(static)
      for (std::size_t i = 0; i < color.size(); ++i) {
        const int k = color[i];
        for (int q = off[k]; q < off[k + 1]; ++q)
          if (eq[q] >= 0) v[eq[q]] += a[k] * d[q];
      }
    }
  }
};
}  // namespace

bool Simulation::Impl::linear_solve(const std::vector<double>& b, std::vector<double>& x, double tol, std::string& why,
                                     bool secant_start) {
  if (petsc_) return petsc_linear_solve(b, x, tol, why, secant_start);  // the petsc route
  const int n = dofs_.num_free;
  x.assign(n, 0.0);
  if (norm(b) == 0.0) return true;
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
  if (factor_version_ == k_version_ && factor_exact_) {
    direct_->solve(b, x);
    return true;
  }
  return krylov_solve(b, x, tol, why);
}

namespace {
/// The operators of one GMRES solve (krylov_solve): the tangent K_c, or the uncondensed (u, t) system
/// of the saddle space (sp.np > 0), with the factor's inverse as right preconditioner, and the time spent
/// in that inverse.
struct KrylovOperators {
  const CscMatrix& K;
  LinearSolver& factor;
  const SaddleSpace& sp;
  const std::vector<double>&db, &cb, &da, &ca;  ///< d_e, c_e of the current (b) and factorized (a) tangents
  double preconditioner_seconds = 0.0;
  std::vector<double> ek, tk, zu, fu;  // element and u work vectors

  KrylovOperators(const CscMatrix& K_, LinearSolver& factor_, const SaddleSpace& sp_, const std::vector<double>& db_,
                  const std::vector<double>& cb_, const std::vector<double>& da_, const std::vector<double>& ca_)
      : K(K_), factor(factor_), sp(sp_), db(db_), cb(cb_), da(da_), ca(ca_), ek(std::size_t(sp_.np)), tk(ek) {}

  int n() const { return sp.n; }
  bool saddle() const { return sp.np > 0; }
  void condensed_matvec(const double* in, double* out) const {
    // Row-parallel product only where it pays: on a loaded 2-core machine an OpenMP barrier can cost
    // a scheduler time slice.
    if (n() >= 50000 && !K.mirror.empty()) {
      K.multiply(in, out);
      return;
    }
    for (int row = 0; row < n(); ++row) {
      double sum = 0.0;
      for (int k = K.colptr[row]; k < K.colptr[row + 1]; ++k) sum += K.values[K.mirror[k]] * in[K.rowind[k]];
      out[row] = sum;
    }
  }
  void precondition(const std::vector<double>& in, std::vector<double>& out) {
    const auto tp = std::chrono::steady_clock::now();
    out.resize(std::size_t(n() + sp.np));
    if (!saddle()) {
      factor.solve(in, out);
      preconditioner_seconds += seconds_since(tp);
      return;
    }
    fu.assign(in.begin(), in.begin() + n());
    for (int k = 0; k < sp.np; ++k) ek[k] = in[n() + k] / sp.wgt[k];
    sp.scatter(da, ek.data(), fu.data());
    factor.solve(fu, zu);
    std::copy(zu.begin(), zu.end(), out.begin());
    sp.dots(da, ca.data(), zu.data(), ek.data(), out.data() + n());
    preconditioner_seconds += seconds_since(tp);
  }
  void multiply(const std::vector<double>& in, std::vector<double>& out) {
    out.resize(std::size_t(n() + sp.np));
    condensed_matvec(in.data(), out.data());
    if (!saddle()) return;
    sp.dots(db, cb.data(), in.data(), in.data() + n(), tk.data());  // t_e = c_e d_eᵀ u − t-unknown
    for (int k = 0; k < sp.np; ++k) {
      out[n() + k] = sp.wgt[k] * tk[k];
      tk[k] = -tk[k];
    }
    sp.scatter(db, tk.data(), out.data());
  }
  /// Condensed residual b − K_c x_u of a saddle residual r: P r = r_u + Σ d_e r_e / w_e.
  void condensed_of(const std::vector<double>& res, std::vector<double>& c) {
    c.assign(res.begin(), res.begin() + n());
    for (int k = 0; k < sp.np; ++k) ek[k] = res[n() + k] / sp.wgt[k];
    sp.scatter(db, ek.data(), c.data());
  }
};

/// The saddle space of a GMRES solve: the uncondensed (u, t) space where three-field elements have the
/// d_e, c_e of both the current and the factorized tangent, else none (np = 0: the condensed system).
SaddleSpace krylov_space(const Simulation::Impl& s) {
  const bool saddle = s.options_.saddle_krylov && !s.sad_elem_.empty() && s.sad_a_valid_ && s.sad_b_version_ == s.k_version_;
  SaddleSpace sp{s.dofs_.num_free, saddle ? int(s.sad_elem_.size()) : 0, s.sad_off_, s.sad_eq_, s.sad_colors_, {}};
  sp.wgt.resize(std::size_t(sp.np));
  for (int k = 0; k < sp.np; ++k) {
    double sum = 0.0;
    for (int q = s.sad_off_[k]; q < s.sad_off_[k + 1]; ++q) sum += s.sad_db_[q] * s.sad_db_[q];
    sp.wgt[k] = sum > 0.0 ? std::sqrt(sum) : 1.0;
  }
  return sp;
}

}  // namespace

krylov::GmresOptions Simulation::Impl::gmres_budget(double tol) const {
  // m = 30: a lagged factor may be given up to ~30 iterations (below), which GMRES(20) would restart.
  // The basis is kept between solves (31 vectors of N: 27 MB at 1e5 dofs).
  krylov::GmresOptions go;
  go.restart = 30;
  go.tolerance = tol;
  // A lagged factor gets as many iterations as cost 90 % of a fresh factorization (measured; at 1e5
  // dofs a factorization is 3 s and an iteration 0.09 s, ~30 iterations), at least 15.
  go.max_iterations = options_.krylov_max;
  if (factor_version_ != k_version_) {
    const int affordable = iteration_time_ > 0.0 ? int(0.9 * last_factor_time_ / iteration_time_) : 15;
    go.max_iterations = std::clamp(affordable, 15, std::min(options_.krylov_max, go.restart));
  }
  return go;
}

void Simulation::Impl::judge_lagged_factor(int its) {
  // Refresh a lagged factor once its iterations cost 3/4 of a factorization (measured), or in any case
  // after 3 × `refactor_after` iterations.
  if (its > 3 * options_.refactor_after || (its > 2 && its * iteration_time_ > 0.75 * last_factor_time_)) {
    factor_stale_ = true;
    if (options_.verbose)
      std::cerr << "      factor stale: " << its << " iterations of " << iteration_time_ << " s vs factorization "
                << last_factor_time_ << " s\n";
  }
}

// Restarted GMRES(m), right-preconditioned by the lagged or symmetric-part factorization M ≈ K:
// minimizes ‖b − K M⁻¹ y‖.
//
// Three-field iteration (saddle_krylov): the condensed tangent is K_c = A + Σ_e c_e d_e d_eᵀ with
// c_e = V_e U″(θ) ~ V_e κ, κ/G ≈ 1.2e5 for the ecoflex tube, and d_e = ∂θ_e/∂u moves with the geometry:
// a strain change δ moves K_c by ≈ κ δ ≫ G, so a factor of K_c at another iterate is a poor
// preconditioner of K_c (GMRES rates 0.25–0.65 per iteration, BENCHMARKS.md). The uncondensed
// system in (u, t_e), t_e = c_e d_eᵀu − p_e,
//     [ K_c u − Σ_e d_e t_e ]   [ b ]        (u-row: A u + Σ d_e p_e)
//     [ w_e t_e             ] = [ 0 ]        (element row: the scaled constraint residual)
// has the same u (t = 0, K_c u = b), but its blocks move only by O(δ) relative to themselves. Its lagged
// version M_a (d_a, c_a of the factorized tangent) is inverted exactly with one solve of the lagged
// condensed factor S_a = K_c,a:  x = S_a⁻¹(f + Σ d_a,e g_e / w_e),  t_e = c_a,e d_a,eᵀ x − g_e / w_e.
// GMRES builds its Krylov space on the uncondensed system but minimizes the condensed residual
// b − K_c x_u = P r, P r = r_u + Σ_e d_e r_e / w_e (row weights w_e = |d_e|), through the Gram matrix of
// P V (krylov::gmres_projection). Measured on the 1e5-dof tube: with the previous step's factor,
// iteration 0 of a step (a residual dominated by the predictor's volume mismatch) reaches 2e-5 in 10–18
// GMRES iterations where the condensed iteration stalls at 1e-3 after 30; later iterations, whose
// residuals load the Q1/P0 pressure modes (weakly controlled by the inf-sup condition, so M_a⁻¹ is
// not bounded there), still need a factor of the same step — hence refactor_each_step.
bool Simulation::Impl::krylov_solve(const std::vector<double>& b, std::vector<double>& x, double tol, std::string& why) {
  const int n = dofs_.num_free;
  const double bnorm = norm(b);
  const SaddleSpace sp = krylov_space(*this);
  const bool saddle = sp.np > 0;
  KrylovOperators ops(K_, *direct_, sp, sad_db_, sad_cb_, sad_da_, sad_ca_);
  auto precond = [&](const std::vector<double>& in, std::vector<double>& out) { ops.precondition(in, out); };
  auto matvec = [&](const std::vector<double>& in, std::vector<double>& out) { ops.multiply(in, out); };
  auto condensed_of = [&](const std::vector<double>& res, std::vector<double>& c) { ops.condensed_of(res, c); };
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<double> b_full(std::size_t(n + sp.np), 0.0), xs;  // the right-hand side in the (u, t) space: (b, 0)
  std::copy(b.begin(), b.end(), b_full.begin());
  for (int attempt = 0; attempt < 2; ++attempt) {
    const auto t_attempt = std::chrono::steady_clock::now();
    const krylov::GmresOptions go = gmres_budget(tol);
    const bool lagged = factor_version_ != k_version_;
    // A lagged factor whose convergence rate would not reach the tolerance within the budget (the early
    // Newton iterations of a step, where the tangent still moves a lot): refactorize now instead of after
    // the whole budget of wasted triangular solves (1e5 dofs: 0.09 s each). Checked every 5 iterations
    // with the rate of the last 5 (GMRES with a lagged factor slows down).
    double checkpoint = 1.0;  // |r|/|b| at the last rate check
    auto rate_can_reach = [&](int its, double res) {
      if (!lagged || its % 5 != 0) return true;
      const double ratio = res / bnorm;
      const double rate = std::pow(ratio / checkpoint, 0.2);
      checkpoint = ratio;
      return rate < 1.0 && its + std::log(tol / ratio) / std::log(rate) <= go.max_iterations;
    };
    const krylov::GmresResult g =
        saddle ? krylov::gmres(b_full, bnorm, xs, matvec, precond, go, krylov_, krylov::gmres_projection(condensed_of),
                               rate_can_reach)
               : krylov::gmres(b_full, bnorm, xs, matvec, precond, go, krylov_, krylov::GmresNoProjection{}, rate_can_reach);
    const int its = g.iterations;
    std::copy(xs.begin(), xs.begin() + n, x.begin());
    stats_.krylov_iterations += its;
    if (its > 0) {  // running mean of the cost of one iteration (preconditioner solve + product + basis)
      const double t = seconds_since(t_attempt) / its;
      iteration_time_ = iteration_time_ > 0.0 ? 0.7 * iteration_time_ + 0.3 * t : t;
    }
    if (options_.verbose)
      std::cerr << "      gmres" << (saddle ? " (u,p)" : "") << " " << its << " its, |r|/|b| = " << g.residual / bnorm
                << (factor_version_ == k_version_ ? " (fresh factor)" : " (lagged factor)") << "\n";
    if (g.converged) {
      stats_.krylov_time += seconds_since(t0) - ops.preconditioner_seconds;
      judge_lagged_factor(its);
      return true;
    }
    // Lagged factor too far off: refactorize with the current tangent and retry once.
    if (attempt == 0) {
      if (options_.verbose) std::cerr << "      lagged factor failed: refactorize\n";
      if (!refactor(why)) break;
      if (factor_exact_) {
        stats_.krylov_time += seconds_since(t0) - ops.preconditioner_seconds;
        direct_->solve(b, x);
        return true;
      }
    }
  }
  stats_.krylov_time += seconds_since(t0) - ops.preconditioner_seconds;
  if (why.empty()) why = "linear solver: GMRES did not converge with a fresh factorization";
  return false;
}

void Simulation::Impl::saddle_current() {
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
    const double* de = mixed_gradient(e);
    std::copy(de, de + (sad_off_[k + 1] - sad_off_[k]), sad_db_.begin() + sad_off_[k]);
    Hex8Geometry hex_scratch;
    Tet10Geometry tet_scratch;
    const double V = tet ? tet_geometry(e, tet_scratch).volume : hex_geometry(e, hex_scratch).volume;
    sad_cb_[k] = V * volumetric_d2U(mix_bulk_[e], mix_theta_[e]);
  }
  sad_b_version_ = k_version_;
}

void Simulation::Impl::mixed_update(const std::vector<double>& du, double alpha) {
  // Newton increments of the condensed element unknowns (see MixedVolume):
  // Δθ = d·Δu_e + θ_e(u) − θ,  Δp = U″(θ) Δθ + U′(θ) − p, taken with the line-search factor α.
  const Mesh& mesh = model_.mesh;
  const int ne = mesh.num_elements();
  if (!du.empty()) {
#pragma omp parallel for schedule(static) if (ne >= 4000)
    for (int e = 0; e < ne; ++e) {
      mix_theta_base_[e] = mix_theta_[e];
      mix_p_base_[e] = mix_p_[e];
      // Another rank's element: its owner updates it (this rank never reads its θ, p).
      if (mix_bulk_[e] <= 0.0 || !owns(e)) continue;
      double s = 0.0;
      const int* en = mesh.element_nodes(e);
      const double* de = mixed_gradient(e);
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

}  // namespace softhom::fe
