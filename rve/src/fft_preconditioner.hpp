#pragma once
// Jacobi–Green preconditioner of the stencil Newton–CG iteration (FftSolverOptions::preconditioner):
//
//   M⁻¹ = S G₀ S,   S = diag(s),   s_(y,i) = (D0_ii / D_(y,i)(i,i))^½,
//
// G₀ the reference-medium Green operator K0⁻¹ (per Fourier mode, fft::ReferenceGreen), D the diagonal
// of the stencil system operator K = Bᵀ A B at node y and component i, D0 that of K0 (the same for every
// node). For a homogeneous cell S = I and M⁻¹ = G₀; with heterogeneous stiffness the diagonal scaling
// takes out the local stiffness level that one reference medium cannot represent (the Jacobi–Green
// preconditioner of the displacement-based FFT-FE literature, Ladecký, Pultarová, Zeman et al.).
// Measured on the glass/ecoflex cells it takes more CG iterations than G₀ alone: 8–15× with the nearly
// incompressible matrix (its node diagonal is its bulk stiffness, not the shear stiffness the slow modes
// see), 1.1–1.8× with a compressible one; it gains (1.8×) on a small 3D hex cell (BENCHMARKS.md, "FFT
// solver cost"). Hence an option, not the default.
//
// S is diagonal in real space and G₀ in Fourier space, so the CG vectors live in real space (nodal
// values; the stencil operator needs no transform at all) and the preconditioner transforms three
// fields forward and back: the same two 3-field transforms per iteration as the Green preconditioner on
// spectral vectors. Real-space scaling is local, so a slab of a distributed cell scales its own nodes;
// the diagonal needs the tangents of the voxels below a node, one lower halo plane (as the adjoint
// stencil pass).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <vector>

#include <Eigen/Core>

#include "softhom/core/krylov.hpp"
#include "softhom/fft/stencil.hpp"
#include "softhom/materials/tensor.hpp"

namespace softhom::rve::detail {

/// Index of (a, b), a ≤ b, in the packed upper triangle of a symmetric 9×9 (row by row, 45 values).
constexpr int packed_index(int a, int b) { return a * 9 - a * (a - 1) / 2 + (b - a); }

/// Diagonal of the stencil operator per point and component: Σ_c Σ_jl B_qcj B_qcl A(3i+j, 3i+l) for
/// the corner c of the voxel, i.e. the 3 diagonal entries a point adds to the node at its corner c.
/// `A(a, b)` returns the (symmetric) tangent entry of the point.
template <class Entry>
inline void corner_diagonal(const fft::StencilGradient& st, int q, int c, Entry&& A, double out[3]) {
  const int d = st.dims();
  for (int i = 0; i < 3; ++i) {
    double acc = 0.0;
    for (int j = 0; j < d; ++j)
      for (int l = 0; l < d; ++l) acc += st.coefficient(q, c, j) * st.coefficient(q, c, l) * A(3 * i + j, 3 * i + l);
    out[i] = acc;
  }
}

/// The node diagonal of K0 (any node): Σ_q w_q Σ_c corner_diagonal(C0).
inline Eigen::Vector3d reference_diagonal(const fft::StencilGradient& st, const std::vector<double>& weights,
                                          const Eigen::Matrix<double, 9, 9>& C0) {
  Eigen::Vector3d D0 = Eigen::Vector3d::Zero();
  for (int q = 0; q < st.points(); ++q)
    for (int c = 0; c < (1 << st.dims()); ++c) {
      double v[3];
      corner_diagonal(st, q, c, [&](int a, int b) { return 0.5 * (C0(a, b) + C0(b, a)); }, v);
      for (int i = 0; i < 3; ++i) D0[i] += weights[q] * v[i];
    }
  return D0;
}

/// The scaling s of M⁻¹ = S G₀ S (3 fields of `voxels` nodes, node y = the voxel whose lower corner it
/// is) from the stored tangents. `tangent(p, idx)`: packed entry idx of point p = v·nq + q; `store`:
/// scratch of 3 values per voxel with room for one lower halo plane (3·plane_voxels values) in front of
/// it; `fill_lower_halo(store, values)`: the halo exchange of a slab (a no-op on one process, where i3
/// wraps periodically). A node whose diagonal is not positive (no stiffness there) keeps s = 1.
template <class Tangent, class Halo>
void jacobi_scaling(const fft::StencilGradient& st, const std::vector<double>& weights, const Eigen::Vector3d& D0,
                    std::size_t voxels, bool slab, Tangent&& tangent, double* store, Halo&& fill_lower_halo,
                    std::vector<float>& s) {
  const int d = st.dims(), nq = st.points(), ncor = 1 << d;
  const fft::Grid& g = st.grid();
  const int n1 = g.n[0], n2 = g.n[1], n3 = g.n[2];
  const std::size_t plane = std::size_t(n1) * n2;
  const long planes = long(voxels / plane);
  // The diagonal is summed in s (float: a preconditioner needs no more) and turned into s in place.
  s.assign(3 * voxels, 0.0f);
  for (int c = 0; c < ncor; ++c) {
    const int c1 = c & 1, c2 = (c >> 1) & 1, c3 = d == 3 ? (c >> 2) & 1 : 0;
    // What every voxel adds to the node at its corner c.
#pragma omp parallel for schedule(static)
    for (std::size_t v = 0; v < voxels; ++v) {
      double acc[3] = {0.0, 0.0, 0.0};
      for (int q = 0; q < nq; ++q) {
        const std::size_t p = v * nq + q;
        double val[3];
        corner_diagonal(st, q, c, [&](int a, int b) { return tangent(p, a <= b ? packed_index(a, b) : packed_index(b, a)); }, val);
        for (int i = 0; i < 3; ++i) acc[i] += weights[q] * val[i];
      }
      for (int i = 0; i < 3; ++i) store[3 * v + i] = acc[i];
    }
    if (c3 && slab) fill_lower_halo(store, 3 * plane);
    // Gather at node y from the voxel y − c (periodic; on a slab the plane below the first is the halo).
#pragma omp parallel for schedule(static)
    for (long row = 0; row < long(n2) * planes; ++row) {
      const int i2 = int(row % n2), i3 = int(row / n2);
      const int j2 = (i2 - c2 + n2) % n2;
      const long j3 = slab ? long(i3) - c3 : long((i3 - c3 + n3) % n3);
      const double* src = store + std::ptrdiff_t(3) * std::ptrdiff_t(n1) * (std::ptrdiff_t(j2) + std::ptrdiff_t(n2) * j3);
      for (int i1 = 0; i1 < n1; ++i1) {
        const int j1 = (i1 - c1 + n1) % n1;
        const std::size_t y = std::size_t(row) * n1 + i1;
        for (int i = 0; i < 3; ++i) s[i * voxels + y] += float(src[3 * j1 + i]);
      }
    }
  }
#pragma omp parallel for schedule(static)
  for (std::size_t y = 0; y < voxels; ++y)
    for (int i = 0; i < 3; ++i) {
      const double Dy = s[i * voxels + y];
      s[i * voxels + y] = Dy > 0.0 && D0[i] > 0.0 ? float(std::sqrt(D0[i] / Dy)) : 1.0f;
    }
}


/// A Krylov vector of the Jacobi–Green CG: three real nodal fields (component i at u + i·voxels, the
/// storage of a spectral work vector reused) and the free macro components (load frame).
struct NodalVec {
  double* u = nullptr;
  Vec9 f = Vec9::Zero();
};

/// The Krylov space of krylov::pcg for M⁻¹ = S G₀ S on nodal vectors, over a solver `m` with the stencil
/// operator (FftRveSolver::Impl: fft3, stencil, green, stencil_tangent_product(), the halo fills,
/// global_sum(), T_load, to_grid()). Inner product ⟨a, b⟩ = Σ_y a(y)·b(y) / N + a_f·b_f, which equals
/// the half-spectrum product of the spectral space (Parseval), so the CG scalars mean the same. Per
/// iteration: p ← z + βp into fft3's real buffer, the stencil pass ∇p → δP → nodal values, the gather
/// pass Bᵀ δP with ⟨p, Kp⟩ (Kp stays in fft3's real buffer), then x += αp, r −= αKp and S r into the
/// buffer, FFT of 3 fields, G₀ per mode, FFT⁻¹ of 3 fields, z = S (G₀ S r) with ⟨r, z⟩.
template <class Solver, class MacroPrecondition>
struct JacobiGreenCgSpace {
  Solver& m;
  const std::array<bool, 9>& free;
  MacroPrecondition macro;  // z_f from r_f (the macro block of the Green preconditioner)
  const float* s;           // scaling, 3 fields of m.N

  double* buf(int i) { return m.fft3->real(i); }

  void start(const NodalVec& b, NodalVec& x, NodalVec& r) {
    const std::size_t N = m.N;
    for (int i = 0; i < 3; ++i) std::fill(x.u + i * N, x.u + (i + 1) * N, 0.0);
    x.f.setZero();
    if (r.u != b.u) std::copy(b.u, b.u + 3 * N, r.u);
    r.f = b.f;
  }
  /// z = S G₀ S r from the scaled residual already in fft3's real buffer; returns Σ r·z / N (global).
  double finish_precondition(const NodalVec& r, NodalVec& z) {
    const std::size_t N = m.N;
    m.fft3->forward();
    m.green.apply(m.fft3->spectrum(0), m.fft3->spectrum(0), double(m.Ntot));  // normalised: 1/N
    m.fft3->backward();
    double d = 0.0;
    for (int i = 0; i < 3; ++i) {
      const double* g = buf(i);
      const float* si = s + i * N;
      const double* ri = r.u + i * N;
      double* zi = z.u + i * N;
#pragma omp parallel for schedule(static) reduction(+ : d)
      for (std::size_t y = 0; y < N; ++y) {
        const double v = double(si[y]) * g[y];
        zi[y] = v;
        d += ri[y] * v;
      }
    }
    z.f = macro(r.f);
    return m.global_sum(d) / double(m.Ntot) + r.f.dot(z.f);
  }
  double precondition_dot(const NodalVec& r, NodalVec& z) {
    const std::size_t N = m.N;
    for (int i = 0; i < 3; ++i) {
      double* g = buf(i);
      const float* si = s + i * N;
      const double* ri = r.u + i * N;
#pragma omp parallel for schedule(static)
      for (std::size_t y = 0; y < N; ++y) g[y] = double(si[y]) * ri[y];
    }
    return finish_precondition(r, z);
  }
  double direction(const NodalVec& z, double beta, NodalVec& p, NodalVec& Kp) {
    const std::size_t N = m.N;
    for (int i = 0; i < 3; ++i) {
      double* g = buf(i);
      const double* zi = z.u + i * N;
      double* pi = p.u + i * N;
#pragma omp parallel for schedule(static)
      for (std::size_t y = 0; y < N; ++y) {
        const double v = beta == 0.0 ? zi[y] : zi[y] + beta * pi[y];
        pi[y] = v;
        g[y] = v;
      }
    }
    p.f = beta == 0.0 ? Vec9(z.f) : Vec9(z.f + beta * p.f);
    m.fill_displacement_halo();
    double pKp_local = 0.0;
    const Vec9 mean = m.stencil_tangent_product(flatten(m.to_grid(unflatten(p.f))), 0.0, &pKp_local);
    const double pKp = m.global_sum(pKp_local) / double(m.Ntot);
    const Vec9 ml = m.T_load * mean;
    for (int c = 0; c < 9; ++c) Kp.f[c] = free[c] ? ml[c] : 0.0;
    return pKp + p.f.dot(Kp.f);
  }
  /// Kp.u is not read: K p is in fft3's real buffer (direction()).
  double update(double alpha, const NodalVec& p, const NodalVec& Kp, NodalVec& x, NodalVec& r, NodalVec& z) {
    const std::size_t N = m.N;
    for (int i = 0; i < 3; ++i) {
      double* g = buf(i);
      const float* si = s + i * N;
      const double* pi = p.u + i * N;
      double* xi = x.u + i * N;
      double* ri = r.u + i * N;
#pragma omp parallel for schedule(static)
      for (std::size_t y = 0; y < N; ++y) {
        xi[y] += alpha * pi[y];
        ri[y] -= alpha * g[y];
        g[y] = double(si[y]) * ri[y];
      }
    }
    x.f += alpha * p.f;
    r.f -= alpha * Kp.f;
    return finish_precondition(r, z);
  }
};


/// The scaling of `m`'s stored tangents for its current reference medium m.C0 into m.jacobi_s (called
/// after each tangent evaluation, with the Green table).
template <class Solver>
void set_jacobi_scaling(Solver& m) {
  const fft::StencilGradient& st = *m.stencil;
  std::vector<double> w(std::size_t(st.points()));
  for (int q = 0; q < st.points(); ++q) w[q] = m.op.quadrature()[q].weight;
  const Eigen::Vector3d D0 = reference_diagonal(st, w, m.C0);
  const float* Tf = m.tangent_f.empty() ? nullptr : m.tangent_f.data();
  const double* T = m.tangent.data();
  // Tangents in blocks of 8 points (structure of arrays): entry idx of point p at 45·⌊p/8⌋·8 + 8 idx + p mod 8.
  auto tangent = [Tf, T](std::size_t p, int idx) {
    const std::size_t a = 45 * (p / 8 * 8) + 8 * std::size_t(idx) + p % 8;
    return Tf ? double(Tf[a]) : T[a];
  };
  auto halo = [&m](double* base, std::size_t values) {
    if (m.dist) m.dist->fill_lower_halo(base, values);
  };
  jacobi_scaling(st, w, D0, m.N, m.dist != nullptr, tangent, m.stencil_store(), halo, m.jacobi_s);
}

/// PCG with M⁻¹ = S G₀ S on K x = b (b and x spectral, as the solver's other linear solves; x starts at
/// zero) over the nodal space JacobiGreenCgSpace, in the solver's CG work vectors. x leaves without
/// components on the kernel modes of the gradient (translations, the rotated scheme's hourglass modes):
/// K does not see them, but the real-space iteration, unlike the spectral one, picks them up through S.
template <class Solver, class Vector, class MacroPrecondition>
krylov::CgResult jacobi_green_pcg(Solver& m, const Vector& b, const std::array<bool, 9>& free, MacroPrecondition macro,
                                  const krylov::Controls& controls, Vector& x) {
  using fft::Complex;
  const std::size_t N = m.N, NM = m.NM, stride = m.fft3->real_stride();
  for (auto* v : {&m.cg_r.u, &m.cg_z.u, &m.cg_p.u, &x.u}) v->resize(3 * NM);  // 6 NM ≥ 3 N doubles each
  auto nodal = [](std::vector<Complex>& v) { return reinterpret_cast<double*>(v.data()); };
  // b → nodal residual (the normalised spectrum's backward transform is the field itself).
  std::copy(b.u.begin(), b.u.end(), m.fft3->spectrum(0));
  m.fft3->backward();
  NodalVec r{nodal(m.cg_r.u), b.f}, z{nodal(m.cg_z.u), Vec9::Zero()}, p{nodal(m.cg_p.u), Vec9::Zero()}, Kp;
  NodalVec xn{nodal(x.u), Vec9::Zero()};
  for (int i = 0; i < 3; ++i) std::copy(m.fft3->real(i), m.fft3->real(i) + N, r.u + i * N);
  JacobiGreenCgSpace<Solver, MacroPrecondition> space{m, free, macro, m.jacobi_s.data()};
  const krylov::CgResult res = krylov::pcg(space, r, xn, r, z, p, Kp, controls);
  // x → spectrum, kernel modes removed.
  for (int i = 0; i < 3; ++i) std::copy(xn.u + i * N, xn.u + (i + 1) * N, m.fft3->real(0) + i * stride);
  x.f = xn.f;
  m.fft3->forward();
  const Complex* s3 = m.fft3->spectrum(0);
  const double invN = 1.0 / double(m.Ntot);
#pragma omp parallel for schedule(static)
  for (std::size_t k = 0; k < NM; ++k) {
    const bool kernel = !(m.op.laplacian(m.op.mode_offset() + k) > 0.0);
    for (int i = 0; i < 3; ++i) x.u[i * NM + k] = kernel ? Complex(0.0) : invN * s3[i * NM + k];
  }
  return res;
}

}  // namespace softhom::rve::detail
