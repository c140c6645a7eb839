#pragma once
// Real-space form of the finite-element gradients of gradient.hpp (rotated, hex) and of their adjoint.
//
// The rotated and hex symbols D_qj(k) = d_j(k_j) Π_{m≠j} v_m(ξ_qm, k_m) are products of one-step
// shifts (e^{ik_m h_m} ↔ u(x + h_m e_m)), so the gradient at point q of the voxel with lower corner x is
// an exactly local stencil on the nodal displacement (nodes = voxel corners = the real-field samples):
//
//   ∇u_q(x)_ij = Σ_c B_qcj u_i(x + c),   c ∈ {0,1}^d (the 2^d voxel corners),
//   B_qcj = (c_j ? 1 : −1)/h_j · Π_{m≠j} (c_m ? ξ_qm : 1 − ξ_qm)
//
// (the trilinear shape-function derivatives at ξ_q), and its adjoint, the nodal force of a stress field,
//
//   f_i(y) = Σ_q w_q Σ_c Σ_j B_qcj S_qij(y − c)       (Fourier: Σ_q w_q Σ_j conj(D_qj) Ŝ_qij).
//
// With these the Krylov operator of the FFT solver transforms only the three displacement fields back
// and the three nodal-force fields forward (6 field transforms instead of 12–18 for rotated or 48–144
// for hex), and the per-mode gradient/divergence passes disappear (the structure of Ladecký et al. 2023).
// Same values as the Fourier operators to round-off (tests/fft: StencilGradient.*). The spectral
// discretization has no local stencil and keeps the Fourier path.
//
// Only grids with n1, n2 > 1 are handled (sections n3 = 1: d = 2, columns j < 2; else d = 3).
#include <algorithm>
#include <array>
#include <cstddef>
#include <stdexcept>
#include <type_traits>

#include <omp.h>

#include "softhom/fft/gradient.hpp"

namespace softhom::fft {

class StencilGradient {
 public:
  /// True when `op` has a local stencil handled here (rotated/hex, n1 > 1 and n2 > 1).
  static bool supported(const GradientOperator& op);
  /// Throws std::invalid_argument when !supported(op).
  explicit StencilGradient(const GradientOperator& op);

  const Grid& grid() const { return grid_; }
  int dims() const { return dims_; }
  int points() const { return nq_; }
  /// Values per voxel that gradient_pass() writes to `store` and divergence_pass() reads: one point
  /// (rotated): its stress columns j < dims (3·dims); several points (hex): the nodal forces of the
  /// voxel's 2^d corners (3·2^d), i.e. the quadrature sum done once per voxel instead of once per node.
  int stored_values() const { return nq_ == 1 ? 3 * dims_ : 3 << dims_; }
  /// B_qcj (0 for j ≥ dims).
  double coefficient(int q, int c, int j) const { return B_[(q * 8 + c) * 3 + j]; }

  /// One slab of `planes` planes i3 (slab.hpp) instead of the whole grid: the passes run over its voxels;
  /// the three displacement fields of gradient_pass() and the force fields of divergence_pass() are
  /// field_stride() apart and carry one upper halo plane (SlabDecomposition::fill_upper_halo, after the
  /// displacement's transform), and the per-voxel store has one lower halo plane in front of the
  /// pointer handed to the passes (store − halo_store_values(); SlabDecomposition::fill_lower_halo
  /// between the passes). Periodicity along i3 is then the halos' business.
  void restrict_to_slab(int planes) {
    planes_ = planes;
    halo_ = true;
  }
  std::size_t field_stride() const {
    return padded_stride_ ? padded_stride_ : plane_voxels() * std::size_t(planes_ + (halo_ ? 1 : 0));
  }
  /// Displacement and force fields in a transform's in-place layout (one process): rows `row_pitch`
  /// values apart (FieldTransform::real_row_pitch()), fields `field_stride` apart; the per-voxel store
  /// stays dense.
  void set_padded_fields(std::size_t row_pitch, std::size_t field_stride) {
    row_pitch_ = row_pitch;
    padded_stride_ = field_stride;
  }
  std::size_t halo_store_values() const { return halo_ ? plane_voxels() * std::size_t(stored_values()) : 0; }

  /// Material points per batch of gradient_pass() (8: one 512-bit register of doubles per component).
  static constexpr int kBatch = 8;

  /// Pass 1, to be called inside a parallel region (orphaned `omp for`, static schedule over batches of
  /// kBatch consecutive material points p = v·nq + q, i.e. kBatch/nq voxels: the same voxel partition as
  /// a static loop over voxels up to one batch). `u`: three real displacement fields (component i at
  /// u + i·voxels()). For each batch: body(p0, count, grad, stress) with p0 a multiple of kBatch, count ≤
  /// kBatch points, grad[(3i + j)·kBatch + l] = ∇u_q(v)_ij of point p0 + l (structure of arrays, columns
  /// j ≥ dims are 0, lanes l ≥ count are 0); body must write stress in the same layout (columns j ≥ dims
  /// are not read). The pass then writes stored_values() per voxel (voxel-major: store[v·stored_values()
  /// + …]) for divergence_pass(). With `store` null it only hands every batch's gradient to body (what
  /// body writes to stress is not read): the solver's pointwise passes that need F but no divergence
  /// (pressure linearization, hot spots, field output).
  template <class Body>
  void gradient_pass(const double* u, double* store, Body&& body) const;

  /// True when streamed_pass() applies: one point per voxel (rotated) and slices (planes i3; rows i2 of a
  /// section) of whole batches, so that batches never straddle two slices.
  bool streams() const { return nq_ == 1 && slice_voxels() % std::size_t(kBatch) == 0; }
  /// streams() of StencilGradient(op), before it is built.
  static bool streams(const GradientOperator& op) {
    const Grid& g = op.grid();
    const std::size_t slice = g.is_section() ? std::size_t(g.n[0]) : std::size_t(g.n[0]) * std::size_t(g.n[1]);
    return supported(op) && op.points() == 1 && slice % std::size_t(kBatch) == 0;
  }
  /// Scratch of streamed_pass() for `threads` threads on grid g (values): three voxel-slice stores of
  /// 3·d values per voxel per thread (+ the one received from the rank below, on a slab).
  static std::size_t stream_scratch_values(const Grid& g, int threads, bool slab) {
    const std::size_t slice_store = g.is_section() ? 6 * std::size_t(g.n[0]) : 9 * std::size_t(g.n[0]) * std::size_t(g.n[1]);
    return (3 * std::size_t(threads) + (slab ? 1 : 0)) * slice_store;
  }
  std::size_t stream_scratch_values(int threads) const { return stream_scratch_values(grid_, threads, halo_); }

  /// Gradient → body → adjoint in one pass, in place and without a store of the grid (streams()): `uf`
  /// holds the three displacement fields on entry (layout of gradient_pass) and the nodal forces
  /// f_i(y) = Σ_c Σ_j B_cj S_ij(y − c) of the stresses body() writes on return. The grid is walked slice
  /// by slice (planes i3, rows i2 of a section); a slice's stresses are kept (as gradient_pass() stores
  /// them), node slice s is gathered from voxel slices s − 1 and s as soon as both are there and
  /// written over the displacement, which no later voxel reads. Each thread walks its own contiguous
  /// slices and keeps its first slice's stresses until its neighbour's last slice is there (a barrier).
  /// So the 9 (3D) or 6 (section) stress values per voxel are kept for three slices per thread, not for
  /// the grid: 72 B per voxel less, and the nodal forces are divergence_pass()'s to the bit.
  /// Call inside a parallel region, by every thread (barriers); `scratch` holds
  /// stream_scratch_values(omp_get_num_threads()) values shared by the team. body(p0, count, grad,
  /// stress) as for gradient_pass() (count = kBatch, p0 a multiple of kBatch); with `gradient` false
  /// grad is null and `uf` is not read (the divergence of a stress body() computes by itself). Returns
  /// this thread's share of Σ_y u(y)·f(y) when `dot` (0 otherwise).
  /// On a slab (restrict_to_slab) the last plane's voxels read the displacement's upper halo plane and
  /// the next rank's first node plane needs this rank's last plane of stresses: shift_up(send, recv,
  /// values) (the master thread calls it, SlabDecomposition::shift_up) hands this rank's to the next and
  /// the previous rank's to this one, which gathers its first node plane with them.
  template <class Body, class ShiftUp = std::nullptr_t>
  double streamed_pass(double* uf, double* scratch, Body&& body, bool gradient = true, bool dot = false,
                       ShiftUp&& shift_up = nullptr) const;

  /// Pass 2 (own parallel region): f_i(y) = Σ_q w_q Σ_c Σ_j B_qcj S_qij(y − c) from `store`; returns
  /// Σ_y Σ_i dot_with_i(y) f_i(y) (0 when dot_with is null). `f` (3 fields) may alias `dot_with`.
  double divergence_pass(const double* store, double* f, const double* dot_with) const;

 private:
  template <int D, int NQ, class Body>
  void gradient_pass_impl(const double* u, double* store, Body& body) const;
  template <int D, int NQ>
  double divergence_pass_impl(const double* store, double* f, const double* dot_with) const;

  std::size_t plane_voxels() const { return std::size_t(grid_.n[0]) * std::size_t(grid_.n[1]); }
  template <int D, class Body, class ShiftUp>
  double streamed_pass_impl(double* uf, double* scratch, Body& body, bool gradient, bool dot, ShiftUp& shift_up) const;
  /// ∇u of the kBatch voxels from v0 (one point per voxel) into g[3i + j][l]: SIMD along a row when the
  /// batch lies inside one, else voxel by voxel. n3: planes readable along i3 (periodic below that).
  template <int D>
  void batch_gradient(const double* u, std::size_t v0, int nv, int n3, double (*g)[kBatch]) const;
  /// The displacement at the 2^d corners of voxel (i1, i2, i3): uc[i][c] (periodic below n3 planes).
  template <int D>
  void corner_values(const double* u, int i1, int i2, int i3, int n3, double (*uc)[1 << D]) const;
  /// Σ_c Σ_j B_cj S_ij(y − c) at node i1 of a row from the stresses of the voxel rows vrow[r] below its
  /// corner rows r (L = 3·D values per voxel, one point): the gather of divergence_pass() and
  /// streamed_pass(), one code so that both give the same bits.
  template <int D>
  static void gather_node(const double* const* vrow, int i1, int n1, const double (*B)[D], double acc[3]) {
    constexpr int NROW = (1 << D) / 2, L = 3 * D;
    const int i1m = i1 == 0 ? n1 - 1 : i1 - 1;
    acc[0] = acc[1] = acc[2] = 0.0;
    for (int r = 0; r < NROW; ++r)
      for (int c1 = 0; c1 < 2; ++c1) {
        const int c = 2 * r + c1;
        const double* o = vrow[r] + std::size_t(L) * std::size_t(c1 ? i1m : i1);
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < D; ++j) acc[i] += B[c][j] * o[D * i + j];
      }
  }
  /// A batch's stress columns j < D (structure of arrays s[3i + j][l]) into the per-voxel store `out`
  /// (L = 3·D values per voxel, voxel-major), as divergence_pass() reads them.
  template <int D>
  static void store_stresses(const double (*s)[kBatch], int nv, double* out) {
    constexpr int L = 3 * D;
    for (int l = 0; l < nv; ++l)
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < D; ++j) out[L * l + D * i + j] = s[3 * i + j][l];
  }
  /// Slices of streamed_pass(): planes i3 (3D) or rows i2 (section), and their voxels.
  int slices() const { return dims_ == 3 ? planes_ : grid_.n[1]; }
  std::size_t slice_voxels() const { return dims_ == 3 ? plane_voxels() : std::size_t(grid_.n[0]); }


  Grid grid_;
  int planes_ = 1;     // planes i3 of the passes (all, or a slab's)
  std::size_t row_pitch_ = 0;      // values per row of the displacement/force fields (0: n1, dense)
  std::size_t padded_stride_ = 0;  // their field stride when padded (0: dense, field_stride())
  bool halo_ = false;  // slab: neighbours along i3 come from the halo planes, not from periodic wrapping
  int dims_ = 2;
  int nq_ = 1;
  std::array<double, 8> weight_{};
  std::array<double, 8 * 8 * 3> B_{};  ///< B_qcj at (q·8 + c)·3 + j
};

// ---------------------------------------------------------------------------------------------------

template <class Body>
void StencilGradient::gradient_pass(const double* u, double* store, Body&& body) const {
  if (dims_ == 2) {
    if (nq_ == 1) return gradient_pass_impl<2, 1>(u, store, body);
    return gradient_pass_impl<2, 4>(u, store, body);
  }
  if (nq_ == 1) return gradient_pass_impl<3, 1>(u, store, body);
  return gradient_pass_impl<3, 8>(u, store, body);
}

template <int D>
void StencilGradient::batch_gradient(const double* u, std::size_t v0, int nv, int n3, double (*g)[kBatch]) const {
  constexpr int NROW = (1 << D) / 2;  // corner rows (c2, c3)
  const int n1 = grid_.n[0], n2 = grid_.n[1];
  const std::size_t NU = field_stride();
  const std::size_t pitch = row_pitch_ ? row_pitch_ : std::size_t(n1);
  double B[2 * NROW][D];
  for (int c = 0; c < 2 * NROW; ++c)
    for (int j = 0; j < D; ++j) B[c][j] = coefficient(0, c, j);
  int i1 = int(v0 % n1), i2 = int((v0 / n1) % n2), i3 = int(v0 / (std::size_t(n1) * n2));
  if (nv == kBatch && i1 + kBatch <= n1) {
    // Whole batch inside one grid row (every batch when n1 % 8 == 0): the corner values of the 8
    // voxels are 9 consecutive nodes per corner row and component, so the gradient is computed
    // lane-wise (SIMD over the 8 voxels) instead of one voxel at a time with 2^d × 3 scalar corner
    // loads each (measured 11–17 % off this pass at 32³/64³; sections were already bound by the
    // tangent stream). Other batches (rows not a multiple of 8) take the scalar path below.
    for (int r = 0; r < NROW; ++r) {
      const int j2 = i2 + (r & 1) == n2 ? 0 : i2 + (r & 1);
      const int j3 = D == 3 ? (i3 + (r >> 1) == n3 ? 0 : i3 + (r >> 1)) : i3;
      const std::size_t base = pitch * (std::size_t(j2) + std::size_t(n2) * std::size_t(j3));
      const std::size_t last = base + (i1 + kBatch == n1 ? 0 : i1 + kBatch);  // node after the batch (periodic)
      for (int i = 0; i < 3; ++i) {
        const double* src = u + i * NU + base + i1;
        alignas(64) double row[kBatch + 1];
        for (int l = 0; l < kBatch; ++l) row[l] = src[l];
        row[kBatch] = u[i * NU + last];
        for (int j = 0; j < D; ++j) {
          const double b0 = B[2 * r][j], b1 = B[2 * r + 1][j];
          for (int l = 0; l < kBatch; ++l) g[3 * i + j][l] += b0 * row[l] + b1 * row[l + 1];
        }
      }
    }
    return;
  }
  for (int a = 0; a < nv; ++a) {
    double uc[3][2 * NROW];
    corner_values<D>(u, i1, i2, i3, n3, uc);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < D; ++j) {
        double acc = 0.0;
        for (int c = 0; c < 2 * NROW; ++c) acc += B[c][j] * uc[i][c];
        g[3 * i + j][a] = acc;
      }
    if (++i1 == n1) {
      i1 = 0;
      if (++i2 == n2) {
        i2 = 0;
        ++i3;
      }
    }
  }
}

template <int D>
void StencilGradient::corner_values(const double* u, int i1, int i2, int i3, int n3, double (*uc)[1 << D]) const {
  constexpr int NROW = (1 << D) / 2;
  const int n1 = grid_.n[0], n2 = grid_.n[1];
  const std::size_t NU = field_stride();
  const std::size_t pitch = row_pitch_ ? row_pitch_ : std::size_t(n1);
  // Nodes of the voxel's corners: rows (i2 + c2, i3 + c3), columns i1 and i1 + 1 (periodic).
  const int i1p = i1 + 1 == n1 ? 0 : i1 + 1;
  for (int r = 0; r < NROW; ++r) {
    const int j2 = i2 + (r & 1) == n2 ? 0 : i2 + (r & 1);
    const int j3 = D == 3 ? (i3 + (r >> 1) == n3 ? 0 : i3 + (r >> 1)) : i3;
    const std::size_t base = pitch * (std::size_t(j2) + std::size_t(n2) * std::size_t(j3));
    for (int i = 0; i < 3; ++i) {
      uc[i][2 * r] = u[i * NU + base + i1];
      uc[i][2 * r + 1] = u[i * NU + base + i1p];
    }
  }
}

template <int D, int NQ, class Body>
void StencilGradient::gradient_pass_impl(const double* u, double* store, Body& body) const {
  constexpr int NCOR = 1 << D;         // voxel corners
  constexpr bool kNodal = NQ > 1;      // store nodal forces (hex) or the stress columns (rotated)
  constexpr int L = kNodal ? 3 * NCOR : 3 * D;
  constexpr int VB = kBatch / NQ;      // voxels per batch
  // With a slab, i3 is local and the row i3 + 1 of the last plane is the halo plane (never wrapped).
  const int n1 = grid_.n[0], n2 = grid_.n[1], n3 = halo_ ? planes_ + 1 : grid_.n[2];
  const std::size_t N = plane_voxels() * std::size_t(planes_);
  double B[NQ][NCOR][D];
  for (int q = 0; q < NQ; ++q)
    for (int c = 0; c < NCOR; ++c)
      for (int j = 0; j < D; ++j) B[q][c][j] = coefficient(q, c, j);
  double w[NQ];
  for (int q = 0; q < NQ; ++q) w[q] = weight_[q];
  const long batches = long((N + VB - 1) / VB);
#pragma omp for schedule(static)
  for (long b = 0; b < batches; ++b) {
    const std::size_t v0 = std::size_t(b) * VB;
    const int nv = int(std::min<std::size_t>(VB, N - v0));
    alignas(64) double g[9][kBatch] = {}, s[9][kBatch];
    if constexpr (NQ == 1) {
      batch_gradient<D>(u, v0, nv, n3, g);
      body(v0, nv, &g[0][0], &s[0][0]);
      if (store) store_stresses<D>(s, nv, store + L * v0);
      continue;
    } else {
      int i1 = int(v0 % n1), i2 = int((v0 / n1) % n2), i3 = int(v0 / (std::size_t(n1) * n2));
      for (int a = 0; a < nv; ++a) {
        double uc[3][NCOR];
        corner_values<D>(u, i1, i2, i3, n3, uc);
        for (int q = 0; q < NQ; ++q)
          for (int i = 0; i < 3; ++i)
            for (int j = 0; j < D; ++j) {
              double acc = 0.0;
              for (int c = 0; c < NCOR; ++c) acc += B[q][c][j] * uc[i][c];
              g[3 * i + j][a * NQ + q] = acc;
            }
        if (++i1 == n1) {
          i1 = 0;
          if (++i2 == n2) {
            i2 = 0;
            ++i3;
          }
        }
      }
      body(v0 * NQ, nv * NQ, &g[0][0], &s[0][0]);
      if (!store) continue;
      for (int a = 0; a < nv; ++a) {
        double* o = store + L * (v0 + a);
        double out[L];
        for (int k = 0; k < L; ++k) out[k] = 0.0;
        for (int q = 0; q < NQ; ++q)
          for (int c = 0; c < NCOR; ++c)
            for (int i = 0; i < 3; ++i) {
              double acc = 0.0;
              for (int j = 0; j < D; ++j) acc += B[q][c][j] * s[3 * i + j][a * NQ + q];
              out[3 * c + i] += w[q] * acc;
            }
        for (int k = 0; k < L; ++k) o[k] = out[k];
      }
    }
  }
}

template <class Body, class ShiftUp>
double StencilGradient::streamed_pass(double* uf, double* scratch, Body&& body, bool gradient, bool dot,
                                      ShiftUp&& shift_up) const {
  return dims_ == 3 ? streamed_pass_impl<3>(uf, scratch, body, gradient, dot, shift_up)
                    : streamed_pass_impl<2>(uf, scratch, body, gradient, dot, shift_up);
}

template <int D, class Body, class ShiftUp>
double StencilGradient::streamed_pass_impl(double* uf, double* scratch, Body& body, bool gradient, bool dot,
                                           ShiftUp& shift_up) const {
  constexpr int NCOR = 1 << D, NROW = NCOR / 2, L = 3 * D;
  const int n1 = grid_.n[0], n2 = grid_.n[1];
  const int ns = slices();
  const std::size_t S = slice_voxels(), NU = field_stride(), SL = std::size_t(L) * S;
  const std::size_t pitch = row_pitch_ ? row_pitch_ : std::size_t(n1);
  const std::size_t slice_rows = D == 3 ? std::size_t(n2) : 1;
  // Planes along i3 the gradient reads: periodic, or a slab's and its upper halo plane (never wrapped).
  const int n3 = halo_ ? planes_ + 1 : grid_.n[2];
  double B[NCOR][D];  // one point (rotated): its weight is 1
  for (int c = 0; c < NCOR; ++c)
    for (int j = 0; j < D; ++j) B[c][j] = weight_[0] * coefficient(0, c, j);
  // Contiguous slices per thread (threads beyond the slices only meet the barriers).
  const int team = omp_get_num_threads(), t = omp_get_thread_num();
  double* received = halo_ ? scratch + std::size_t(team) * 3 * SL : nullptr;  // the rank below's last slice
  const int active = std::min(team, ns);
  auto first_slice = [&](int k) { return int(long(k) * ns / active); };
  // Three voxel-slice stores per thread (L values per voxel, as gradient_pass() stores them): the
  // thread's first slice, kept until its node slice is gathered after the barrier, and two rolling ones
  // (slices s − 1 and s). A thread's last slice ends in the first (one slice), the second (an even
  // count) or the third (an odd count > 1) store.
  auto store_of = [&](int k, int which) { return scratch + (std::size_t(k) * 3 + std::size_t(which)) * SL; };
  auto last_of = [&](int k) {
    const int count = first_slice(k + 1) - first_slice(k);
    return store_of(k, count == 1 ? 0 : (count % 2 == 0 ? 1 : 2));
  };
  // Node slice s gathered from the stores of voxel slices s − 1 (below) and s (here) in the order and
  // arithmetic of divergence_pass(), so that the nodal forces are the same to the bit: their terms are
  // large and cancel (the bulk stress of a nearly incompressible matrix), and summing each corner row's
  // neighbours first keeps the round-off of the differences, not of the terms. Written over the
  // displacement, with Σ u·f first.
  double local_dot = 0.0;
  auto gather = [&](int s, const double* below, const double* here) {
    for (std::size_t rr = 0; rr < slice_rows; ++rr) {
      const int i2 = D == 3 ? int(rr) : s;
      const double* vrow[NROW];
      for (int r = 0; r < NROW; ++r) {
        const int c2 = r & 1, c3 = r >> 1;
        if constexpr (D == 3) {
          const int j2 = (i2 - c2 + n2) % n2;
          vrow[r] = (c3 ? below : here) + std::size_t(L) * std::size_t(n1) * std::size_t(j2);
        } else {
          vrow[r] = c2 ? below : here;
        }
      }
      const std::size_t row = std::size_t(s) * slice_rows + rr;
      for (int i1 = 0; i1 < n1; ++i1) {
        double acc[3];
        gather_node<D>(vrow, i1, n1, B, acc);
        const std::size_t y = row * pitch + std::size_t(i1);
        if (dot)
          for (int i = 0; i < 3; ++i) local_dot += uf[std::size_t(i) * NU + y] * acc[i];
        for (int i = 0; i < 3; ++i) uf[std::size_t(i) * NU + y] = acc[i];
      }
    }
  };
  if (t < active) {
    const int a = first_slice(t), b = first_slice(t + 1);
    const double* prev = nullptr;
    for (int s = a; s < b; ++s) {
      double* cur = s == a ? store_of(t, 0) : store_of(t, 1 + (s - a + 1) % 2);
      for (std::size_t o = 0; o < S; o += kBatch) {
        const std::size_t v0 = std::size_t(s) * S + o;
        alignas(64) double g[9][kBatch] = {}, st[9][kBatch];
        if (gradient) batch_gradient<D>(uf, v0, kBatch, n3, g);
        body(v0, kBatch, gradient ? &g[0][0] : nullptr, &st[0][0]);
        store_stresses<D>(st, kBatch, cur + std::size_t(L) * o);
      }
      // Node slice s is complete once voxel slices s − 1 and s are stored: no voxel after them reads
      // its displacement.
      if (s > a) gather(s, prev, cur);
      prev = cur;
    }
  }
#pragma omp barrier
  if (halo_) {
    if constexpr (!std::is_same_v<std::decay_t<ShiftUp>, std::nullptr_t>) {
#pragma omp master
      shift_up(last_of(active - 1), received, SL);
    }
#pragma omp barrier
  }
  if (t < active)
    gather(first_slice(t), t == 0 && halo_ ? received : last_of((t + active - 1) % active), store_of(t, 0));
#pragma omp barrier
  return local_dot;
}

/// y = S x for a batch of StencilGradient::kBatch (8) points: S their packed symmetric 9×9 tangents
/// (upper triangle row by row, 45 entries) as a structure of arrays, S[idx·8 + l]; x and y [9][8]. The
/// lanes are the SIMD vector (4 doubles, two halves), fully unrolled so that x and y stay in registers:
/// bound by the tangent stream, not by the arithmetic (measured 256² rotated, 1 thread: 0.33 ms of
/// arithmetic, 1.1 ms of memory). Float tangents are widened on load (half the stream); x, y and the sums
/// stay double. Each has an x86-64-v3 (AVX2 + FMA) clone chosen at run time (the default build targets
/// plain x86-64).
void symmetric_product_batch(const double* __restrict S, const double* __restrict x, double* __restrict y);
void symmetric_product_batch(const float* __restrict S, const double* __restrict x, double* __restrict y);

}  // namespace softhom::fft
