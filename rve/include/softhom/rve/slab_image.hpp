#pragma once
// The phase image one rank of a distributed FFT cell holds (FftSolverOptions::distributed): the planes
// i3 of its FFTW-MPI slab and one halo plane each side, so that per-rank memory is O(voxels / ranks)
// from the image on (a whole image is 40 B per voxel with normals: 5.4 GB per rank at 512³).
#include <array>
#include <optional>

#include "softhom/rve/geometry.hpp"

namespace softhom::rve {

/// Planes i3 ∈ [begin, begin + count) of a slab.
struct SlabPlanes {
  int begin = 0, count = 0;
};

/// Halo planes of a slab image: one each side for the −∇φ normal estimate of composite voxels.
constexpr int kSlabImageHalo = 1;

/// This rank's planes in a distributed FFT solve of an n1 × n2 × n3 grid (MPI active with more than one
/// rank: the slabs of fft::SlabDecomposition over MPI_COMM_WORLD, as the solver makes them), nullopt
/// when the cell is solved by one process (no MPI, one rank). Collective. A grid that cannot be
/// distributed (a section, fewer planes than ranks) is the solver's InputError on microstructure.grid.
std::optional<SlabPlanes> distributed_planes(const std::array<int, 3>& n);

/// What a rank needs of a whole image: its slab_of() when distributed, else the image itself.
PhaseImage rank_image(PhaseImage whole);

}  // namespace softhom::rve
