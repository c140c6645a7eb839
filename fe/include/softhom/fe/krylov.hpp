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
