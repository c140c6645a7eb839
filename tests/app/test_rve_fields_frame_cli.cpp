// An RVE's fields.h5 as a viewer meets it: the cell shown in the load frame (the fiber-aligned grid turned
// by the grid axes), the displacement in load-frame components, and step groups that sort in time order.
#include <gtest/gtest.h>

#include <Eigen/Dense>

#include "app/cli_helpers.hpp"
#include "softhom/io/fields.hpp"

using namespace softhom;
using namespace softhom::test;
namespace fs = std::filesystem;

namespace {

using Mat3 = Eigen::Matrix3d;
using Vec3 = Eigen::Vector3d;

Vec3 node_vector(const std::vector<double>& v, const std::vector<std::size_t>& dims, std::size_t k, std::size_t j,
                 std::size_t i) {
  const std::size_t at = 3 * (i + dims[2] * (j + dims[1] * k));
  return {v[at], v[at + 1], v[at + 2]};
}

}  // namespace

TEST(RveFieldsFrame, TheCellIsShownInTheLoadFrameAndItsStepsSort) {
  // 8² cell, fiber at α = 30°, two load steps: small enough for well under a second.
  const std::string scene = write_temp_scene("fields_frame_" + std::to_string(::getpid()),
                                             "[microstructure]\nvolume_fraction = 0.2\nradius = 0.2\nfiber_angle_deg = 30\n"
                                             "grid = [8, 8]\n[phases.matrix]\npreset = \"ecoflex\"\n"
                                             "[phases.fiber]\npreset = \"glass\"\n[load]\ntype = \"uniaxial\"\n"
                                             "stretch = 1.3\nduration = 1.0\nsteps = 2\n[output]\nfields = \"all\"\n");
  const fs::path out = fresh_dir("fields_frame");
  const CommandResult r = run_softhom("rve " + scene + " --out " + out.string() + " -q -j 1");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const fs::path h5 = out / "fields.h5";

  // The grid axes (columns) in load-frame coordinates: g1 = (cos α, −sin α, 0), g2 = −e3, g3 = (sin α, cos α, 0).
  const auto axes = io::read_dataset(h5, "/mesh/grid_axes").values;
  ASSERT_EQ(axes.size(), 9u);
  const double c = std::cos(M_PI / 6), s = std::sin(M_PI / 6);
  const double expected[9] = {c, 0, s, -s, 0, c, 0, -1, 0};
  for (int k = 0; k < 9; ++k) EXPECT_NEAR(axes[k], expected[k], 1e-15) << k;

  const io::Dataset X = io::read_dataset(h5, "/mesh/coordinates");
  ASSERT_EQ(X.dims.size(), 4u);
  const std::size_t n3 = X.dims[0] - 1, n2 = X.dims[1] - 1, n1 = X.dims[2] - 1;
  // The cell's first edge lies along g1 in the load frame (the grid is turned, not only relabelled).
  const Vec3 edge1 = node_vector(X.values, X.dims, 0, 0, n1) - node_vector(X.values, X.dims, 0, 0, 0);
  EXPECT_NEAR(edge1.normalized().dot(Vec3(c, -s, 0)), 1.0, 1e-14);

  // The last step (t = 0, 0.5, 1: step_000002, zero-padded). Its deformed corners x = X + u are periodic under
  // the mean F in the load frame: x(y + L) − x(y) = F̄ (X(y + L) − X(y)) for every cell edge, to
  // round-off (u = (F̄ − I) y + ũ with ũ periodic), which holds only if X, u and F share one frame.
  const io::Dataset u = io::read_dataset(h5, "/step_000002/displacement");
  const io::Dataset F = io::read_dataset(h5, "/step_000002/F");
  ASSERT_EQ(u.dims, X.dims);
  Mat3 Fbar = Mat3::Zero();
  const std::size_t cells = F.values.size() / 9;
  for (std::size_t v = 0; v < cells; ++v)
    for (int k = 0; k < 9; ++k) Fbar(k / 3, k % 3) += F.values[9 * v + k] / double(cells);
  EXPECT_NEAR(Fbar(0, 0), 1.3, 1e-9);  // the prescribed stretch along e1, the load direction
  auto x = [&](std::size_t k, std::size_t j, std::size_t i) {
    return Vec3(node_vector(X.values, X.dims, k, j, i) + node_vector(u.values, u.dims, k, j, i));
  };
  const std::size_t far[3][3] = {{0, 0, n1}, {0, n2, 0}, {n3, 0, 0}};
  for (const auto& e : far) {
    const Vec3 dX = node_vector(X.values, X.dims, e[0], e[1], e[2]) - node_vector(X.values, X.dims, 0, 0, 0);
    EXPECT_LT((x(e[0], e[1], e[2]) - x(0, 0, 0) - Fbar * dX).norm(), 1e-9 * dX.norm()) << e[0] << e[1] << e[2];
  }
  fs::remove_all(out);
  fs::remove(scene);
}
