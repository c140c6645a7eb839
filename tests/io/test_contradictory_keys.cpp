// Keys that contradict each other were ignored with exit 0 (a stress target at a prescribed entry of F,
// an in_plane along the direction), and values whose derived quantities overflow were reported under a
// derived name (material.K = inf) or as NaN: each is refused naming the key given, its value as written.
#include <gtest/gtest.h>

#include <cmath>

#include "softhom/io/scene.hpp"
#include "softhom/materials/errors.hpp"

using namespace softhom;

namespace {
std::string error_of(const std::string& text) {
  try {
    const auto t = io::parse_scene(text, "test.toml");
    if (const auto* m = t["material"].as_table()) build_material(io::parse_material(*m, "material"));
    if (const auto* l = t["load"].as_table()) io::parse_load(*l, "load");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

const std::string kMixed = "[load]\ntype = \"mixed\"\npath = [[0, 0], [1, 1]]\nsteps = 4\n"
                           "F = [[1.2, 0, 0], [0, \"free\", 0], [0, 0, \"free\"]]\n";
}  // namespace

TEST(ContradictoryKeys, StressTargetAtAPrescribedEntryIsRefused) {
  // F11 = 1.2 is prescribed: a P11 other than the zero filler cannot act.
  for (const auto& [p11, shown] : {std::pair{"nan", "nan"}, std::pair{"\"fre\"", "\"fre\""}, std::pair{"0.5", "0.5"}}) {
    const std::string e = error_of(kMixed + "P = [[" + p11 + ", 0, 0], [0, 0, 0], [0, 0, 0]]\n");
    EXPECT_NE(e.find(std::string("load.P[0][0] = ") + shown + ": a stress target applies to a \"free\" entry of F only; "
                     "load.F[0][0] is prescribed"),
              std::string::npos)
        << e;
  }
  EXPECT_EQ(error_of(kMixed + "P = [[0, 0, 0], [0, 0.1, 0], [0, 0, 0]]\n"), "");
}

TEST(ContradictoryKeys, InPlaneAlongTheDirectionIsRefused) {
  const std::string load = "[load]\ntype = \"uniaxial\"\nstretch = 1.2\nsteps = 4\ndirection = [1, 0, 0]\n";
  const std::string e = error_of(load + "in_plane = [2, 0, 0]\n");
  EXPECT_NE(e.find("load.in_plane = [2, 0, 0]: is parallel to direction [1, 0, 0]"), std::string::npos) << e;
  EXPECT_EQ(error_of(load + "in_plane = [1, 1, 0]\n"), "");
  // Without in_plane the default second axis is replaced when the direction lies along it: not an error.
  EXPECT_EQ(error_of("[load]\ntype = \"uniaxial\"\nstretch = 1.2\nsteps = 4\ndirection = [0, 1, 0]\n"), "");
}

TEST(ContradictoryKeys, OverflowingModulusNamesTheKeyGiven) {
  const std::string e = error_of("[material]\nlaw = \"neo-hookean\"\nE = 1e308\nnu = 0.3\n");
  EXPECT_NE(e.find("material.E = 1e+308: with nu = 0.3 gives mu = "), std::string::npos) << e;
  EXPECT_EQ(e.find("material.K"), std::string::npos) << e;
}

TEST(ContradictoryKeys, HugeFiberAngleIsReducedNotNaN) {
  // 1e308 deg overflowed to inf in radians (direction [-nan, -nan, 0]); modulo one turn it is exact.
  const auto t = io::parse_scene("[material]\npreset = \"ecoflex-anisotropic\"\n[[material.fibers]]\nangle_deg = 1e308\n", "t");
  const auto spec = io::parse_material(*t["material"].as_table(), "material");
  ASSERT_FALSE(spec.gent.fibers.empty());
  const auto& d = spec.gent.fibers[0].direction;
  const double a = std::fmod(1e308, 360.0) * 3.14159265358979323846 / 180.0;
  EXPECT_NEAR(d.x(), std::sin(a), 1e-15);  // the same formula: round-off only
  EXPECT_NEAR(d.y(), std::cos(a), 1e-15);
}

// duration = 5e-324 over 5 steps underflowed to a first output time of 0 and was reported as
// 'load.times[0] = 0.000000'; 1e308 overflowed (end · s) to 'load.times[2] = inf'. The key given is
// named with its value as written; 1e308 itself is a valid duration now (end · (s / steps)).
TEST(ContradictoryKeys, TimeScaleErrorsNameTheDuration) {
  const std::string load = "[load]\ntype = \"uniaxial\"\nstretch = 1.2\nsteps = 5\n";
  const std::string tiny = error_of(load + "duration = 5e-324\n");
  EXPECT_NE(tiny.find("load.duration = 5e-324: gives output times from 0 to"), std::string::npos) << tiny;
  EXPECT_EQ(error_of(load + "duration = 1e308\n"), "");
  const std::string huge = error_of(load + "duration = 1e308\nhold = 1e308\n");
  EXPECT_NE(huge.find("load.duration = 1e+308: gives output times from"), std::string::npos) << huge;
}
