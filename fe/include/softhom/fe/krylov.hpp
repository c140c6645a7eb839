#pragma once
// Krylov solvers templated on the operator, the preconditioner and the vector operations, so that a
// distributed vector (with its own reductions) can replace std::vector<double> without touching the
// iterations. Each solver's section is self-contained (its own includes).

// ---------------------------------------------------------------------------------------------------
// GMRES
// ---------------------------------------------------------------------------------------------------
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
#include <vector>

#include <Eigen/Dense>

namespace softhom::krylov {

/// Vector operations of std::vector<double> (shared memory). A distributed vector supplies the same
/// static functions with global reductions in dot().
struct StdVectorOps {
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
struct NoProjection {
  static constexpr bool active = false;
  template <class Vector>
  void operator()(const Vector&, Vector&) const {}
};

/// A projected residual ‖P r‖: `apply(in, out)` computes out = P in.
template <class Apply>
struct Projection {
  static constexpr bool active = true;
  Apply apply;
  template <class Vector>
  void operator()(const Vector& in, Vector& out) const { apply(in, out); }
};
template <class Apply>
Projection<Apply> projection(Apply apply) { return {std::move(apply)}; }

/// Always continue (no early stop).
struct NoMonitor {
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
/// `project`: NoProjection or projection(...); `keep_going(iterations, residual)` may end the run early
/// (false: stop after this iteration, e.g. when the convergence rate cannot reach the tolerance).
template <class Ops = StdVectorOps, class Operator, class Preconditioner, class Project = NoProjection,
          class Monitor = NoMonitor>
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
