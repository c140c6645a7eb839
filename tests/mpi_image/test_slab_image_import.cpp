// An imported voxel image on a distributed FFT cell: every rank reads only the planes of its slab and
// their halo from the HDF5 file (io::read_dataset_planes), and what it holds is exactly the whole image
// restricted to them (rve::slab_of), fractions, normals and fiber directions alike; the cell's volume
// fraction is reduced over the ranks; a bad value is reported at its voxel of the whole grid.
#include <gtest/gtest.h>
#include <mpi.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <toml++/toml.h>

#include "softhom/io/fields.hpp"
#include "softhom/core/input_error.hpp"
#include "softhom/rve/slab_image.hpp"
#include "softhom/studies/rve_scene.hpp"

namespace fs = std::filesystem;
using namespace softhom;

namespace {

int rank() {
  int r = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &r);
  return r;
}

int ranks() {
  int n = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &n);
  return n;
}

// 7 planes: uneven slabs on 2 (4 + 3) and 3 ranks (3 + 3 + 1), so halos wrap and differ in size.
constexpr std::array<int, 3> kN{6, 5, 7};

/// A directory every rank sees, made by rank 0.
fs::path shared_dir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("softhom-mpi-image-" + name + "-" + std::to_string(ranks()));
  if (rank() == 0) {
    fs::remove_all(dir);
    fs::create_directories(dir);
  }
  MPI_Barrier(MPI_COMM_WORLD);
  return dir;
}

/// Rank 0 writes a fiber-fraction image whose every voxel differs (so a misplaced plane cannot pass),
/// with normals in composite voxels and fiber directions in fiber; `bad_fraction` goes into the last
/// voxel of plane `bad_plane` (−1: none).
fs::path write_image(const fs::path& dir, int bad_plane = -1, double bad_fraction = 0.0) {
  const fs::path stem = dir / "cell";
  if (rank() == 0) {
    io::VoxelGrid grid;
    grid.cells = kN;
    grid.spacing = {0.1, 0.1, 0.1};
    const std::size_t voxels = std::size_t(kN[0]) * kN[1] * kN[2];
    std::vector<double> fraction(voxels), normal(3 * voxels, 0.0), direction(3 * voxels, 0.0);
    for (std::size_t v = 0; v < voxels; ++v) {
      const double f = std::fmod(0.37 * double(v), 1.3);
      fraction[v] = f >= 1.0 ? 1.0 : (v % 4 == 0 ? 0.0 : f);  // pure matrix, pure fiber and composite voxels
      if (fraction[v] > 0.0 && fraction[v] < 1.0) normal[3 * v + v % 3] = 1.0 + 0.01 * double(v);
      if (fraction[v] > 0.0) {
        direction[3 * v] = 0.3;
        direction[3 * v + 2] = 1.0 + 0.001 * double(v);
      }
    }
    if (bad_plane >= 0) fraction[std::size_t(kN[0]) * kN[1] * std::size_t(bad_plane + 1) - 1] = bad_fraction;
    io::write_voxel_image(stem, grid, {{"fraction", fraction, 1, false}, {"normal", normal, 3, false}, {"direction", direction, 3, false}});
  }
  MPI_Barrier(MPI_COMM_WORLD);
  return fs::path(stem.string() + ".h5");
}

toml::table image_table(const fs::path& file) {
  return toml::table{{"file", file.string()}, {"dataset", "/fraction"}, {"normal_dataset", "/normal"}, {"direction_dataset", "/direction"}};
}

}  // namespace

TEST(SlabImageImport, EachRankReadsExactlyItsPlanesAndHalo) {
  const fs::path file = write_image(shared_dir("planes"));
  std::string note;
  const toml::table t = image_table(file);
  const rve::PhaseImage whole = studies::import_phase_image(t, "microstructure.image", note, false);
  const rve::PhaseImage mine = studies::import_phase_image(t, "microstructure.image", note, true);
  ASSERT_EQ(whole.n, kN);
  const std::optional<rve::SlabPlanes> planes = rve::distributed_planes(kN);
  if (ranks() == 1) {
    EXPECT_FALSE(planes);
    EXPECT_FALSE(mine.is_slab());
    EXPECT_EQ(mine.fiber_fraction, whole.fiber_fraction);
    return;
  }
  ASSERT_TRUE(planes);
  ASSERT_TRUE(mine.is_slab());
  const rve::PhaseImage cut = rve::slab_of(whole, planes->begin, planes->count, rve::kSlabImageHalo);
  EXPECT_EQ(mine.plane_begin, cut.plane_begin);
  EXPECT_EQ(mine.plane_count, cut.plane_count);
  EXPECT_EQ(mine.halo, cut.halo);
  EXPECT_EQ(mine.size, whole.size);
  // Bit-equal: the same file values through the same conversions.
  EXPECT_EQ(mine.fiber_fraction, cut.fiber_fraction);
  ASSERT_EQ(mine.normal.size(), cut.normal.size());
  ASSERT_EQ(mine.fiber_direction.size(), cut.fiber_direction.size());
  for (std::size_t v = 0; v < cut.normal.size(); ++v) {
    EXPECT_EQ(mine.normal[v], cut.normal[v]) << v;
    EXPECT_EQ(mine.fiber_direction[v], cut.fiber_direction[v]) << v;
  }
  // What a rank holds is its share: n1 n2 (count + 2 halo) voxels, not the whole image.
  EXPECT_EQ(mine.fiber_fraction.size(), std::size_t(kN[0]) * kN[1] * std::size_t(planes->count + 2 * mine.halo));
  // The owned sums add up to the whole image's over the ranks (each plane owned once).
  double sum = mine.owned_fiber_sum();
  MPI_Allreduce(MPI_IN_PLACE, &sum, 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
  EXPECT_NEAR(sum, whole.owned_fiber_sum(), 1e-12 * whole.owned_fiber_sum());
}

TEST(SlabImageImport, BadFractionIsReportedAtItsVoxelOfTheWholeGrid) {
  // 1.5 in the last voxel (5, 4, 6) of plane 6: only the ranks holding plane 6 (owned or halo) see it.
  const fs::path file = write_image(shared_dir("bad"), 6, 1.5);
  std::string note;
  const toml::table t = image_table(file);
  const std::optional<rve::SlabPlanes> planes = rve::distributed_planes(kN);
  bool holds_plane_6 = true;
  if (planes) {
    holds_plane_6 = false;
    for (int k = planes->begin - rve::kSlabImageHalo; k < planes->begin + planes->count + rve::kSlabImageHalo; ++k)
      holds_plane_6 |= ((k % kN[2]) + kN[2]) % kN[2] == 6;
  }
  if (!holds_plane_6) {
    EXPECT_NO_THROW(studies::import_phase_image(t, "microstructure.image", note, true));
    return;
  }
  try {
    studies::import_phase_image(t, "microstructure.image", note, true);
    FAIL() << "no error for a fiber fraction of 1.5";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("microstructure.image.dataset"), std::string::npos) << what;
    EXPECT_NE(what.find("1.5 at voxel (i1, i2, i3) = (5, 4, 6)"), std::string::npos) << what;
  }
}
