// Fourier symbols of the spectral, rotated-FD and linear-hexahedron gradients (see gradient.hpp).
#include "softhom/fft/gradient.hpp"

#include <cmath>
#include <stdexcept>

#include <Eigen/Dense>

namespace softhom::fft {
namespace {
constexpr double kTwoPi = 6.283185307179586476925286766559;
}

const char* to_string(Discretization d) {
  switch (d) {
    case Discretization::spectral: return "spectral";
    case Discretization::rotated: return "rotated";
    case Discretization::hex: return "hex";
  }
  return "?";
}

Discretization parse_discretization(const std::string& name) {
  if (name == "spectral") return Discretization::spectral;
  if (name == "rotated") return Discretization::rotated;
  if (name == "hex") return Discretization::hex;
  throw std::invalid_argument("unknown discretization '" + name + "' (spectral, rotated, hex)");
}

GradientOperator::GradientOperator(const Grid& grid, Discretization discretization)
    : grid_(grid), disc_(discretization), k3_count_(grid.n[2]) {
  std::array<std::vector<double>, 3> xi, w;
  for (int m = 0; m < 3; ++m) {
    if (disc_ == Discretization::hex && grid.n[m] > 1) {
      const double g = 0.5 / std::sqrt(3.0);
      xi[m] = {0.5 - g, 0.5 + g};
      w[m] = {0.5, 0.5};
    } else {
      xi[m] = {0.5};  // a section direction (n = 1) needs one point: nothing varies along it
      w[m] = {1.0};
    }
    points_per_dim_[m] = int(xi[m].size());
    const int n = grid.n[m];
    const double h = grid.spacing(m);
    deriv_[m].resize(n);
    value_[m].resize(std::size_t(n) * xi[m].size());
    for (int k = 0; k < n; ++k) {
      const int f = grid.frequency(m, k);
      const double angle = kTwoPi * f / n;
      // e^{ikh}; exactly −1 on the Nyquist index (sin π ≠ 0 in floating point): the hourglass modes of the
      // rotated scheme (v(½, π) = 0) then have D = 0 exactly, i.e. trace 0 and a zero Green operator, as
      // in the real-space stencil (stencil.hpp). With sin π ≈ 1.2e-16 the Green operator there was ~1e32
      // and amplified the round-off of any other evaluation of the same operator.
      const Complex e = grid.is_nyquist(m, k) ? Complex(-1.0, 0.0) : Complex(std::cos(angle), std::sin(angle));
      if (disc_ == Discretization::spectral) {
        deriv_[m][k] = grid.is_nyquist(m, k) ? Complex(0.0) : Complex(0.0, kTwoPi * f / grid.size[m]);
        for (std::size_t p = 0; p < xi[m].size(); ++p) value_[m][p * n + k] = 1.0;
      } else {
        deriv_[m][k] = (e - 1.0) / h;
        for (std::size_t p = 0; p < xi[m].size(); ++p) value_[m][p * n + k] = (1.0 - xi[m][p]) + xi[m][p] * e;
      }
    }
  }
  for (int p3 = 0; p3 < points_per_dim_[2]; ++p3)
    for (int p2 = 0; p2 < points_per_dim_[1]; ++p2)
      for (int p1 = 0; p1 < points_per_dim_[0]; ++p1)
        quadrature_.push_back({{xi[0][p1], xi[1][p2], xi[2][p3]}, w[0][p1] * w[1][p2] * w[2][p3]});
}

void GradientOperator::coefficients(std::size_t mode, Complex* out) const {
  const auto k = grid_.mode_index(mode);
  const Complex d[3] = {deriv_[0][k[0]], deriv_[1][k[1]], deriv_[2][k[2]]};
  int q = 0;
  for (int p3 = 0; p3 < points_per_dim_[2]; ++p3)
    for (int p2 = 0; p2 < points_per_dim_[1]; ++p2)
      for (int p1 = 0; p1 < points_per_dim_[0]; ++p1, ++q) {
        const Complex v0 = value_[0][std::size_t(p1) * grid_.n[0] + k[0]];
        const Complex v1 = value_[1][std::size_t(p2) * grid_.n[1] + k[1]];
        const Complex v2 = value_[2][std::size_t(p3) * grid_.n[2] + k[2]];
        out[3 * q + 0] = d[0] * v1 * v2;
        out[3 * q + 1] = d[1] * v0 * v2;
        out[3 * q + 2] = d[2] * v0 * v1;
      }
}

double GradientOperator::laplacian(std::size_t mode) const {
  Complex D[24];
  coefficients(mode, D);
  double s = 0.0;
  for (int q = 0; q < points(); ++q)
    s += quadrature_[q].weight * (std::norm(D[3 * q]) + std::norm(D[3 * q + 1]) + std::norm(D[3 * q + 2]));
  return s;
}

template <class Body>
void GradientOperator::for_modes(Body&& body) const {
  const int n1 = grid_.n[0], n2 = grid_.n[1], n3 = grid_.n[2], m1 = grid_.half_n1();
  const int P1 = points_per_dim_[0], P2 = points_per_dim_[1], P3 = points_per_dim_[2];
  const long rows = long(n2) * k3_count_;
  const bool even1 = n1 % 2 == 0;
#pragma omp for schedule(static)
  for (long row = 0; row < rows; ++row) {
    const int k2 = int(row % n2), k3 = k3_begin_ + int(row / n2);
    const Complex d1 = deriv_[1][k2], d2 = deriv_[2][k3];
    Complex v1[2], v2[2];
    for (int p = 0; p < P2; ++p) v1[p] = value_[1][std::size_t(p) * n2 + k2];
    for (int p = 0; p < P3; ++p) v2[p] = value_[2][std::size_t(p) * n3 + k3];
    const std::size_t first = std::size_t(row) * m1;
    for (int k1 = 0; k1 < m1; ++k1) {
      // Same products, in the same order, as coefficients().
      Complex D[24];
      const Complex d0 = deriv_[0][k1];
      int q = 0;
      for (int p3 = 0; p3 < P3; ++p3)
        for (int p2 = 0; p2 < P2; ++p2)
          for (int p1 = 0; p1 < P1; ++p1, ++q) {
            const Complex v0 = value_[0][std::size_t(p1) * n1 + k1];
            D[3 * q + 0] = d0 * v1[p2] * v2[p3];
            D[3 * q + 1] = d1 * v0 * v2[p3];
            D[3 * q + 2] = d2 * v0 * v1[p2];
          }
      const double w = (k1 == 0 || (even1 && 2 * k1 == n1)) ? 1.0 : 2.0;
      body(first + std::size_t(k1), D, w);
    }
  }
}

void GradientOperator::gradient(const Complex* u, Complex* grad, bool all_columns) const {
  const std::size_t nm = local_modes();
  const int nq = points(), nc = all_columns ? 3 : columns();
#pragma omp parallel
  for_modes([&](std::size_t k, const Complex* D, double) {
    const Complex ui[3] = {u[k], u[nm + k], u[2 * nm + k]};
    for (int q = 0; q < nq; ++q)
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < nc; ++j) grad[std::size_t(9 * q + 3 * i + j) * nm + k] = D[3 * q + j] * ui[i];
  });
}

void GradientOperator::gradient_of_update(const Complex* z, double beta, Complex* p, Complex* grad) const {
  const std::size_t nm = local_modes();
  const int nq = points(), nc = columns();
#pragma omp parallel
  for_modes([&](std::size_t k, const Complex* D, double) {
    Complex pi[3];
    for (int i = 0; i < 3; ++i) {
      const std::size_t a = std::size_t(i) * nm + k;
      pi[i] = beta == 0.0 ? z[a] : z[a] + beta * p[a];
      p[a] = pi[i];
    }
    for (int q = 0; q < nq; ++q)
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < nc; ++j) grad[std::size_t(9 * q + 3 * i + j) * nm + k] = D[3 * q + j] * pi[i];
  });
}

void GradientOperator::divergence(const Complex* stress, Complex* out, double scale) const {
  const std::size_t nm = local_modes();
  const int nq = points(), nc = columns();
#pragma omp parallel
  for_modes([&](std::size_t k, const Complex* D, double) {
    Complex acc[3] = {0.0, 0.0, 0.0};
    for (int q = 0; q < nq; ++q) {
      const double wq = quadrature_[q].weight;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < nc; ++j)
          acc[i] += wq * std::conj(D[3 * q + j]) * stress[std::size_t(9 * q + 3 * i + j) * nm + k];
    }
    for (int i = 0; i < 3; ++i) out[std::size_t(i) * nm + k] = scale * acc[i];
  });
}

void GradientOperator::gradient_block(const Complex* ui, int q, Complex* out) const {
  const std::size_t nm = local_modes();
  const int nc = columns();
#pragma omp parallel
  for_modes([&](std::size_t k, const Complex* D, double) {
    for (int j = 0; j < nc; ++j) out[std::size_t(j) * nm + k] = D[3 * q + j] * ui[k];
  });
}

void GradientOperator::divergence_block(const Complex* stress, int q, Complex* out_i, double scale, bool accumulate) const {
  const std::size_t nm = local_modes();
  const int nc = columns();
  const double wq = quadrature_[q].weight;
#pragma omp parallel
  for_modes([&](std::size_t k, const Complex* D, double) {
    Complex acc = 0.0;
    for (int j = 0; j < nc; ++j) acc += wq * std::conj(D[3 * q + j]) * stress[std::size_t(j) * nm + k];
    out_i[k] = accumulate ? out_i[k] + scale * acc : scale * acc;
  });
}

double GradientOperator::divergence_dot(const Complex* stress, Complex* out, double scale, const Complex* x) const {
  const std::size_t nm = local_modes();
  const int nq = points(), nc = columns();
  double s = 0.0;
#pragma omp parallel reduction(+ : s)
  for_modes([&](std::size_t k, const Complex* D, double w) {
    Complex acc[3] = {0.0, 0.0, 0.0};
    for (int q = 0; q < nq; ++q) {
      const double wq = quadrature_[q].weight;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < nc; ++j)
          acc[i] += wq * std::conj(D[3 * q + j]) * stress[std::size_t(9 * q + 3 * i + j) * nm + k];
    }
    double d = 0.0;
    for (int i = 0; i < 3; ++i) {
      const Complex o = scale * acc[i];
      out[std::size_t(i) * nm + k] = o;
      d += std::real(std::conj(x[std::size_t(i) * nm + k]) * o);
    }
    s += w * d;
  });
  return s;
}

void GradientOperator::solve_reference(const Matrix9& C0, const Complex* r, Complex* out) const {
  const std::size_t nm = local_modes();
  const int nq = points();
#pragma omp parallel for schedule(static)
  for (std::size_t k = 0; k < nm; ++k) {
    Complex D[24];
    coefficients(mode_offset() + k, D);
    // M_jl = Σ_q w_q conj(D_qj) D_ql, then K0_ik = Σ_jl C0_(ij)(kl) M_jl.
    Eigen::Matrix3cd M = Eigen::Matrix3cd::Zero();
    for (int q = 0; q < nq; ++q)
      for (int j = 0; j < 3; ++j)
        for (int l = 0; l < 3; ++l) M(j, l) += quadrature_[q].weight * std::conj(D[3 * q + j]) * D[3 * q + l];
    const double trace = M.trace().real();
    const Eigen::Vector3cd rk(r[k], r[nm + k], r[2 * nm + k]);
    Eigen::Vector3cd x = Eigen::Vector3cd::Zero();
    if (trace > 0.0) {
      Eigen::Matrix3cd K0;
      for (int i = 0; i < 3; ++i)
        for (int kk = 0; kk < 3; ++kk) {
          Complex s = 0.0;
          for (int j = 0; j < 3; ++j)
            for (int l = 0; l < 3; ++l) s += C0(3 * i + j, 3 * kk + l) * M(j, l);
          K0(i, kk) = s;
        }
      // Hermitian positive definite for elliptic C0 and M ≠ 0 (kernel modes have trace 0 and stay 0).
      x = K0.inverse() * rk;
    }
    out[k] = x[0];
    out[nm + k] = x[1];
    out[2 * nm + k] = x[2];
  }
}

// ---------------------------------------------------------------------------------------------------
// ReferenceGreen

void ReferenceGreen::set(const Matrix9& C0) {
  const std::size_t nm = op_.local_modes();
  const int nq = op_.points();
  table_.resize(single_ ? 0 : kValuesPerMode * nm);
  table_f_.resize(single_ ? kValuesPerMode * nm : 0);
  double* Td = table_.data();
  float* Tf = table_f_.data();
  const bool single = single_;
#pragma omp parallel
  op_.for_modes([&](std::size_t k, const Complex* D, double) {
    // As solve_reference(), with M_jl = Σ_q w_q Re(conj(D_qj) D_ql): its imaginary part is zero but for
    // round-off (a few ulps of |D|², see the class comment), so K0_ik = Σ_jl C0_(ij)(kl) M_jl is real
    // symmetric (C0 major-symmetric) and so is its inverse: the upper triangle is kept.
    Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
    for (int q = 0; q < nq; ++q)
      for (int j = 0; j < 3; ++j)
        for (int l = 0; l < 3; ++l)
          M(j, l) += op_.quadrature_[q].weight * std::real(std::conj(D[3 * q + j]) * D[3 * q + l]);
    double t[kValuesPerMode] = {0, 0, 0, 0, 0, 0};
    if (M.trace() > 0.0) {  // else a kernel mode: the Green operator is 0 there
      Eigen::Matrix3d K0;
      for (int i = 0; i < 3; ++i)
        for (int kk = 0; kk < 3; ++kk) {
          double s = 0.0;
          for (int j = 0; j < 3; ++j)
            for (int l = 0; l < 3; ++l) s += C0(3 * i + j, 3 * kk + l) * M(j, l);
          K0(i, kk) = s;
        }
      const Eigen::Matrix3d G = K0.inverse();
      t[0] = G(0, 0);
      t[1] = G(1, 1);
      t[2] = G(2, 2);
      t[3] = G(0, 1);
      t[4] = G(0, 2);
      t[5] = G(1, 2);
    }
    for (int c = 0; c < kValuesPerMode; ++c) {
      if (single)
        Tf[kValuesPerMode * k + c] = float(t[c]);
      else
        Td[kValuesPerMode * k + c] = t[c];
    }
  });
}

namespace {
/// z = G r with G real symmetric from its packed upper triangle (double or float table, double
/// arithmetic): real times complex, 2 multiplications per term.
template <class T>
inline void green_mul(const T* t, const Complex r[3], Complex z[3]) {
  const double g00 = t[0], g11 = t[1], g22 = t[2], g01 = t[3], g02 = t[4], g12 = t[5];
  z[0] = g00 * r[0] + g01 * r[1] + g02 * r[2];
  z[1] = g01 * r[0] + g11 * r[1] + g12 * r[2];
  z[2] = g02 * r[0] + g12 * r[1] + g22 * r[2];
}
}  // namespace

void ReferenceGreen::apply(const Complex* r, Complex* out, double scale) const {
  const std::size_t nm = op_.local_modes();
  const double inv = 1.0 / scale;
  with_table([&](const auto* T) {
#pragma omp parallel for schedule(static)
    for (std::size_t k = 0; k < nm; ++k) {
      const Complex rk[3] = {r[k], r[nm + k], r[2 * nm + k]};
      Complex z[3];
      green_mul(T + kValuesPerMode * k, rk, z);
      for (int i = 0; i < 3; ++i) out[std::size_t(i) * nm + k] = inv * z[i];
    }
    return 0.0;
  });
}

double ReferenceGreen::apply_dot(const Complex* r, Complex* out, double scale) const {
  const Grid& g = op_.grid();
  const std::size_t nm = op_.local_modes(), m1 = std::size_t(g.half_n1()), rows = nm / m1;
  const bool even1 = g.n[0] % 2 == 0;
  const double inv = 1.0 / scale;
  return with_table([&](const auto* T) {
  double s = 0.0;
#pragma omp parallel for schedule(static) reduction(+ : s)
  for (std::size_t row = 0; row < rows; ++row)
    for (std::size_t k1 = 0; k1 < m1; ++k1) {
      const std::size_t k = row * m1 + k1;
      const double w = (k1 == 0 || (even1 && 2 * k1 == std::size_t(g.n[0]))) ? 1.0 : 2.0;
      const Complex rk[3] = {r[k], r[nm + k], r[2 * nm + k]};
      Complex z[3];
      green_mul(T + kValuesPerMode * k, rk, z);
      double d = 0.0;
      for (int i = 0; i < 3; ++i) {
        if (out) out[std::size_t(i) * nm + k] = inv * z[i];
        d += std::real(std::conj(rk[i]) * (inv * z[i]));
      }
      s += w * d;
    }
  return s;
  });
}

double ReferenceGreen::cg_update(double alpha, const Complex* p, const Complex* Ap, Complex* x, Complex* r, Complex* z,
                                 double scale, double ap_scale) const {
  const Grid& g = op_.grid();
  const std::size_t nm = op_.local_modes(), m1 = std::size_t(g.half_n1()), rows = nm / m1;
  const bool even1 = g.n[0] % 2 == 0;
  const double inv = 1.0 / scale;
  const double alpha_ap = alpha * ap_scale;  // = alpha when ap_scale = 1 (bit-identical to the plain update)
  return with_table([&](const auto* T) {
  double s = 0.0;
#pragma omp parallel for schedule(static) reduction(+ : s)
  for (std::size_t row = 0; row < rows; ++row)
    for (std::size_t k1 = 0; k1 < m1; ++k1) {
      const std::size_t k = row * m1 + k1;
      const double w = (k1 == 0 || (even1 && 2 * k1 == std::size_t(g.n[0]))) ? 1.0 : 2.0;
      Complex rk[3];
      for (int i = 0; i < 3; ++i) {
        const std::size_t a = std::size_t(i) * nm + k;
        x[a] += alpha * p[a];
        r[a] -= alpha_ap * Ap[a];
        rk[i] = r[a];
      }
      Complex zk[3];
      green_mul(T + kValuesPerMode * k, rk, zk);
      double d = 0.0;
      for (int i = 0; i < 3; ++i) {
        if (z) z[std::size_t(i) * nm + k] = inv * zk[i];
        d += std::real(std::conj(rk[i]) * (inv * zk[i]));
      }
      s += w * d;
    }
  return s;
  });
}

void ReferenceGreen::direction_update(const Complex* r, double beta, Complex* p, Complex* copy, double scale) const {
  const std::size_t nm = op_.local_modes();
  const double inv = 1.0 / scale;
  with_table([&](const auto* T) {
#pragma omp parallel for schedule(static)
    for (std::size_t k = 0; k < nm; ++k) {
      const Complex rk[3] = {r[k], r[nm + k], r[2 * nm + k]};
      Complex z[3];
      green_mul(T + kValuesPerMode * k, rk, z);
      for (int i = 0; i < 3; ++i) {
        const std::size_t a = std::size_t(i) * nm + k;
        const Complex zi = inv * z[i];
        const Complex v = beta == 0.0 ? zi : zi + beta * p[a];
        p[a] = v;
        copy[a] = v;
      }
    }
    return 0.0;
  });
}

namespace {
/// Real and imaginary parts of a complex number, for the per-mode arithmetic of the bulk passes
/// (written out: std::complex products carry a NaN check per product that costs more than the product).
struct Cplx {
  double re, im;
};
inline Cplx mul(Cplx a, Cplx b) { return {a.re * b.re - a.im * b.im, a.re * b.im + a.im * b.re}; }
inline Cplx as_cplx(const Complex& c) { return {c.real(), c.imag()}; }
/// ψ(k) = η·r(k)/|η|² = phase i (g·r(k)) inv for η = phase i g, inv = 1/|g|² (r: three spectra of nm modes).
inline Cplx bulk_psi(Cplx phase, const double* g, double inv, const Complex* r, std::size_t nm, std::size_t k) {
  const Cplx t = {(g[0] * r[k].real() + g[1] * r[nm + k].real() + g[2] * r[2 * nm + k].real()) * inv,
                  (g[0] * r[k].imag() + g[1] * r[nm + k].imag() + g[2] * r[2 * nm + k].imag()) * inv};
  return mul(phase, {-t.im, t.re});
}
}  // namespace

ReferenceGreen::ReferenceGreen(const GradientOperator& op) : op_(op) {
  if (op.points() != 1) return;
  for (int m = 0; m < 3; ++m) {
    const int n = op.grid_.n[m];
    half_shift_[m].resize(std::size_t(n));
    sine_[m].resize(std::size_t(n));
    cosine_[m].resize(std::size_t(n));
    for (int k = 0; k < n; ++k) {
      // rotated: d = (e^{ikh} − 1)/h and v = (1 + e^{ikh})/2 share the phase e^{ikh/2}; spectral: d = iξ, v = 1.
      const Complex p = op.disc_ == Discretization::rotated ? std::polar(1.0, 0.5 * kTwoPi * op.grid_.frequency(m, k) / n)
                                                            : Complex(1.0);
      half_shift_[m][k] = p;
      sine_[m][k] = std::imag(op.deriv_[m][k] * std::conj(p));
      cosine_[m][k] = std::real(op.value_[m][k] * std::conj(p));  // 0 on the Nyquist index, as v
    }
  }
}

/// Calls body(k, phase, g, |g|^2) for the local modes with eta = cof D(k) = phase i g, g real (one point
/// per voxel; an orphaned omp for, as for_modes). Along a row (k2, k3 fixed) only the k1 factors vary.
template <class Body>
void ReferenceGreen::for_bulk_modes(const Eigen::Matrix3d& cof, Body&& body) const {
  const GradientOperator& op = op_;
  if (op.points() != 1) throw std::logic_error("the bulk passes need one point per voxel");
  const int n2 = op.grid_.n[1], m1 = op.grid_.half_n1();
  const long rows = long(n2) * op.k3_count_;
  const Complex* p0_table = half_shift_[0].data();
  const double* s0_table = sine_[0].data();
  const double* c0_table = cosine_[0].data();
#pragma omp for schedule(static)
  for (long row = 0; row < rows; ++row) {
    const int k2 = int(row % n2), k3 = op.k3_begin_ + int(row / n2);
    const Cplx p12 = mul(as_cplx(half_shift_[1][std::size_t(k2)]), as_cplx(half_shift_[2][std::size_t(k3)]));
    const double s1 = sine_[1][std::size_t(k2)], c1 = cosine_[1][std::size_t(k2)];
    const double s2 = sine_[2][std::size_t(k3)], c2 = cosine_[2][std::size_t(k3)];
    const double c12 = c1 * c2, s1c2 = s1 * c2, c1s2 = c1 * s2;
    const std::size_t first = std::size_t(row) * m1;
    for (int k1 = 0; k1 < m1; ++k1) {
      const Cplx phase = mul(as_cplx(p0_table[k1]), p12);
      const double s0 = s0_table[k1], c0 = c0_table[k1];
      const double z0 = s0 * c12, z1 = c0 * s1c2, z2 = c0 * c1s2;
      double g[3];
      for (int i = 0; i < 3; ++i) g[i] = cof(i, 0) * z0 + cof(i, 1) * z1 + cof(i, 2) * z2;
      body(first + std::size_t(k1), phase, g, g[0] * g[0] + g[1] * g[1] + g[2] * g[2]);
    }
  }
}

void ReferenceGreen::bulk_potential(const Eigen::Matrix3d& cof, const Complex* r, Complex* psi) const {
  const std::size_t nm = op_.local_modes();
#pragma omp parallel
  for_bulk_modes(cof, [&](std::size_t k, Cplx phase, const double* g, double g2) {
    if (!(g2 > 0.0)) {
      psi[k] = 0.0;
      return;
    }
    const Cplx v = bulk_psi(phase, g, 1.0 / g2, r, nm, k);
    psi[k] = Complex(v.re, v.im);
  });
}

void ReferenceGreen::add_bulk_correction(const Eigen::Matrix3d& cof, const Complex* r, const Complex* s_hat,
                                         double s_scale, double w0, Complex* p, Complex* copy) const {
  const std::size_t nm = op_.local_modes();
#pragma omp parallel
  for_bulk_modes(cof, [&](std::size_t k, Cplx phase, const double* g, double g2) {
    if (!(g2 > 0.0)) return;
    // With ψ = phase i t, t = (g·r)/|g|², and c = (s_scale ŝ − w0 ψ)/|g|²: conj(η) c = g (conj(phase) (−i) c).
    const double inv = 1.0 / g2;
    const Cplx psi = bulk_psi(phase, g, inv, r, nm, k);
    const Cplx c = {(s_scale * s_hat[k].real() - w0 * psi.re) * inv, (s_scale * s_hat[k].imag() - w0 * psi.im) * inv};
    const Cplx q = mul({phase.re, -phase.im}, {c.im, -c.re});
    for (int i = 0; i < 3; ++i) {
      const Complex d(g[i] * q.re, g[i] * q.im);
      const std::size_t a = std::size_t(i) * nm + k;
      p[a] += d;
      if (copy) copy[a] += d;
    }
  });
}

}  // namespace softhom::fft
