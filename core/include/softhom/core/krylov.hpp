#pragma once
// Krylov methods templated on the vector space: the operator, the preconditioner and the vector
// operations (inner products, updates) are supplied by the caller, so a spectral vector (the FFT
// engine's half spectra with mode weights) or a distributed one (each rank its slab, inner products
// reduced over ranks) plugs in without touching the iteration. Operations that a space can fuse into
// one pass over memory (direction update + operator, update + preconditioner + inner product) are
// single calls of the space.

// ---------------------------------------------------------------------------------------------
// Conjugate gradients
// ---------------------------------------------------------------------------------------------
#include <algorithm>
#include <cmath>

namespace softhom::krylov {

/// Stops shared by the methods of this file.
struct Controls {
  double rel_tol = 1e-8;      ///< relative residual in the preconditioned norm
  int max_iterations = 1000;
  bool (*stop)() = nullptr;   ///< polled once per iteration (e.g. softhom::stop_requested); true ends the solve
};

struct CgResult {
  int iterations = 0;
  bool converged = false;
  bool breakdown = false;    ///< a direction of non-positive curvature stopped it (K not SPD there)
  bool interrupted = false;  ///< Controls::stop said so
};

/// Preconditioned CG on K x = b, x starting at zero. `space` provides, on vectors V:
///   void start(const V& b, V& x, V& r)                     r = b, x = 0
///   double precondition_dot(const V& r, V& z)              z = M⁻¹ r, returns ⟨r, z⟩
///   double direction(const V& z, double beta, V& p, V& Kp) p = z + β p (β = 0: p = z), Kp = K p;
///                                                          returns ⟨p, K p⟩
///   double update(double alpha, const V& p, const V& Kp, V& x, V& r, V& z)
///                                                          x += α p, r −= α K p, z = M⁻¹ r; returns ⟨r, z⟩
/// Converged when ⟨r, z⟩^½ ≤ rel_tol ⟨r₀, z₀⟩^½. r, z, p, Kp are work vectors kept by the caller
/// (no allocation per solve).
template <class V, class Space>
CgResult pcg(Space& space, const V& b, V& x, V& r, V& z, V& p, V& Kp, const Controls& c) {
  CgResult out;
  space.start(b, x, r);
  double rz = space.precondition_dot(r, z);
  const double rz0 = rz;
  if (!(rz0 > 0.0)) {
    out.converged = true;
    return out;
  }
  double beta = 0.0;
  while (out.iterations < c.max_iterations) {
    if (c.stop && c.stop()) {
      out.interrupted = true;
      break;
    }
    const double pKp = space.direction(z, beta, p, Kp);
    ++out.iterations;
    if (!(pKp > 0.0)) {
      out.breakdown = true;
      break;
    }
    const double alpha = rz / pKp;
    const double rz_new = space.update(alpha, p, Kp, x, r, z);
    if (std::sqrt(std::max(rz_new, 0.0) / rz0) <= c.rel_tol) {
      out.converged = true;
      break;
    }
    beta = rz_new / rz;
    rz = rz_new;
  }
  return out;
}

}  // namespace softhom::krylov

// ---------------------------------------------------------------------------------------------
// MINRES
// ---------------------------------------------------------------------------------------------
#include <algorithm>
#include <cmath>
#include <utility>

namespace softhom::krylov {

struct MinresResult {
  int iterations = 0;
  bool converged = false;
  bool interrupted = false;
};

/// Preconditioned MINRES (Paige–Saunders; the Lanczos form of Elman, Silvester & Wathen, Alg. 2.4)
/// on a symmetric, possibly indefinite K x = b with an SPD preconditioner M, x starting at zero.
/// `space` provides, on vectors V (copyable):
///   V zero_like(const V& b)                                a zero vector of b's shape
///   void precondition(const V& r, V& z)                    z = M⁻¹ r
///   void apply(const V& x, V& y)                           y = K x
///   double dot(const V& a, const V& b)                     ⟨a, b⟩
///   void axpby(double a, const V& x, double b, V& y)       y = a x + b y
///   void divide(V& x, double s)                            x = x / s
///   void combine(const V& z, double a3, const V& w_old, double a2, const V& w, double a1, V& w_new,
///                double c, V& x)                           w_new = (z − a3 w_old − a2 w) / a1, x += c w_new
/// Converged when the preconditioned residual norm |η| ≤ rel_tol γ₁ (or at an invariant subspace).
template <class V, class Space>
MinresResult pminres(Space& space, const V& b, V& x, const Controls& ctl) {
  MinresResult out;
  V v_old = space.zero_like(b), v = b, z = space.zero_like(b), Kz = space.zero_like(b);
  V w_old = space.zero_like(b), w = space.zero_like(b), w_new = space.zero_like(b);
  x = space.zero_like(b);
  space.precondition(v, z);
  double gamma = std::sqrt(std::max(space.dot(z, v), 0.0)), gamma_old = 1.0;
  const double gamma1 = gamma;
  double eta = gamma, s_old = 0.0, s = 0.0, c_old = 1.0, c = 1.0;
  if (!(gamma1 > 0.0)) {
    out.converged = true;
    return out;
  }
  while (out.iterations < ctl.max_iterations) {
    if (ctl.stop && ctl.stop()) {
      out.interrupted = true;
      break;
    }
    ++out.iterations;
    space.divide(z, gamma);
    space.apply(z, Kz);
    const double delta = space.dot(Kz, z);
    // v_new = K z − (δ/γ) v − (γ/γ_old) v_old, written into v_old (then swapped).
    space.axpby(1.0, Kz, -gamma / gamma_old, v_old);
    space.axpby(-delta / gamma, v, 1.0, v_old);
    std::swap(v_old, v);  // v_old ← v (current), v ← v_new
    const double a3 = s_old * gamma, a2_base = gamma;
    V& z_next = Kz;  // K z no longer needed
    space.precondition(v, z_next);
    const double gamma_next = std::sqrt(std::max(space.dot(z_next, v), 0.0));
    const double a0 = c * delta - c_old * s * a2_base;
    const double a1 = std::hypot(a0, gamma_next);
    const double a2 = s * delta + c_old * c * a2_base;
    if (!(a1 > 0.0)) break;
    const double c_new = a0 / a1, s_new = gamma_next / a1;
    space.combine(z, a3, w_old, a2, w, a1, w_new, c_new * eta, x);
    std::swap(w_old, w);
    std::swap(w, w_new);
    eta = -s_new * eta;
    std::swap(z, z_next);
    gamma_old = gamma;
    gamma = gamma_next;
    c_old = c;
    c = c_new;
    s_old = s;
    s = s_new;
    if (std::abs(eta) <= ctl.rel_tol * gamma1) {
      out.converged = true;
      break;
    }
    if (!(gamma > 0.0)) {  // invariant subspace: x is the exact solution in it
      out.converged = true;
      break;
    }
  }
  return out;
}

}  // namespace softhom::krylov
// ---------------------------------------------------------------------------------------------------
// GMRES
// ---------------------------------------------------------------------------------------------------
// Templated on the operator, the preconditioner and the vector operations, so that a distributed
// vector (with its own reductions) can replace std::vector<double> without touching the iterations.
// This section is self-contained (its own includes and names).
//
// Restarted GMRES(m), right-preconditioned: minimizes ‖b − A M⁻¹ y‖ over the Krylov space of A M⁻¹,
// with modified Gram–Schmidt. The preconditioned basis Z = M⁻¹ V is kept, so the update x += Z y needs
// no extra preconditioner application (and M may change between iterations: flexible GMRES).
//
// Optionally the least squares minimizes a projected residual ‖P (b − A x)‖ instead (P a linear map,
// e.g. the condensation of a saddle-point residual onto its primal unknowns): then the small problem
// is min_y ‖P V (β e₁ − H̄ y)‖, solved through the Gram matrix of P V. Convergence is judged on ‖P r‖.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <type_traits>
#include <utility>
#include <vector>

#include <Eigen/Dense>

namespace softhom::krylov {

/// Vector operations of std::vector<double> (shared memory). A distributed vector supplies the same
/// static functions with global reductions in dot().
struct GmresStdOps {
  using Vector = std::vector<double>;
  static double dot(const Vector& a, const Vector& b) {
    double s = 0.0;
    for (std::size_t k = 0; k < a.size(); ++k) s += a[k] * b[k];
    return s;
  }
  static double norm(const Vector& a) { return std::sqrt(dot(a, a)); }
  /// y += alpha x
  static void axpy(double alpha, const Vector& x, Vector& y) {
    for (std::size_t k = 0; k < x.size(); ++k) y[k] += alpha * x[k];
  }
  /// y = alpha x (y takes x's size)
  static void scaled_copy(double alpha, const Vector& x, Vector& y) {
    y.resize(x.size());
    for (std::size_t k = 0; k < x.size(); ++k) y[k] = alpha * x[k];
  }
  /// y = x / d (y takes x's size)
  static void quotient(const Vector& x, double d, Vector& y) {
    y.resize(x.size());
    for (std::size_t k = 0; k < x.size(); ++k) y[k] = x[k] / d;
  }
  static void zeros_like(const Vector& like, Vector& y) { y.assign(like.size(), 0.0); }
};

/// The plain residual norm (no projection).
struct GmresNoProjection {
  static constexpr bool active = false;
  template <class Vector>
  void operator()(const Vector&, Vector&) const {}
};

/// A projected residual ‖P r‖: `apply(in, out)` computes out = P in.
template <class Apply>
struct GmresProjection {
  static constexpr bool active = true;
  Apply apply;
  template <class Vector>
  void operator()(const Vector& in, Vector& out) const { apply(in, out); }
};
template <class Apply>
GmresProjection<Apply> gmres_projection(Apply apply) { return {std::move(apply)}; }

/// Always continue (no early stop).
struct GmresNoMonitor {
  bool operator()(int, double) const { return true; }
};

struct GmresOptions {
  int restart = 30;         ///< m: basis vectors per cycle
  int max_iterations = 30;  ///< total over the cycles
  double tolerance = 1e-8;  ///< on ‖r‖ / ‖b‖ (‖P r‖ / ‖b‖ with a projection)
};

struct GmresResult {
  bool converged = false;
  int iterations = 0;
  double residual = 0.0;  ///< final ‖r‖ (or ‖P r‖), absolute
};

/// Basis storage kept between solves (allocated once, grown lazily).
template <class Vector>
struct GmresWorkspace {
  std::vector<Vector> V, Z, W;  ///< Krylov basis, M⁻¹ of it, P of it (projected runs)
};

/// Solves A x = b from x = 0. `b_norm` is the norm the tolerance refers to (‖b‖, or ‖P b‖ when the
/// projected residual of b is meant). `A(in, out)`: out = A in; `M(in, out)`: out = M⁻¹ in;
/// `project`: GmresNoProjection or gmres_projection(...); `keep_going(iterations, residual)` may end the run early
/// (false: stop after this iteration, e.g. when the convergence rate cannot reach the tolerance).
template <class Ops = GmresStdOps, class Operator, class Preconditioner, class Project = GmresNoProjection,
          class Monitor = GmresNoMonitor>
GmresResult gmres(const typename Ops::Vector& b, double b_norm, typename Ops::Vector& x, Operator&& A,
                  Preconditioner&& M, const GmresOptions& options, GmresWorkspace<typename Ops::Vector>& ws,
                  Project&& project = {}, Monitor&& keep_going = {}) {
  using Vector = typename Ops::Vector;
  constexpr bool projected = std::decay_t<Project>::active;
  const int m = options.restart;
  GmresResult out;
  Ops::zeros_like(b, x);
  if (b_norm == 0.0) {
    out.converged = true;
    return out;
  }
  if (int(ws.V.size()) != m + 1) ws.V.assign(m + 1, Vector{});
  if (int(ws.Z.size()) != m) ws.Z.assign(m, Vector{});
  if (projected && int(ws.W.size()) != m + 1) ws.W.assign(m + 1, Vector{});
  auto& V = ws.V;
  auto& Z = ws.Z;
  auto& W = ws.W;
  Vector w, r, pr;
  Ops::zeros_like(b, w);
  Ops::scaled_copy(1.0, b, r);
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(m + 1, m), G = Eigen::MatrixXd::Zero(m + 1, m + 1);
  double beta = Ops::norm(r);
  int max_its = options.max_iterations;
  const double target = options.tolerance * b_norm;
  while (!out.converged && out.iterations < max_its) {
    Ops::quotient(r, beta, V[0]);
    if constexpr (projected) {
      project(V[0], W[0]);
      G(0, 0) = Ops::dot(W[0], W[0]);
    }
    int j = 0;
    Eigen::VectorXd y;
    while (j < m && out.iterations < max_its) {
      M(V[j], Z[j]);
      A(Z[j], w);
      for (int i = 0; i <= j; ++i) {  // modified Gram–Schmidt
        const double h = Ops::dot(w, V[i]);
        Ops::axpy(-h, V[i], w);
        H(i, j) = h;
      }
      const double hn = Ops::norm(w);
      H(j + 1, j) = hn;
      if (hn > 0.0) Ops::quotient(w, hn, V[j + 1]);
      else Ops::scaled_copy(0.0, w, V[j + 1]);
      ++j;
      ++out.iterations;
      const Eigen::MatrixXd Hj = H.topLeftCorner(j + 1, j);
      Eigen::VectorXd e1 = Eigen::VectorXd::Zero(j + 1);
      e1[0] = beta;
      double res;
      if constexpr (projected) {
        // min_y ‖P V (β e₁ − H̄ y)‖ = min_y ‖R (β e₁ − H̄ y)‖ with G = (PV)ᵀ(PV) = RᵀR.
        project(V[j], W[j]);
        for (int i = 0; i <= j; ++i) G(i, j) = G(j, i) = Ops::dot(W[i], W[j]);
        Eigen::MatrixXd Gj = G.topLeftCorner(j + 1, j + 1);
        // The projected basis can be nearly dependent: a tiny diagonal shift keeps the Cholesky factor
        // defined without changing the minimizer measurably.
        Gj.diagonal().array() += 1e-14 * Gj.diagonal().maxCoeff();
        const Eigen::MatrixXd R = Gj.llt().matrixU();
        const Eigen::MatrixXd RH = R * Hj;
        const Eigen::VectorXd rhs = R * e1;
        y = RH.colPivHouseholderQr().solve(rhs);
        res = (rhs - RH * y).norm();
      } else {
        y = Hj.colPivHouseholderQr().solve(e1);
        res = (e1 - Hj * y).norm();
      }
      if (res <= target || hn == 0.0) break;
      if (!keep_going(out.iterations, res)) max_its = out.iterations;
    }
    for (int i = 0; i < j; ++i) Ops::axpy(y[i], Z[i], x);  // x += M⁻¹ V y
    // True residual (the restart vector; guards against loss of orthogonality).
    A(x, w);
    Ops::scaled_copy(1.0, b, r);
    Ops::axpy(-1.0, w, r);
    beta = Ops::norm(r);
    if constexpr (projected) {
      project(r, pr);
      out.residual = Ops::norm(pr);
    } else {
      out.residual = beta;
    }
    out.converged = out.residual <= 1.01 * target;  // else restart from the true residual
    if (!out.converged && beta == 0.0) break;
  }
  return out;
}

}  // namespace softhom::krylov
