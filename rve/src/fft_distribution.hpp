#pragma once
// The distributed FFT solver's layer of local ranges and reductions (fft/slab.hpp).
//
// A distributed FftRveSolver keeps, per rank, the voxels of its planes i3 and the modes of its planes
// k3: contiguous sub-ranges of the serial arrays, so every voxel and mode loop of the solver runs as
// before on local sizes. What makes the result global is here: the volume averages, phase sums and
// inner products are local sums followed by one SlabDecomposition::sum (rank-ordered, identical on every
// rank), so the macro unknowns, the Krylov coefficients and every convergence decision are the same
// numbers on all ranks. Only normalisations use the global voxel count.
#include <mpi.h>

#include <cmath>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "softhom/fft/slab.hpp"
#include "softhom/core/mpi.hpp"
#include "diagnostics.hpp"
#include "softhom/rve/fft_solver.hpp"
#include "softhom/rve/geometry.hpp"
#include "softhom/materials/errors.hpp"

namespace softhom::rve::detail {

/// The slabs of MPI_COMM_WORLD for a distributed solve, or null for the one-process solver (not asked,
/// MPI inactive, or one rank: then the serial transforms run, bit for bit). A section grid or a grid
/// with fewer planes than ranks is an InputError on microstructure.grid (every rank throws it).
inline std::unique_ptr<fft::SlabDecomposition> make_slabs(const fft::Grid& grid, bool distributed,
                                                          const std::string& grid_text) {
  if (!distributed || !mpi::active()) return nullptr;
  const int ranks = mpi::world_size();
  if (ranks == 1) return nullptr;
  if (grid.is_section())
    throw InputError("microstructure.grid", grid_text,
                     "a 2D section grid (n3 = 1) is solved on one rank; run it without mpirun, not on " +
                         std::to_string(ranks) + " ranks");
  if (grid.n[2] < ranks)
    throw InputError("microstructure.grid", grid_text,
                     std::to_string(grid.n[2]) + " planes i3 cannot be distributed over " + std::to_string(ranks) +
                         " ranks (at least one plane per rank: use at most " + std::to_string(grid.n[2]) + " ranks)");
  return std::make_unique<fft::SlabDecomposition>(grid, MPI_COMM_WORLD);
}

/// The phase image a rank of `slabs` reads: a slab image of exactly its planes (extrude_planes(),
/// slab_of(), one halo plane for −∇φ normal estimates), or a whole image (its planes are then taken from
/// it). Throws std::invalid_argument for a slab image of other planes.
inline void check_slab_image(const PhaseImage& image, const fft::SlabDecomposition* slabs) {
  if (!image.is_slab()) return;
  if (!slabs)
    throw std::invalid_argument("a slab phase image (planes " + std::to_string(image.plane_begin) + "+" +
                                std::to_string(image.plane_count) + ") needs the distributed solver");
  if (image.plane_begin != slabs->slab().begin || image.plane_count != slabs->slab().count ||
      (image.plane_count > 0 && image.halo < 1))
    throw std::invalid_argument("the slab phase image (planes " + std::to_string(image.plane_begin) + "+" +
                                std::to_string(image.plane_count) + ", halo " + std::to_string(image.halo) +
                                ") is not this rank's slab (" + std::to_string(slabs->slab().begin) + "+" +
                                std::to_string(slabs->slab().count) + ", halo 1)");
}

/// The first fiber fraction outside [0, 1] of any rank (lowest rank first), or nullopt when there is none
/// anywhere (collective: the same answer, hence the same InputError, on every rank).
inline std::optional<double> first_bad_fraction(const fft::SlabDecomposition& slabs, std::optional<double> mine) {
  const double flag_value[2] = {mine ? 1.0 : 0.0, mine ? *mine : 0.0};
  std::vector<double> all(2 * std::size_t(slabs.size()));
  slabs.all_gather(flag_value, 2, all.data());
  for (int r = 0; r < slabs.size(); ++r)
    if (all[2 * r] != 0.0) return all[2 * r + 1];
  return std::nullopt;
}

/// The fiber fractions of voxels of the whole grid on every rank, each from the rank that owns it (`phi`:
/// the fraction of its slab's local voxel, `held` voxels from voxel v0 on), summed over the ranks: exact,
/// as one term is non-zero. Collective (failure messages name voxels with their fraction).
template <class FractionOfLocal>
std::vector<double> fractions_of(const fft::SlabDecomposition& slabs, const FractionOfLocal& phi, std::size_t held,
                                 std::size_t v0, const std::vector<std::size_t>& voxels) {
  std::vector<double> f(voxels.size(), 0.0);
  for (std::size_t k = 0; k < voxels.size(); ++k)
    if (voxels[k] >= v0 && voxels[k] < v0 + held) f[k] = phi(voxels[k] - v0);
  slabs.sum(f.data(), int(f.size()));
  return f;
}

/// Sums every additive member of a pass's PassSums over the ranks; the smallest limit margins keep
/// their (global) voxel.
template <class Sums>
void reduce_pass_sums(Sums& s, const fft::SlabDecomposition& slabs) {
  // One list of the additive members, walked to pack them and again to unpack the sums.
  auto each_member = [&s](auto&& f) {
    f(s.P);
    f(s.A);
    for (int x = 0; x < 2; ++x) {
      f(s.phase_A[x]);
      f(s.phase_A_w[x]);
      f(s.phase_P[x]);
      f(s.phase_F[x]);
      f(s.phase_PFt[x]);
      f(s.phase_J[x]);
      f(s.phase_w[x]);
    }
  };
  std::vector<double> b;
  b.reserve(400);
  each_member([&](auto& m) {
    if constexpr (std::is_arithmetic_v<std::decay_t<decltype(m)>>) b.push_back(m);
    else b.insert(b.end(), m.data(), m.data() + m.size());
  });
  slabs.sum(b.data(), int(b.size()));
  std::size_t k = 0;
  each_member([&](auto& m) {
    if constexpr (std::is_arithmetic_v<std::decay_t<decltype(m)>>) m = b[k++];
    else
      for (int i = 0; i < int(m.size()); ++i) m.data()[i] = b[k++];
  });
  for (int x = 0; x < 2; ++x) slabs.min_location(s.margin[x], s.margin_at[x]);
}

/// The hot spots of all ranks (each computed on its slab with global voxel indices; force_rms over its
/// `local_voxels`): extremes with their voxel (lowest rank on ties), counts summed, rms over all voxels.
inline void reduce_hot_spots(HotSpots& h, const fft::SlabDecomposition& slabs, std::size_t local_voxels) {
  constexpr int K = 12;
  const double mine[K] = {h.margin, double(h.v_margin), h.margin_composite ? 1.0 : 0.0, h.J_min, double(h.v_J_min),
                          h.J_max, h.p_max, double(h.v_p), h.force_max, double(h.v_force),
                          h.force_rms * h.force_rms * double(local_voxels), double(h.near_limit)};
  std::vector<double> all(std::size_t(K) * slabs.size());
  slabs.all_gather(mine, K, all.data());
  double s2 = 0.0;
  int near = 0;
  for (int r = 0; r < slabs.size(); ++r) {
    const double* a = &all[std::size_t(K) * r];
    if (r == 0 || a[0] < h.margin) {
      h.margin = a[0];
      h.v_margin = std::size_t(a[1]);
      h.margin_composite = a[2] != 0.0;
    }
    if (r == 0 || a[3] < h.J_min) {
      h.J_min = a[3];
      h.v_J_min = std::size_t(a[4]);
    }
    if (r == 0 || a[5] > h.J_max) h.J_max = a[5];
    if (r == 0 || a[6] > h.p_max) {
      h.p_max = a[6];
      h.v_p = std::size_t(a[7]);
    }
    if (r == 0 || a[8] > h.force_max) {
      h.force_max = a[8];
      h.v_force = std::size_t(a[9]);
    }
    s2 += a[10];
    near += int(a[11]);
  }
  h.force_rms = std::sqrt(s2 / double(slabs.grid().voxels()));
  h.near_limit = near;
}

/// Corner displacements of this rank's planes i3 (the last rank's also of i3 = n3, from the upper halo
/// of ũ): ũ in fields 0, step, 2·step of t, as node_displacement() leaves it.
inline std::vector<double> slab_node_displacement(const fft::SlabDecomposition& d, fft::FieldTransform& t, int step,
                                                const fft::Grid& grid, const Mat3& G) {
  const std::array<int, 3>& n = grid.n;
  const std::size_t plane = d.plane_voxels(), count = std::size_t(d.slab().count), stride = plane * (count + 1);
  std::vector<double> uh(3 * stride, 0.0);
  for (int i = 0; i < 3; ++i) std::copy(t.real(step * i), t.real(step * i) + plane * count, uh.data() + i * stride);
  d.fill_upper_halo(uh.data(), stride, 3);
  const bool last = d.slab().count > 0 && d.slab().begin + d.slab().count == n[2];
  const std::size_t m1 = n[0] + 1, m2 = n[1] + 1, m3 = count + (last ? 1 : 0);
  std::vector<double> out(3 * m1 * m2 * m3);
  for (std::size_t l3 = 0; l3 < m3; ++l3)
    for (std::size_t i2 = 0; i2 < m2; ++i2)
      for (std::size_t i1 = 0; i1 < m1; ++i1) {
        const std::size_t v = i1 % n[0] + std::size_t(n[0]) * (i2 % n[1] + std::size_t(n[1]) * l3);
        const double i3 = double(d.slab().begin + l3);
        const Vec3 y(double(i1) * grid.spacing(0), double(i2) * grid.spacing(1), i3 * grid.spacing(2));
        const Vec3 uy = G * y + Vec3(uh[v], uh[stride + v], uh[2 * stride + v]);
        double* o = &out[3 * (i1 + m1 * (i2 + m2 * l3))];
        for (int c = 0; c < 3; ++c) o[c] = uy[c];
      }
  return out;
}

}  // namespace softhom::rve::detail
