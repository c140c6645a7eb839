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
    : grid_(grid), disc_(discretization) {
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
      const Complex e(std::cos(angle), std::sin(angle));
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

void GradientOperator::gradient(const Complex* u, Complex* grad) const {
  const std::size_t nm = grid_.modes();
  const int nq = points();
#pragma omp parallel for schedule(static)
  for (std::size_t k = 0; k < nm; ++k) {
    Complex D[24];
    coefficients(k, D);
    const Complex ui[3] = {u[k], u[nm + k], u[2 * nm + k]};
    for (int q = 0; q < nq; ++q)
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) grad[std::size_t(9 * q + 3 * i + j) * nm + k] = D[3 * q + j] * ui[i];
  }
}

void GradientOperator::divergence(const Complex* stress, Complex* out, double scale) const {
  const std::size_t nm = grid_.modes();
  const int nq = points();
#pragma omp parallel for schedule(static)
  for (std::size_t k = 0; k < nm; ++k) {
    Complex D[24];
    coefficients(k, D);
    Complex acc[3] = {0.0, 0.0, 0.0};
    for (int q = 0; q < nq; ++q) {
      const double wq = quadrature_[q].weight;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
          acc[i] += wq * std::conj(D[3 * q + j]) * stress[std::size_t(9 * q + 3 * i + j) * nm + k];
    }
    for (int i = 0; i < 3; ++i) out[std::size_t(i) * nm + k] = scale * acc[i];
  }
}

void GradientOperator::solve_reference(const Matrix9& C0, const Complex* r, Complex* out) const {
  const std::size_t nm = grid_.modes();
  const int nq = points();
#pragma omp parallel for schedule(static)
  for (std::size_t k = 0; k < nm; ++k) {
    Complex D[24];
    coefficients(k, D);
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

}  // namespace softhom::fft
