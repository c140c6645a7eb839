#pragma once
// Grids distributed over MPI ranks in slabs of the slowest index i3 (FFTW-MPI), and their transforms.
//
// Layout. Rank r owns the planes i3 ∈ [begin, begin + count) of every real field and the planes
// k3 ∈ [begin, begin + count) of every half spectrum (FFTW-MPI's default block ⌈n3/P⌉, so the last ranks
// may own fewer planes, or none). Both are stored compactly exactly as the serial arrays restricted to
// those planes: real index i1 + n1 (i2 + n2 i3_local), spectrum index k1 + m1 (k2 + n2 k3_local). The
// local voxels and modes are therefore one contiguous range of the serial arrays, starting at
// voxel_offset() and mode_offset(): every per-voxel and per-mode kernel of the serial code runs unchanged
// on that range (mode weights depend on k1 only, which the offset, a multiple of m1, keeps).
//
// The spectrum is not transposed (no FFTW_MPI_TRANSPOSED_OUT): a transposed spectrum (distributed over
// k2) would save one of the two all-to-all transposes per transform, but every per-mode kernel
// (gradient symbols, Green operator, weighted dots, residual norm) would need a second, k2-slowest
// indexing. Keeping the serial order costs 2× the transpose volume (measured and modelled in
// BENCHMARKS.md, "Distributed FFT cells") and keeps one code path for the spectra.
//
// FFTW-MPI's r2c works on an interleaved (howmany fields per point), padded real array (the fastest
// dimension padded to 2 m1); SlabFFT packs the compact field-major buffers into it and back, so that no
// padding or interleaving reaches the solvers.
#include <mpi.h>

#include <cstddef>
#include <string>
#include <vector>

#include "softhom/fft/grid.hpp"
#include "softhom/fft/plan.hpp"

namespace softhom::fft {

/// The planes i3 (real) / k3 (spectrum) one rank owns.
struct Slab {
  int begin = 0, count = 0;
};

class SlabDecomposition {
 public:
  /// The slabs of FFTW-MPI's default block distribution of `grid` over `comm` (collective).
  /// Throws std::invalid_argument when the grid is a section (n3 = 1) or has fewer planes than ranks.
  SlabDecomposition(const Grid& grid, MPI_Comm comm);

  const Grid& grid() const { return grid_; }
  MPI_Comm comm() const { return comm_; }
  int rank() const { return rank_; }
  int size() const { return size_; }
  const Slab& slab() const { return slabs_[rank_]; }
  const Slab& slab(int rank) const { return slabs_[rank]; }
  std::size_t plane_voxels() const { return std::size_t(grid_.n[0]) * grid_.n[1]; }
  std::size_t plane_modes() const { return std::size_t(grid_.half_n1()) * grid_.n[1]; }
  std::size_t local_voxels() const { return plane_voxels() * slab().count; }
  std::size_t local_modes() const { return plane_modes() * slab().count; }
  std::size_t voxel_offset() const { return plane_voxels() * slab().begin; }
  std::size_t mode_offset() const { return plane_modes() * slab().begin; }
  /// Planes, voxels and modes of the largest slab (memory and benchmark figures).
  int max_planes() const;

  // Reductions: every rank gets bit-identical results. The per-rank partial sums are gathered and added
  // in rank order (not left to MPI_Allreduce, whose summation order may differ between ranks for
  // non-power-of-two rank counts): identical macro quantities and control flow on every rank.
  double sum(double local) const;
  void sum(double* values, int count) const;
  int max(int local) const;
  /// Every rank's `count` values, rank after rank, into `all` (size() · count values).
  void all_gather(const double* mine, int count, double* all) const;
  /// The smallest `value` over ranks and its `where` (lowest rank on ties); both in/out.
  void min_location(double& value, std::size_t& where) const;

  /// Halo of the stencil gradient: `fields` real fields, field f at base + f·stride, each with
  /// count + 1 planes, the last a halo: it receives the first plane of the next rank holding planes
  /// (periodic, the last rank gets plane 0). Collective.
  void fill_upper_halo(double* base, std::size_t stride, int fields) const;
  /// Halo of its adjoint: `values` per plane, stored plane-major from base − values (halo plane) on;
  /// the halo receives the last plane of the previous rank holding planes (periodic). Collective.
  void fill_lower_halo(double* base, std::size_t values) const;
  /// `values` from `send` to the next rank holding planes, into `recv` from the previous one (periodic:
  /// what the upper neighbour's first plane needs from this rank's last). Collective.
  void shift_up(const double* send, double* recv, std::size_t values) const;

 private:
  Grid grid_;
  MPI_Comm comm_;
  int rank_ = 0, size_ = 1;
  std::vector<Slab> slabs_;
  int next_ = MPI_PROC_NULL, prev_ = MPI_PROC_NULL;  // neighbours among the ranks that hold planes
  mutable std::vector<double> send_, recv_;
  mutable std::vector<double> gather_;
};

/// FieldTransform of BatchedFFT over a SlabDecomposition: `fields` compact real fields of
/// local_voxels() (+ `halo_planes` · plane_voxels(), an upper halo for fill_upper_halo()) values each,
/// spectra of local_modes() each; `columns` as in BatchedFFT. `spare_doubles` extra values are
/// allocated after the real fields (scratch of the stencil operator, which keeps a lower halo plane).
/// One interleaved FFTW-MPI plan per direction for all transformed fields (one all-to-all per
/// transpose, whatever the field count). forward() preserves the real buffer, backward() the spectrum.
class SlabFFT : public FieldTransform {
 public:
  SlabFFT(const SlabDecomposition& slabs, int fields, const PlanOptions& options = {}, int columns = 3,
          int halo_planes = 0, std::size_t spare_doubles = 0);
  ~SlabFFT() override;
  SlabFFT(const SlabFFT&) = delete;
  SlabFFT& operator=(const SlabFFT&) = delete;

  int fields() const override { return fields_; }
  int transformed_fields() const override { return int(transformed_.size()); }
  void forward() override;
  void backward() override;
  std::string describe() const override;
  double planning_seconds() const override { return planning_seconds_; }
  /// Bytes this rank sends (and receives) per forward() or backward(): FFTW's two transposes of the
  /// non-local part of the interleaved spectrum.
  std::size_t transpose_bytes() const;
  std::size_t buffer_bytes() const;

 private:
  const SlabDecomposition& slabs_;
  int fields_ = 0, threads_ = 1;
  PlanRigor rigor_;
  std::vector<int> transformed_;   // field indices handed to FFTW, in order
  std::size_t real_stride_ = 0;
  double* real_ = nullptr;         // compact fields (+ halo planes, + spare)
  Complex* spectrum_ = nullptr;    // compact spectra
  double* work_ = nullptr;         // FFTW's interleaved padded buffer (in place)
  std::size_t work_doubles_ = 0;
  void* forward_plan_ = nullptr;
  void* backward_plan_ = nullptr;
  double planning_seconds_ = 0.0;
};

}  // namespace softhom::fft
