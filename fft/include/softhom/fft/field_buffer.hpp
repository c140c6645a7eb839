#pragma once
// Real fields without a spectrum: the FieldTransform layout (field f at real(f), real_stride() values
// apart) for arrays that are never transformed as a whole.
//
// The FFT solver with the stencil Krylov operator keeps ∇ũ and P (9 · nq fields) in real space only and
// transforms them block by block (3 fields at a time) through the 3-field transform of the displacement
// and the nodal forces; a spectrum of all 9 · nq fields would be 9 · nq · 16 · modes/voxels bytes per
// voxel more (≈ 72 B per quadrature point) for nothing (BENCHMARKS.md, "FFT memory per voxel").
#include <algorithm>
#include <cstddef>
#include <memory>
#include <new>
#include <stdexcept>
#include <string>

#include "softhom/fft/plan.hpp"

namespace softhom::fft {

class FieldBuffer : public FieldTransform {
 public:
  /// `fields` fields of `stride` values each, then `spare_doubles` more (zero-initialised).
  FieldBuffer(int fields, std::size_t stride, std::size_t spare_doubles = 0)
      : fields_(fields), values_(std::size_t(fields) * stride + spare_doubles), data_(allocate(values_)) {
    std::fill(data_.get(), data_.get() + values_, 0.0);
    set_buffers(data_.get(), stride, nullptr, 0);
  }
  int fields() const override { return fields_; }
  int transformed_fields() const override { return 0; }
  void forward() override { throw std::logic_error("FieldBuffer: real fields only, no transform"); }
  void backward() override { throw std::logic_error("FieldBuffer: real fields only, no transform"); }
  std::string describe() const override { return std::to_string(fields_) + " real fields, no transform"; }
  double planning_seconds() const override { return 0.0; }

 private:
  struct Free {
    void operator()(double* p) const { ::operator delete[](p, std::align_val_t(64)); }
  };
  static std::unique_ptr<double[], Free> allocate(std::size_t n) {
    return std::unique_ptr<double[], Free>(
        static_cast<double*>(::operator new[](std::max<std::size_t>(n, 1) * sizeof(double), std::align_val_t(64))));
  }
  int fields_ = 0;
  std::size_t values_ = 0;
  std::unique_ptr<double[], Free> data_;
};

}  // namespace softhom::fft
