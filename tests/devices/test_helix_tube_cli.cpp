// The coarse fully resolved fiber tube (studies/structures/resolved_coarse.toml) through `softhom
// macro`: gmsh meshes studies/meshes/helix_tube.geo with the scene's [helix_tube] parameters, one
// pressure step runs, device.csv holds the tube gauge ([device] kind = "tube").
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>

#include "app/cli_helpers.hpp"

using namespace softhom::test;
namespace fs = std::filesystem;

// Internal pressure of 1 kPa on the Ecoflex tube with 45° glass fibers: the cavity grows (the pressure
// does positive work), the tube lengthens, and the single helix couples extension to twist, which a
// tube without the fibers' handedness would not show (measured: λz = 1.0065, inner λr = 1.0035, twist
// −0.26°; the bounds are wide enough for any mesh gmsh may give and fail on a sign change or a zero).
TEST(HelixTubeCli, CoarseResolvedTubeRunsOnePressureStep) {
  const fs::path scene = fs::path(SOFTHOM_SOURCE_DIR) / "studies/structures/resolved_coarse.toml";
  const fs::path out = fresh_dir("helix-tube-coarse");
  const fs::path cache = fs::temp_directory_path() / "softhom-mesh-cache";  // shared with tests/macro's parse
  const auto r = run_softhom("macro " + scene.string() + " --out " + out.string() + " -q",
                             "OMP_NUM_THREADS=1 SOFTHOM_MESH_CACHE=" + cache.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Csv c = read_csv(out / "device.csv");
  ASSERT_EQ(c.rows.size(), 2u);
  EXPECT_NEAR(c.at(1, "pressure_kPa"), 1.0, 1e-12);
  EXPECT_GT(c.at(1, "channel_volume_change_mm3"), 0.0);
  EXPECT_GT(c.at(1, "axial_stretch"), 1.001);
  EXPECT_LT(c.at(1, "axial_stretch"), 1.05);
  EXPECT_GT(c.at(1, "radial_stretch_inner"), 1.0005);
  EXPECT_LT(c.at(1, "radial_stretch_inner"), 1.05);
  EXPECT_GT(std::abs(c.at(1, "twist_end_deg")), 0.05);
  EXPECT_LT(std::abs(c.at(1, "twist_end_deg")), 5.0);
  std::ifstream in(out / "summary.json");
  std::stringstream ss;
  ss << in.rdbuf();
  EXPECT_NE(ss.str().find("\"kind\": \"tube\""), std::string::npos);
}
