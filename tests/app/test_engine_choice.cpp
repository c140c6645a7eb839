// The engine choice of `softhom rve` with engine = "auto" (softhom/jobs/engine_choice.hpp): a pure
// function of the target error, the matrix K/G, the shear contrast and the cell sides, checked against
// the error and cost models it encodes (BENCHMARKS.md, FE RVE); and the scene it resolves to, which
// leaves the given table as it was.
#include <gtest/gtest.h>

#include <cmath>

#include "softhom/io/scene.hpp"
#include "softhom/jobs/jobs.hpp"
#include "softhom/materials/errors.hpp"

using softhom::jobs::choose_engine;
using softhom::jobs::EngineRequest;
using softhom::jobs::RveEngine;

namespace {

EngineRequest request(double target, double kg, double contrast, double L1 = 1.0, double L2 = 1.0) {
  return {.target_error = target, .matrix_bulk_to_shear = kg, .shear_contrast = contrast, .L1 = L1, .L2 = L2};
}

}  // namespace

// PDMS matrix (contrast 5.9 to glass: c = 6.2e-3): 16² gives 3.9e-4 < 1e-3 at 0.25 s, cheaper than the
// coarsest mesh (1 s).
TEST(EngineChoice, StiffMatrixAtModerateTargetIsFft16) {
  const auto r = choose_engine(request(1e-3, 100.0, 5.9));
  EXPECT_EQ(r.engine, RveEngine::fft);
  EXPECT_EQ(r.grid[0], 16);
  EXPECT_EQ(r.grid[1], 16);
  EXPECT_NEAR(r.fft_error_coefficient, 6.2e-3, 1e-15);
  EXPECT_NEAR(r.predicted_error, 6.2e-3 / 16, 1e-15);
  EXPECT_DOUBLE_EQ(r.predicted_fft_seconds, 0.25);
  EXPECT_DOUBLE_EQ(r.predicted_fe_seconds, 1.0);
  EXPECT_NE(r.why.find("FFT 16"), std::string::npos) << r.why;
}

// Ecoflex (contrast 226, K/G 1.2e5): c = 6.2e-3 (226/5.9)^0.65 = 0.0663 needs n = 128 (5.2e-4), costing
// 0.25 · 5³ · 6 = 187.5 s; the FE engine's L/4 mesh (1 s) wins.
TEST(EngineChoice, HighContrastNearlyIncompressibleIsFeOnTheCoarsestMesh) {
  const auto r = choose_engine(request(1e-3, 1.2e5, 226.0, 2.0, 1.0));
  EXPECT_EQ(r.engine, RveEngine::fe);
  EXPECT_NEAR(r.fft_error_coefficient, 6.2e-3 * std::pow(226.0 / 5.9, 0.65), 1e-15);
  EXPECT_DOUBLE_EQ(r.predicted_fft_seconds, 0.25 * 125.0 * 6.0);
  EXPECT_DOUBLE_EQ(r.mesh_divisions, 4.0);
  EXPECT_DOUBLE_EQ(r.mesh_size, 0.5);
  EXPECT_DOUBLE_EQ(r.interface_size, 2.0 / 12.0);
}

// Below 1e-4 the mesh refines as d = ceil(4 (1e-4/e)^(1/3.3)): 1e-5 → ceil(8.04) = 9 (3.6 s), while the
// FFT grid hits its cap 1024 (3906 s).
TEST(EngineChoice, TightTargetRefinesTheMesh) {
  const auto r = choose_engine(request(1e-5, 100.0, 5.9));
  EXPECT_EQ(r.engine, RveEngine::fe);
  EXPECT_DOUBLE_EQ(r.mesh_divisions, 9.0);
  // 1e-5 (4/9)^3.3 = 6.9e-7: under the target by the rule's factor 10 of safety and the rounding up of d.
  EXPECT_NEAR(r.predicted_error, 1e-5 * std::pow(4.0 / 9.0, 3.3), 1e-18);
  EXPECT_DOUBLE_EQ(r.predicted_fft_seconds, 0.25 * std::pow(5.0, 6.0));
  EXPECT_NEAR(r.predicted_fe_seconds, std::pow(3.0, std::log2(9.0 / 4.0)), 1e-12);
}

// A rectangular section keeps its aspect in the grid: n2 = round(n L2/L1).
TEST(EngineChoice, GridFollowsTheCellAspect) {
  const auto r = choose_engine(request(1e-3, 100.0, 5.9, 1.0, 0.5));
  EXPECT_EQ(r.engine, RveEngine::fft);
  EXPECT_EQ(r.grid[0], 16);
  EXPECT_EQ(r.grid[1], 8);
}

namespace {
const char* kAutoScene = R"(
[microstructure]
shape = "circle"
volume_fraction = 0.23
radius = 0.2
fiber_angle_deg = 45
[phases.matrix]
preset = "pdms"
[phases.fiber]
preset = "glass"
[load]
type = "uniaxial"
stretch = 1.1
steps = 1
[solver]
engine = "auto"
target_error = 1e-3
)";
}  // namespace

// The scene's numbers reach the choice, and the resolved scene is a new table: the given one keeps
// engine and target_error and gets no grid.
TEST(EngineChoice, ResolvedSceneLeavesTheGivenTableUnchanged) {
  const toml::table scene = softhom::io::parse_scene(kAutoScene, "auto.toml");
  const EngineRequest req = softhom::jobs::engine_request(scene);
  EXPECT_DOUBLE_EQ(req.target_error, 1e-3);
  EXPECT_GT(req.shear_contrast, 1.0);
  const auto r = choose_engine(req);
  ASSERT_EQ(r.engine, RveEngine::fft);
  const toml::table resolved = softhom::jobs::resolved_scene(scene, r);
  EXPECT_EQ(scene["solver"]["engine"].value<std::string>(), "auto");
  EXPECT_TRUE(scene["solver"]["target_error"].is_value());
  EXPECT_FALSE(scene["microstructure"]["grid"]);
  EXPECT_FALSE(resolved["solver"]["engine"]);
  EXPECT_FALSE(resolved["solver"]["target_error"]);
  EXPECT_EQ(resolved["microstructure"]["grid"][0].value<int>(), 16);
}

TEST(EngineChoice, TargetWithAResolutionIsRefused) {
  toml::table scene = softhom::io::parse_scene(kAutoScene, "auto.toml");
  scene["microstructure"].as_table()->insert_or_assign("grid", toml::array{16, 16});
  try {
    softhom::jobs::engine_request(scene);
    FAIL() << "target_error with a grid accepted";
  } catch (const softhom::InputError& e) {
    EXPECT_EQ(e.field(), "solver.target_error");
  }
  scene["solver"].as_table()->erase("target_error");
  scene["microstructure"].as_table()->erase("grid");
  try {
    softhom::jobs::engine_request(scene);
    FAIL() << "engine = auto without target_error accepted";
  } catch (const softhom::InputError& e) {
    EXPECT_EQ(e.field(), "solver.target_error");
  }
}
