#pragma once
// Tangents of the stencil Krylov operator in compact form (materials/compact_linearization.hpp): the
// pure points of phases whose law has a compact linearization store F and five scalars (14 floats) and
// the product δF ↦ δP is formed on the fly; the composite (laminate) points, whose condensed tangent has
// no such form, keep the packed symmetric 9×9 tangent (45 floats), indexed by composite point. Per point
// 56 B instead of 180 B, and a lighter stream per Krylov iteration (the product is bound by it).
#include <cstddef>
#include <vector>

#include "softhom/materials/compact_linearization.hpp"
#include "softhom/materials/tensor.hpp"

namespace softhom::rve::detail {

class CompactTangents {
 public:
  static constexpr int kBatch = 8;  // points per block (the stencil pass's batch)

  /// `points` material points, `composite_points` of them composite (their full tangents).
  CompactTangents(std::size_t points, std::size_t composite_points)
      : records_(std::size_t(kCompactValues) * ((points + kBatch - 1) / kBatch * kBatch), 0.0f),
        full_(45 * composite_points, 0.0f) {}

  std::size_t record_values() const { return records_.size(); }
  std::size_t full_values() const { return full_.size(); }

  /// Pure point p: F and its compact linearization.
  void store(std::size_t p, const Mat3& F, const CompactLinearization& L) {
    store_compact_record(&records_[kCompactValues * (p - p % kBatch)], int(p % kBatch), F, L);
  }
  /// Pure point p: F alone (its record's F, as store() writes it; the five scalars are left as they are).
  /// The mixed (u, p) iteration keeps the F of each evaluation here, also without a tangent.
  void store_F(std::size_t p, const Mat3& F) {
    float* block = &records_[kCompactValues * (p - p % kBatch)] + p % kBatch;
    for (int c = 0; c < 9; ++c) block[kBatch * c] = float(F(c / 3, c % 3));
  }
  /// The F of pure point p's record (rounded to float, widened).
  Mat3 F(std::size_t p) const {
    const float* block = &records_[kCompactValues * (p - p % kBatch)] + p % kBatch;
    Mat3 F;
    for (int c = 0; c < 9; ++c) F(c / 3, c % 3) = double(block[kBatch * c]);
    return F;
  }
  /// Composite point c (composite index · points per voxel + q): the packed symmetric tangent (upper
  /// triangle row by row, symmetrized as for the stored tangents).
  void store_full(std::size_t c, const Mat9& A) {
    float* S = &full_[45 * c];
    int idx = 0;
    for (int a = 0; a < 9; ++a) {
      S[idx++] = float(A(a, a));
      for (int b = a + 1; b < 9; ++b) S[idx++] = float(0.5 * (A(a, b) + A(b, a)));
    }
  }

  /// δP of the batch of points p0 … p0 + 7 (dF, dP [9][8] as in fft::StencilGradient::gradient_pass).
  /// `composite(l)` returns the composite point of lane l or −1: those lanes take the full tangent
  /// (their compact record is zero, so the compact product gives 0 there).
  template <class CompositeOf>
  void product(std::size_t p0, int count, const double* dF, double* dP, CompositeOf&& composite) const {
    compact_product_batch(&records_[kCompactValues * p0], dF, dP);
    for (int l = 0; l < count; ++l) {
      const long c = composite(l);
      if (c < 0) continue;
      const float* S = &full_[45 * std::size_t(c)];
      double out[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
      int idx = 0;
      for (int a = 0; a < 9; ++a) {
        double acc = double(S[idx++]) * dF[a * kBatch + l];
        for (int b = a + 1; b < 9; ++b, ++idx) {
          acc += double(S[idx]) * dF[b * kBatch + l];
          out[b] += double(S[idx]) * dF[a * kBatch + l];
        }
        out[a] += acc;
      }
      for (int a = 0; a < 9; ++a) dP[a * kBatch + l] = out[a];
    }
  }

 private:
  std::vector<float> records_;  // blocks of 8 points, structure of arrays (compact_product_batch)
  std::vector<float> full_;     // 45 per composite point
};

}  // namespace softhom::rve::detail
