#pragma once
// Batched, multithreaded real-to-complex FFTs of many fields on one grid (FFTW3 + OpenMP threads).
//
// A BatchedFFT owns its buffers (FFTW-aligned) and two plans made once, at construction: forward
// (real → half spectrum) and backward (half spectrum → real). Reuse it for every transform on the
// grid. Plans are made with FFTW_MEASURE by default; wisdom can be cached on disk so that the
// measurement is paid once per machine.
#include <complex>
#include <cstddef>
#include <filesystem>
#include <string>

#include "softhom/fft/grid.hpp"

namespace softhom::fft {

using Complex = std::complex<double>;

enum class PlanRigor { estimate, measure, patient };

/// "estimate", "measure" or "patient" (the [solver] fftw value).
inline const char* to_string(PlanRigor r) {
  switch (r) {
    case PlanRigor::estimate: return "estimate";
    case PlanRigor::measure: return "measure";
    case PlanRigor::patient: return "patient";
  }
  return "?";
}

/// Field buffers and their transforms, whatever computes them: BatchedFFT (one process) or SlabFFT
/// (slab.hpp, FFTW-MPI slabs). Field f of the real buffer starts at real(f) (real_stride() values
/// apart), its spectrum at spectrum(f) (spectrum_stride() apart); the accessors are not virtual so that
/// the solvers' voxel loops pay nothing for the choice.
class FieldTransform {
 public:
  virtual ~FieldTransform() = default;
  double* real(int field = 0) { return real_base_ + std::size_t(field) * real_stride_; }
  Complex* spectrum(int field = 0) { return spectrum_base_ + std::size_t(field) * spectrum_stride_; }
  std::size_t real_stride() const { return real_stride_; }
  std::size_t spectrum_stride() const { return spectrum_stride_; }
  /// Grid transforms (BatchedFFT, SlabFFT): values from one grid row (fixed i2, i3) of a real field to the
  /// next, n1 (dense) or 2 (n1/2 + 1) for an in-place transform (the real rows padded to the length of a
  /// half-spectrum row).
  std::size_t real_row_pitch() const { return row_pitch_; }
  bool padded_rows() const { return row_pitch_ != row_length_; }
  /// Position in a real field of voxel v (i1 fastest).
  std::size_t real_index(std::size_t v) const { return v + (v / row_length_) * (row_pitch_ - row_length_); }
  virtual int fields() const = 0;
  virtual int transformed_fields() const = 0;
  virtual void forward() = 0;
  virtual void backward() = 0;
  virtual std::string describe() const = 0;
  virtual double planning_seconds() const = 0;

 protected:
  void set_buffers(double* real, std::size_t real_stride, Complex* spectrum, std::size_t spectrum_stride) {
    real_base_ = real;
    real_stride_ = real_stride;
    spectrum_base_ = spectrum;
    spectrum_stride_ = spectrum_stride;
  }
  void set_rows(std::size_t length, std::size_t pitch) {
    row_length_ = length;
    row_pitch_ = pitch;
  }

 private:
  double* real_base_ = nullptr;
  Complex* spectrum_base_ = nullptr;
  std::size_t real_stride_ = 0, spectrum_stride_ = 0;
  std::size_t row_length_ = 1, row_pitch_ = 1;
};

struct PlanOptions {
  PlanRigor rigor = PlanRigor::measure;
  int threads = 0;                     ///< 0: omp_get_max_threads()
  std::filesystem::path wisdom_file;   ///< empty: no wisdom cache; else imported before and saved after planning
};

class BatchedFFT : public FieldTransform {
 public:
  /// `fields` real fields of grid.voxels() values each; spectra of grid.modes() values each.
  /// `columns` < 3: the fields are 3×3 tensors (field = 9 t + 3 i + j, fields % 9 == 0) and only the
  /// columns j < `columns` are transformed; the others are left untouched in both buffers. On a
  /// section grid the gradient has no j = 3 column and the divergence does not read it, so the
  /// solver transforms 6 of 9 fields.
  /// `in_place` (columns = 3 only): the real fields live in the spectrum buffer, their rows padded to
  /// real_row_pitch() = 2 (n1/2 + 1) values (FFTW's in-place layout), which saves the real buffer (8 B per
  /// voxel and field); forward() then destroys the real fields.
  BatchedFFT(const Grid& grid, int fields, const PlanOptions& options = {}, int columns = 3, bool in_place = false);
  ~BatchedFFT() override;
  BatchedFFT(const BatchedFFT&) = delete;
  BatchedFFT& operator=(const BatchedFFT&) = delete;

  const Grid& grid() const { return grid_; }
  int fields() const override { return fields_; }
  /// Fields actually transformed per forward()/backward() (fields · columns / 3).
  int transformed_fields() const override { return fields_ / 3 * columns_ + (columns_ == 3 ? fields_ % 3 : 0); }
  Complex* spectrum(int field = 0) { return spectrum_ + std::size_t(field) * grid_.modes(); }
  bool in_place() const { return in_place_; }

  /// real → spectrum, unnormalised (x̂_k = Σ_x x e^{−ik·x}); the real buffer is preserved (not in place).
  void forward() override;
  /// spectrum → real, unnormalised (x = Σ_k x̂_k e^{ik·x}); the spectrum buffer is destroyed.
  void backward() override;

  /// Human-readable plan description ("fftw3 r2c 9 x 64x64x1, 2 threads, measure").
  std::string describe() const override;
  double planning_seconds() const override { return planning_seconds_; }

 private:
  Grid grid_;
  int fields_ = 0;
  int threads_ = 1;
  int columns_ = 3;
  bool in_place_ = false;
  PlanRigor rigor_;
  double* real_ = nullptr;
  Complex* spectrum_ = nullptr;
  void* forward_plan_ = nullptr;
  void* backward_plan_ = nullptr;
  double planning_seconds_ = 0.0;
};

}  // namespace softhom::fft
