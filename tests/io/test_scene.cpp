// Scene parsing: shipped point scenes load; every error names its TOML field.
#include <gtest/gtest.h>

#include <cmath>

#include "softhom/io/scene.hpp"
#include "softhom/materials/errors.hpp"

using namespace softhom;

namespace {
std::string load_error(const std::string& text) {
  try {
    const auto t = io::parse_scene(text, "test.toml");
    if (const auto* m = t["material"].as_table()) build_material(io::parse_material(*m, "material"));
    if (const auto* l = t["load"].as_table()) io::parse_load(*l, "load");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(Scene, ShippedPointScenesParse) {
  for (const char* stem : {"point_uniaxial_ecoflex", "point_uniaxial_fiber", "point_equibiaxial_fiber30",
                           "point_relaxation", "point_locking"}) {
    const auto t = io::load_scene(std::string(SOFTHOM_SOURCE_DIR) + "/studies/scenes/" + stem + ".toml");
    const auto spec = io::parse_material(*t["material"].as_table(), "material");
    const auto control = io::parse_load(*t["load"].as_table(), "load");
    EXPECT_NO_THROW(build_material(spec)) << stem;
    EXPECT_FALSE(control.times.empty()) << stem;
  }
}

TEST(Scene, RampHoldBreakpointIsAnOutputTime) {
  const auto t = io::parse_scene(
      "[load]\ntype = \"uniaxial\"\nstretch = [[0, 1], [20, 1.5], [40, 1.5]]\nsteps = 7\n", "x");
  const auto c = io::parse_load(*t["load"].as_table(), "load");
  EXPECT_NE(std::find_if(c.times.begin(), c.times.end(), [](double x) { return std::abs(x - 20.0) < 1e-12; }),
            c.times.end());
  EXPECT_DOUBLE_EQ(c.times.back(), 40.0);
  EXPECT_DOUBLE_EQ(c.value[0](10.0), 1.25);
}

TEST(Scene, FiberAngleConventionOfSpec7) {
  // α is measured from e2 (in-plane, perpendicular to the load) toward e1: α = 90° lies along the load.
  const auto t = io::parse_scene(
      "[material]\npreset = \"ecoflex-anisotropic\"\nfiber_invariant = \"full\"\n"
      "[[material.fibers]]\nangle_deg = 90\n[[material.fibers]]\nangle_deg = 0\nk1 = 0.1\n", "x");
  const auto s = io::parse_material(*t["material"].as_table(), "material");
  ASSERT_EQ(s.gent.fibers.size(), 2u);
  EXPECT_NEAR((s.gent.fibers[0].direction - Vec3::UnitX()).norm(), 0.0, 1e-15);
  EXPECT_NEAR((s.gent.fibers[1].direction - Vec3::UnitY()).norm(), 0.0, 1e-15);
  EXPECT_DOUBLE_EQ(s.gent.fibers[0].k1, 0.8);  // preset default
  EXPECT_DOUBLE_EQ(s.gent.fibers[1].k1, 0.1);  // per-family override
}

TEST(Scene, MixedControlParses) {
  const auto t = io::parse_scene(
      "[load]\ntype = \"mixed\"\npath = [[0, 0], [1, 1]]\n"
      "F = [[1.5, 0, 0], [\"free\", \"free\", 0], [\"free\", \"free\", \"free\"]]\n", "x");
  const auto c = io::parse_load(*t["load"].as_table(), "load");
  EXPECT_EQ(c.kind[voigt9(0, 0)], ControlKind::deformation);
  EXPECT_EQ(c.kind[voigt9(2, 2)], ControlKind::stress);
  EXPECT_DOUBLE_EQ(c.value[voigt9(0, 0)](0.5), 1.25);
}

TEST(Scene, ErrorsNameTheField) {
  EXPECT_NE(load_error("[material]\npreset = \"nope\"\n").find("material.preset = \"nope\": unknown parameter set"), std::string::npos);
  EXPECT_NE(load_error("[material]\nlaw = \"gent\"\nG = 0.1\nJm = 3\n").find("material.K"), std::string::npos);
  EXPECT_NE(load_error("[material]\nlaw = \"gent\"\nG = \"a\"\nJm = 3\nK = 1\n").find("material.G = \"a\""),
            std::string::npos);
  EXPECT_NE(load_error("[material]\nlaw = \"neo-hookean\"\nE = 10\nnu = 0.5\n").find("material.nu"), std::string::npos);
  EXPECT_NE(load_error("[material]\nlaw = \"gent\"\nG = 0.1\nJm = 3\nK = 1\nfiber_invariant = \"full\"\n[[material.fibers]]\n"
                       "direction = [0, 0, 0]\nk1 = 1\nk2 = 1\n")
                .find("material.fibers[0].direction"),
            std::string::npos);
  // Fiber dispersion κ outside [0, 1/3], given per family or as the material-wide default (refused
  // where it is written).
  EXPECT_NE(load_error("[material]\nlaw = \"gent\"\nG = 0.1\nJm = 3\nK = 1\nfiber_invariant = \"full\"\n[[material.fibers]]\n"
                       "angle_deg = 30\nk1 = 1\nk2 = 1\nkappa = 0.5\n")
                .find("material.fibers[0].kappa = 0.5"),
            std::string::npos);
  EXPECT_NE(load_error("[material]\nlaw = \"gent\"\nG = 0.1\nJm = 3\nK = 1\nkappa = -0.1\nfiber_invariant = \"full\"\n"
                       "[[material.fibers]]\nangle_deg = 30\nk1 = 1\nk2 = 1\n")
                .find("material.kappa = -0.1: must lie in [0, 0.3333333333333333]"),
            std::string::npos);
  EXPECT_NE(load_error("[load]\ntype = \"uniaxial\"\nstretch = [[0, 1], [0, 2]]\n").find("load.stretch[1][0]"),
            std::string::npos);
  EXPECT_NE(load_error("[load]\ntype = \"mixed\"\npath = [[0, 0], [1, 1]]\n"
                       "F = [[1.5, 0, 0], [0, \"free\", \"free\"], [0, \"free\", \"free\"]]\n")
                .find("rigid rotation"),
            std::string::npos);
}

TEST(Scene, LawParametersComeFromTheLawTable) {
  // A key of another law names the chosen law's own parameters (from law_table()).
  EXPECT_NE(load_error("[material]\nlaw = \"yeoh\"\nC1 = 0.1\nK = 10\nG = 1\n")
                .find("material.G = 1: not a parameter of the Yeoh law (its parameters: C1, C2, C3, K)"),
            std::string::npos);
  EXPECT_NE(load_error("[material]\nlaw = \"gent\"\nG = 0.1\nJm = 3\nK = 1\nform = \"lame-log\"\n").find("material.form"),
            std::string::npos);
  // The declared range refuses the value as written.
  EXPECT_NE(load_error("[material]\nlaw = \"gent\"\nG = -1e-300\nJm = 3\nK = 1\n").find("material.G = -1e-300: must lie in (0, 1e+09]"),
            std::string::npos);
  EXPECT_NE(load_error("[material]\nlaw = \"neo-hookean\"\nmu = 1\nK = 10\nE = 3\nnu = 0.3\n").find("give either (E, nu) or (mu, K)"),
            std::string::npos);
  EXPECT_NE(load_error("[material]\nlaw = \"gnet\"\n").find("(did you mean 'gent'?)"), std::string::npos);
  EXPECT_NE(load_error("[material]\nlaw = \"gent\"\nGG = 1\n").find("material.GG = 1: unknown key (did you mean 'G'?)"),
            std::string::npos);
  // Every law's parameters are declared keys of a material table.
  const auto tables = material_tables("material");  // kept alive: the loop below reads into it
  for (const auto& law : law_table())
    for (const auto& p : law.parameters) {
      bool documented = false;
      for (const auto& k : tables.front().keys) documented |= k.name == p.name;
      EXPECT_TRUE(documented) << law.name << "." << p.name;
    }
  // Values equal to the old parser's: E, nu → mu, K (exact formulas).
  const auto t = io::parse_scene("[material]\nlaw = \"neo-hookean\"\nE = 3\nnu = 0.25\nform = \"lame-log\"\n", "x");
  const MaterialSpec s = io::parse_material(*t["material"].as_table(), "material");
  EXPECT_DOUBLE_EQ(s.neo_hookean.mu, 3.0 / 2.5);
  EXPECT_DOUBLE_EQ(s.neo_hookean.K, 3.0 / 1.5);
  EXPECT_EQ(s.neo_hookean.form, NeoHookeanForm::lame_log);
}

TEST(Scene, LoadPathsRefuseBadTimesAndSteps) {
  EXPECT_NE(load_error("[load]\ntype = \"uniaxial\"\nstretch = [[0, 1], [nan, 2]]\n").find("load.stretch[1][0] = nan: must be a finite number"),
            std::string::npos);
  EXPECT_NE(load_error("[load]\ntype = \"uniaxial\"\nstretch = [[0, 1], [inf, 2]]\n").find("load.stretch[1][0] = inf"),
            std::string::npos);
  EXPECT_NE(load_error("[load]\ntype = \"uniaxial\"\nstretch = [[-1, 1], [1, 2]]\n").find("load.stretch[0][0] = -1: a load path starts at t = 0"),
            std::string::npos);
  EXPECT_NE(load_error("[load]\ntype = \"uniaxial\"\nstretch = 1.5\nduration = -2\n").find("load.duration = -2: must be > 0"),
            std::string::npos);
  EXPECT_NE(load_error("[load]\ntype = \"uniaxial\"\nstretch = 1.5\nsteps = 2e6\n").find("load.steps = 2e+06: must lie in [1, 1e+06]"),
            std::string::npos);
  EXPECT_NE(load_error("[load]\ntype = \"uniaxial\"\nstretch = 1.5\nsteps = 2.5\n").find("load.steps = 2.5: must be a whole number"),
            std::string::npos);
  EXPECT_NE(load_error("[load]\ntype = \"uniaxial\"\nstretch = 1.5\ndt = 1e-7\n").find("load.dt = 1e-07: more than 1e6"),
            std::string::npos);
  EXPECT_NE(load_error("[load]\ntype = \"pure_shear\"\nstretch = 1.5\n").find("load.type = \"pure_shear\": renamed to \"pure-shear\""),
            std::string::npos);
  EXPECT_NE(load_error("[load]\ntype = \"simple_shear\"\ngamma = 0.5\n").find("renamed to \"simple-shear\""), std::string::npos);
  EXPECT_NE(load_error("[load]\ntype = \"uniaxial\"\nstretch = 1.5\ngamma = 0.5\n").find("load.gamma: not a key of load type \"uniaxial\""),
            std::string::npos);
  EXPECT_EQ(load_error("[load]\ntype = \"simple-shear\"\ngamma = 0.5\nsteps = 4\n"), "");
}

// Keys that contradict each other were ignored with exit 0 (a stress target at a prescribed entry of F,
// an in_plane along the direction), and values whose derived quantities overflow were reported under a
// derived name (material.K = inf) or as NaN: each is refused naming the key given, its value as written.
namespace {
const std::string kMixed = "[load]\ntype = \"mixed\"\npath = [[0, 0], [1, 1]]\nsteps = 4\n"
                           "F = [[1.2, 0, 0], [0, \"free\", 0], [0, 0, \"free\"]]\n";
}  // namespace

TEST(ContradictoryKeys, StressTargetAtAPrescribedEntryIsRefused) {
  // F11 = 1.2 is prescribed: a P11 other than the zero filler cannot act.
  for (const auto& [p11, shown] : {std::pair{"nan", "nan"}, std::pair{"\"fre\"", "\"fre\""}, std::pair{"0.5", "0.5"}}) {
    const std::string e = load_error(kMixed + "P = [[" + p11 + ", 0, 0], [0, 0, 0], [0, 0, 0]]\n");
    EXPECT_NE(e.find(std::string("load.P[0][0] = ") + shown + ": a stress target applies to a \"free\" entry of F only; "
                     "load.F[0][0] is prescribed"),
              std::string::npos)
        << e;
  }
  EXPECT_EQ(load_error(kMixed + "P = [[0, 0, 0], [0, 0.1, 0], [0, 0, 0]]\n"), "");
}

TEST(ContradictoryKeys, InPlaneAlongTheDirectionIsRefused) {
  const std::string load = "[load]\ntype = \"uniaxial\"\nstretch = 1.2\nsteps = 4\ndirection = [1, 0, 0]\n";
  const std::string e = load_error(load + "in_plane = [2, 0, 0]\n");
  EXPECT_NE(e.find("load.in_plane = [2, 0, 0]: is parallel to direction [1, 0, 0]"), std::string::npos) << e;
  EXPECT_EQ(load_error(load + "in_plane = [1, 1, 0]\n"), "");
  // Without in_plane the default second axis is replaced when the direction lies along it: not an error.
  EXPECT_EQ(load_error("[load]\ntype = \"uniaxial\"\nstretch = 1.2\nsteps = 4\ndirection = [0, 1, 0]\n"), "");
}

TEST(ContradictoryKeys, OverflowingModulusNamesTheKeyGiven) {
  // Moduli above 1e9 MPa are refused where they are given (E = 1e308 gave K = inf with nu = 0.49, and a
  // non-finite stress at the first step with nu = 0.3); a finite E whose derived K overflows near
  // nu = 0.5 still names E.
  for (const char* nu : {"0.49", "0.3"}) {
    const std::string e = load_error(std::string("[material]\nlaw = \"neo-hookean\"\nE = 1e308\nnu = ") + nu + "\n");
    EXPECT_NE(e.find("material.E = 1e+308"), std::string::npos) << e;
    EXPECT_EQ(e.find("material.K"), std::string::npos) << e;
  }
  EXPECT_NE(load_error("[material]\nlaw = \"gent\"\nG = 2e9\nJm = 3\nK = 100\n").find("material.G = 2e+09"), std::string::npos);
}

TEST(ContradictoryKeys, HugeFiberAngleIsReducedNotNaN) {
  // 1e308 deg overflowed to inf in radians (direction [-nan, -nan, 0]); modulo one turn it is exact.
  const auto t = io::parse_scene("[material]\npreset = \"ecoflex-anisotropic\"\nfiber_invariant = \"full\"\n[[material.fibers]]\nangle_deg = 1e308\n", "t");
  const auto spec = io::parse_material(*t["material"].as_table(), "material");
  ASSERT_FALSE(spec.gent.fibers.empty());
  const auto& d = spec.gent.fibers[0].direction;
  const double a = std::fmod(1e308, 360.0) * 3.14159265358979323846 / 180.0;
  EXPECT_NEAR(d.x(), std::sin(a), 1e-15);  // the same formula: round-off only
  EXPECT_NEAR(d.y(), std::cos(a), 1e-15);
}

// duration = 5e-324 over 5 steps underflowed to a first output time of 0 and was reported as
// 'load.times[0] = 0.000000'; 1e308 overflowed (end · s) to 'load.times[2] = inf'. The key given is
// named with its value as written; 1e308 itself is a valid duration now (end · (s / steps)). A hold of
// 1e308 after it made the path end at inf, and the hold was dropped from the output times with exit 0.
TEST(ContradictoryKeys, TimeScaleErrorsNameTheDuration) {
  const std::string load = "[load]\ntype = \"uniaxial\"\nstretch = 1.2\nsteps = 5\n";
  const std::string tiny = load_error(load + "duration = 5e-324\n");
  EXPECT_NE(tiny.find("load.duration = 5e-324: gives output times from 0 to"), std::string::npos) << tiny;
  EXPECT_EQ(load_error(load + "duration = 1e308\n"), "");
  const std::string huge = load_error(load + "duration = 1e308\nhold = 1e308\n");
  EXPECT_NE(huge.find("load.duration = 1e+308: gives output times from"), std::string::npos) << huge;
}
