// Real-space stencils of the rotated and hex gradients and their adjoint (see stencil.hpp).
#include "softhom/fft/stencil.hpp"

namespace softhom::fft {

bool StencilGradient::supported(const GradientOperator& op) {
  const Grid& g = op.grid();
  return op.discretization() != Discretization::spectral && g.n[0] > 1 && g.n[1] > 1;
}

StencilGradient::StencilGradient(const GradientOperator& op) : grid_(op.grid()), nq_(op.points()) {
  if (!supported(op))
    throw std::invalid_argument(std::string("StencilGradient: no local stencil for the ") +
                                to_string(op.discretization()) + " discretization on this grid");
  dims_ = grid_.is_section() ? 2 : 3;
  planes_ = grid_.n[2];
  // Quadrature points of gradient.hpp: 1 (rotated) or 2 per active dimension (hex), so 1, 4 or 8.
  if (!(nq_ == 1 || nq_ == (1 << dims_)))
    throw std::invalid_argument("StencilGradient: unexpected number of quadrature points");
  for (int q = 0; q < nq_; ++q) {
    const QuadraturePoint& qp = op.quadrature()[q];
    weight_[q] = qp.weight;
    for (int c = 0; c < (1 << dims_); ++c)
      for (int j = 0; j < dims_; ++j) {
        double b = 1.0;
        for (int m = 0; m < dims_; ++m) {
          const bool upper = (c >> m) & 1;
          if (m == j)
            b *= (upper ? 1.0 : -1.0) / grid_.spacing(m);
          else
            b *= upper ? qp.xi[m] : 1.0 - qp.xi[m];
        }
        B_[(q * 8 + c) * 3 + j] = b;
      }
  }
}

double StencilGradient::divergence_pass(const double* store, double* f, const double* dot_with) const {
  if (dims_ == 2) return nq_ == 1 ? divergence_pass_impl<2, 1>(store, f, dot_with) : divergence_pass_impl<2, 4>(store, f, dot_with);
  return nq_ == 1 ? divergence_pass_impl<3, 1>(store, f, dot_with) : divergence_pass_impl<3, 8>(store, f, dot_with);
}

template <int D, int NQ>
double StencilGradient::divergence_pass_impl(const double* store, double* f, const double* dot_with) const {
  constexpr int NCOR = 1 << D, NROW = NCOR / 2;
  constexpr bool kNodal = NQ > 1;
  constexpr int L = kNodal ? 3 * NCOR : 3 * D;
  const int n1 = grid_.n[0], n2 = grid_.n[1], n3 = grid_.n[2];
  const std::size_t N = field_stride();  // stride of the force fields (voxels, + a halo plane on a slab)
  const std::size_t pitch = row_pitch_ ? row_pitch_ : std::size_t(n1);
  double B[NCOR][D];  // one point (rotated): its weight is 1
  for (int c = 0; c < NCOR; ++c)
    for (int j = 0; j < D; ++j) B[c][j] = weight_[0] * coefficient(0, c, j);
  const long rows = long(n2) * planes_;
  double dot = 0.0;
#pragma omp parallel for schedule(static) reduction(+ : dot)
  for (long row = 0; row < rows; ++row) {
    const int i2 = int(row % n2), i3 = int(row / n2);
    const double* vrow[NROW];  // voxel row (i2 − c2, i3 − c3) of the corner rows
    for (int r = 0; r < NROW; ++r) {
      // (slab: the row i3 − 1 of the first plane is the lower halo plane in front of `store`)
      const int j2 = (i2 - (r & 1) + n2) % n2,
                j3 = D == 3 ? (halo_ ? i3 - (r >> 1) : (i3 - (r >> 1) + n3) % n3) : i3;
      vrow[r] = store + std::ptrdiff_t(L) * std::ptrdiff_t(n1) * (std::ptrdiff_t(j2) + std::ptrdiff_t(n2) * j3);
    }
    double local = 0.0;
    for (int i1 = 0; i1 < n1; ++i1) {
      double acc[3] = {0.0, 0.0, 0.0};
      if constexpr (kNodal) {
        const int i1m = i1 == 0 ? n1 - 1 : i1 - 1;
        for (int r = 0; r < NROW; ++r)
          for (int c1 = 0; c1 < 2; ++c1) {
            const int c = 2 * r + c1;
            const double* o = vrow[r] + std::size_t(L) * std::size_t(c1 ? i1m : i1);
            for (int i = 0; i < 3; ++i) acc[i] += o[3 * c + i];
          }
      } else {
        gather_node<D>(vrow, i1, n1, B, acc);
      }
      const std::size_t y = std::size_t(row) * pitch + i1;
      if (dot_with)
        for (int i = 0; i < 3; ++i) local += dot_with[i * N + y] * acc[i];
      for (int i = 0; i < 3; ++i) f[i * N + y] = acc[i];
    }
    dot += local;
  }
  return dot;
}

namespace {
template <class T>
[[gnu::always_inline]] inline void batch_product(const T* __restrict S, const double* __restrict x, double* __restrict y) {
  typedef double v4 __attribute__((vector_size(32), aligned(8)));
  typedef T v4t __attribute__((vector_size(4 * sizeof(T)), aligned(sizeof(T))));
  for (int h = 0; h < 2; ++h) {
    v4 xv[9], out[9];
#pragma GCC unroll 9
    for (int a = 0; a < 9; ++a) {
      xv[a] = *reinterpret_cast<const v4*>(x + a * 8 + 4 * h);
      out[a] = v4{0.0, 0.0, 0.0, 0.0};
    }
    int idx = 0;
#pragma GCC unroll 9
    for (int a = 0; a < 9; ++a) {
      out[a] += __builtin_convertvector(*reinterpret_cast<const v4t*>(S + idx * 8 + 4 * h), v4) * xv[a];
      ++idx;
#pragma GCC unroll 8
      for (int b = a + 1; b < 9; ++b, ++idx) {
        const v4 t = __builtin_convertvector(*reinterpret_cast<const v4t*>(S + idx * 8 + 4 * h), v4);
        out[a] += t * xv[b];
        out[b] += t * xv[a];
      }
    }
#pragma GCC unroll 9
    for (int a = 0; a < 9; ++a) *reinterpret_cast<v4*>(y + a * 8 + 4 * h) = out[a];
  }
}
}  // namespace

__attribute__((target_clones("arch=x86-64-v3", "default"))) void symmetric_product_batch(
    const double* __restrict S, const double* __restrict x, double* __restrict y) {
  batch_product(S, x, y);
}

__attribute__((target_clones("arch=x86-64-v3", "default"))) void symmetric_product_batch(
    const float* __restrict S, const double* __restrict x, double* __restrict y) {
  batch_product(S, x, y);
}

}  // namespace softhom::fft
