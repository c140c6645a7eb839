// Shell scenes: the shipped balloon parses and builds; every refusal (a layer of zero thickness, a
// frame that cannot be formed, an unknown edge, volume control on an open surface, a [material] or
// [shell] table where it does not belong) names its key before anything runs.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "softhom/io/scene.hpp"
#include "softhom/macro/scene.hpp"
#include "softhom/materials/errors.hpp"

namespace fs = std::filesystem;
using namespace softhom;

namespace {

const char* kBalloon = R"(
[geometry]
type = "shell"
shape = "sphere_octant"
radius = 10.0
cells = 4
[shell]
frame = "global"
frame_axis = [0.0, 0.0, 1.0]
[[shell.layers]]
thickness = 0.1
[shell.layers.material]
law = "neo-hookean"
mu = 0.5
K = 500.0
[[shell.layers]]
thickness = 0.05
points = 2
fiber_angles = [30.0, -30.0]
[shell.layers.material]
preset = "ecoflex-anisotropic"
fiber_invariant = "full"
[load]
control = "volume"
path = [[0.0, 1.0], [1.0, 2.0]]
steps = 2
)";

macro::MacroScene parse_shell_scene(const std::string& text) { return macro::parse_macro_scene(io::parse_scene(text, "<test>")); }

/// The scene with `from` replaced by `to` must be refused naming `field`.
void expect_refused(const std::string& from, const std::string& to, const std::string& field, bool build = false) {
  std::string text = kBalloon;
  const std::size_t at = text.find(from);
  ASSERT_NE(at, std::string::npos) << from;
  text.replace(at, from.size(), to);
  try {
    const macro::MacroScene m = parse_shell_scene(text);
    if (build) (void)macro::build_structure(m.spec);
    FAIL() << "accepted: " << to;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << field << " :: " << e.what();
  }
}

}  // namespace

TEST(ShellScene, TheShippedBalloonParsesAndBuilds) {
  const fs::path file = fs::path(SOFTHOM_SOURCE_DIR) / "studies/scenes/macro_shell_balloon.toml";
  const macro::MacroScene m = macro::parse_macro_scene(io::load_scene(file), file);
  EXPECT_EQ(m.spec.kind, macro::StructureKind::shell);
  const macro::Structure s = macro::build_structure(m.spec);
  ASSERT_TRUE(s.shell);
  EXPECT_EQ(int(s.shell->triangles().size()), 16 * 16);
  EXPECT_TRUE(s.model.cavity.has_value());
}

TEST(ShellScene, LayersFramesAndEdgesAreRead) {
  const macro::MacroScene m = parse_shell_scene(kBalloon);
  ASSERT_TRUE(m.spec.shell.section);
  EXPECT_EQ(m.spec.shell.section->layers().size(), 2u);
  EXPECT_NEAR(m.spec.shell.section->thickness(), 0.15, 1e-15);
  EXPECT_EQ(m.spec.shell.section->layers()[1].law->fiber_directions().size(), 2u);
  EXPECT_NEAR((m.spec.shell.frame.axis - Vec3::UnitZ()).norm(), 0.0, 1e-15);
  // On a strip in the plane z = 0 the z axis is every triangle's normal: each frame falls back to y.
  std::string strip = kBalloon;
  strip.replace(strip.find("sphere_octant"), 13, "strip");
  strip.replace(strip.find("\"volume\""), 8, "\"pressure\"");
  const macro::Structure s = macro::build_structure(parse_shell_scene(strip).spec);
  EXPECT_EQ(s.shell->frame_fallbacks(), int(s.shell->triangles().size()));
  EXPECT_NEAR((s.shell->patches()[0].frame.col(0) - Vec3::UnitY()).norm(), 0.0, 1e-14);
}

TEST(ShellScene, BadInputIsRefusedNamingItsKey) {
  expect_refused("thickness = 0.1", "thickness = 0.0", "shell.layers[0].thickness");
  expect_refused("thickness = 0.1", "thickness = -1.0", "shell.layers[0].thickness");
  expect_refused("frame_axis = [0.0, 0.0, 1.0]", "frame_axis = [0.0, 0.0, 0.0]", "shell.frame_axis");
  expect_refused("points = 2", "points = 9", "shell.layers[1].points");
  expect_refused("shape = \"sphere_octant\"", "shape = \"cube\"", "geometry.shape");
  expect_refused("[load]", "[[shell.edges]]\nedge = \"rim\"\ntype = \"clamped\"\n[load]", "shell.edges[0].edge", true);
  // An open strip has no cavity for volume control: refused naming an element with an open edge.
  expect_refused("shape = \"sphere_octant\"", "shape = \"strip\"", "load.control", true);
  expect_refused("[shell]\n", "[material]\npreset = \"ecoflex\"\n[shell]\n", "material");
  expect_refused("type = \"shell\"\nshape = \"sphere_octant\"\nradius = 10.0\ncells = 4",
                 "type = \"sphere\"\ninner_radius = 1.0\nthickness = 0.1", "shell");
}

TEST(ShellScene, ARunOfTheBalloonSceneReachesTheEndOfItsPath) {
  const macro::MacroScene m = parse_shell_scene(kBalloon);
  const macro::Structure s = macro::build_structure(m.spec);
  fe::Simulation sim(s.model, m.newton);
  for (double t : m.times) ASSERT_TRUE(sim.advance_to(t).reached());
  const std::vector<double> probe = macro::probe_values(s, sim);
  EXPECT_NEAR(probe[3], 2.0, 1e-8);  // the volume ratio on target (the driver's 1e-9 of V0)
  EXPECT_GT(probe[1], 0.0);
}
