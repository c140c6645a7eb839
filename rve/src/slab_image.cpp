// The slab phase image of a distributed FFT cell (see slab_image.hpp).
#include "softhom/rve/slab_image.hpp"

#include <string>

#include "fft_distribution.hpp"

namespace softhom::rve {

std::optional<SlabPlanes> distributed_planes(const std::array<int, 3>& n) {
  fft::Grid grid;
  grid.n = n;
  const std::string text = "[" + std::to_string(n[0]) + ", " + std::to_string(n[1]) +
                           (n[2] > 1 ? ", " + std::to_string(n[2]) : "") + "]";  // as the scene writes it
  const std::unique_ptr<fft::SlabDecomposition> slabs = detail::make_slabs(grid, true, text);
  if (!slabs) return std::nullopt;
  return SlabPlanes{slabs->slab().begin, slabs->slab().count};
}

PhaseImage rank_image(PhaseImage whole) {
  const std::optional<SlabPlanes> planes = whole.n[2] > 1 && !whole.is_slab() ? distributed_planes(whole.n) : std::nullopt;
  if (!planes) return whole;
  return slab_of(whole, planes->begin, planes->count, kSlabImageHalo);
}

}  // namespace softhom::rve
