// Macro scene files: every shipped scene parses; each refusal names its field (and the relation it
// breaks); renamed solver keys say their new name; output field times join the output steps.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "softhom/io/scene.hpp"
#include "softhom/macro/scene.hpp"
#include "softhom/materials/errors.hpp"

namespace fs = std::filesystem;
using namespace softhom;

namespace {

const fs::path kScenes = fs::path(SOFTHOM_SOURCE_DIR) / "studies/scenes";

const char* kTube = R"(
[geometry]
type = "tube"
inner_radius = 5.0
outer_radius = 7.5
length = 0.5
radial_cells = 2
circumferential_cells = 4
sweep_deg = 90.0
plane_strain = true
[material]
preset = "ecoflex"
[load]
control = "volume"
path = [[0.0, 1.0], [1.0, 4.0]]
steps = 4
)";

macro::MacroScene parse(const std::string& text, const fs::path& file = {}) {
  return macro::parse_macro_scene(io::parse_scene(text, "<test>"), file);
}

/// The InputError of parsing `text`, or "no error".
std::string error_of(const std::string& text, const fs::path& file = {}) {
  try {
    parse(text, file);
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return text.replace(at, from.size(), to);
}

}  // namespace

TEST(MacroScene, EveryShippedSceneParses) {
  int n = 0;
  for (const auto& e : fs::directory_iterator(kScenes)) {
    const std::string name = e.path().filename().string();
    if (name.rfind("macro_", 0) != 0) continue;
    SCOPED_TRACE(name);
    EXPECT_NO_THROW(macro::parse_macro_scene(io::load_scene(e.path()), e.path()));
    ++n;
  }
  EXPECT_GE(n, 10);
}

TEST(MacroScene, DefaultsAndOutputTimes) {
  const macro::MacroScene m = parse(kTube);
  EXPECT_EQ(m.spec.kind, macro::StructureKind::tube);
  EXPECT_TRUE(m.spec.plane_strain);
  EXPECT_EQ(m.spec.tube.axial_cells, 1);       // declared default
  EXPECT_EQ(m.newton.max_iterations, 25);      // fe::NewtonOptions default
  ASSERT_EQ(m.times.size(), 4u);
  EXPECT_DOUBLE_EQ(m.times.back(), 1.0);       // exact end of the path
  EXPECT_TRUE(m.fields_at(0.5));
}

TEST(MacroScene, SolverKeysUseTheSharedSpelling) {
  const macro::MacroScene m = parse(std::string(kTube) +
                                    "[solver]\ntolerance = 1e-7\nmax_newton_iterations = 9\nmax_krylov_iterations = 33\n"
                                    "max_cutbacks = 3\nmixed_pressure = false\nmax_step_seconds = 60\n");
  EXPECT_EQ(m.newton.tolerance, 1e-7);
  EXPECT_EQ(m.newton.max_iterations, 9);
  EXPECT_EQ(m.newton.krylov_max, 33);
  EXPECT_EQ(m.newton.max_cutbacks, 3);
  EXPECT_FALSE(m.newton.mixed);
  EXPECT_EQ(m.newton.max_step_seconds, 60.0);
  for (const char* old : {"max_iterations = 3", "krylov_max = 3", "mixed = false"}) {
    const std::string msg = error_of(std::string(kTube) + "[solver]\n" + old + "\n");
    EXPECT_NE(msg.find("renamed to solver."), std::string::npos) << msg;
  }
}

TEST(MacroScene, RefusalsNameTheField) {
  struct Case {
    std::string text, expect;
  };
  const std::string t = kTube;
  const std::vector<Case> cases{
      {replaced(t, "plane_strain = true", "plane_strain = \"yes\""), "geometry.plane_strain = \"yes\": must be true or false"},
      {t + "[solver]\nmax_cutbacks = -1\n", "solver.max_cutbacks = -1"},
      {t + "[solver]\nkrylov_tolerance = -1\n", "solver.krylov_tolerance = -1"},
      {t + "[solver]\ntolerance = 1.5\n", "solver.tolerance = 1.5"},
      {replaced(t, "[1.0, 4.0]", "[nan, 4.0]"), "load.path[1][0] = nan: must be a finite number"},
      {replaced(t, "[1.0, 4.0]", "[1.0, inf]"), "load.path[1][1] = inf: must be a finite number"},
      {replaced(t, "[1.0, 4.0]", "[1.0, -2.0]"), "load.path[1][1] = -2: a volume ratio must be > 0"},
      {t + "[output]\nfields = [0.5, 2.0]\n", "output.fields[1] = 2: outside the load path [0, 1]"},
      {replaced(t, "outer_radius = 7.5", "outer_radius = 1e300"), "geometry.outer_radius = 1e+300: must lie in (0, 1e+06]"},
      {replaced(t, "outer_radius = 7.5", "outer_radius = 4"), "geometry.outer_radius = 4: must exceed geometry.inner_radius = 5"},
      {replaced(t, "radial_cells = 2", "radial_cells = 2.5"), "geometry.radial_cells = 2.5: must be a whole number"},
      {replaced(t, "radial_cells = 2", "radial_cells = 1e12"), "geometry.radial_cells"},
      {replaced(t, "sweep_deg = 90.0", "sweep_deg = 45.0"), "geometry.sweep_deg = 45: only 90 (quarter) or 360"},
      {replaced(t, "radial_cells", "radial_cell"), "geometry.radial_cell = 2: unknown key (did you mean 'radial_cells'?)"},
      {replaced(t, "length = 0.5", "thickness = 0.5"), "geometry.thickness = 0.5: not a key of geometry.type = \"tube\""},
      {replaced(t, "control = \"volume\"", "control = \"stretch\""), "load.control = \"stretch\""},
      {t + "[material_lower]\npreset = \"pdms\"\n", "material_lower: only for geometry.type = \"actuator\""},
      {replaced(t, "plane_strain = true", "plane_strain = true\ncap_thickness = 1.0"), "geometry.plane_strain = true: incompatible"},
  };
  for (const Case& c : cases) {
    const std::string msg = error_of(c.text);
    EXPECT_NE(msg.find(c.expect), std::string::npos) << "expected '" << c.expect << "' in: " << msg;
  }
}

TEST(MacroScene, PlateCellCountsAreRangedIntegers) {
  const std::string plate = R"(
[geometry]
type = "plate"
size = [10.0, 10.0, 0.5]
cells = [4, 4, 1]
[material]
preset = "ecoflex"
[load]
control = "stretch"
path = [[0.0, 1.0], [1.0, 1.5]]
)";
  EXPECT_EQ(parse(plate).spec.plate.cells[0], 4);
  EXPECT_NE(error_of(replaced(plate, "[4, 4, 1]", "[4, -4, 1]")).find("geometry.cells[1] = -4"), std::string::npos);
  EXPECT_NE(error_of(replaced(plate, "[4, 4, 1]", "[4, 4]")).find("geometry.cells"), std::string::npos);
  EXPECT_NE(error_of(replaced(plate, "[10.0, 10.0, 0.5]", "[10.0, 0.0, 0.5]")).find("geometry.size[1] = 0"), std::string::npos);
}

TEST(MacroScene, GmshBodyMustBeConstrained) {
  const fs::path file = kScenes / "macro_gmsh_tube.toml";
  std::ifstream in(file);
  const std::string text((std::istreambuf_iterator<char>(in)), {});
  EXPECT_NO_THROW(parse(text, file));
  // Without any [[boundary]] table.
  std::string none = text;
  for (std::size_t at; (at = none.find("[[boundary]]")) != std::string::npos;) {
    const std::size_t end = none.find("fix = ", at);
    none.erase(at, none.find('\n', end) + 1 - at);
  }
  std::string msg = error_of(none, file);
  EXPECT_NE(msg.find("boundary: the body is not constrained"), std::string::npos) << msg;
  msg = error_of(replaced(text, "fix = [\"z\"]", "fix = []"), file);
  EXPECT_NE(msg.find("boundary[0].fix = []"), std::string::npos) << msg;
  msg = error_of(replaced(text, "surface = \"zmin\"", "surface = \"zmni\""), file);
  EXPECT_NE(msg.find("boundary[0].surface = \"zmni\": no physical surface"), std::string::npos) << msg;
}

TEST(MacroScene, GmshPressureControlNeedsItsSurface) {
  // Without load.surface the pressure had nowhere to act: the run wrote a response.csv of zeros, exit 0.
  const fs::path file = kScenes / "macro_gmsh_tube.toml";
  std::ifstream in(file);
  const std::string text((std::istreambuf_iterator<char>(in)), {});
  const std::string msg = error_of(replaced(text, "surface = \"inner\"", ""), file);
  EXPECT_NE(msg.find("load.surface"), std::string::npos) << msg;
}

TEST(MacroScene, FieldTimesJoinTheOutputSteps) {
  const macro::MacroScene m = parse(std::string(kTube) + "[output]\nfields = [0.3, 1.0]\n");
  // 4 uniform steps (0.25, 0.5, 0.75, 1) plus 0.3.
  ASSERT_EQ(m.times.size(), 5u);
  EXPECT_DOUBLE_EQ(m.times[1], 0.3);
  EXPECT_TRUE(m.fields_at(0.3));
  EXPECT_TRUE(m.fields_at(1.0));
  EXPECT_FALSE(m.fields_at(0.5));
  EXPECT_FALSE(m.fields_at(0.0));
  EXPECT_FALSE(parse(std::string(kTube) + "[output]\nfields = false\n").fields_at(1.0));
}

TEST(MacroScene, KeyTablesDocumentEveryTable) {
  bool solver = false;
  for (const auto& t : macro::macro_scene_tables())
    if (t.path == "solver") {
      solver = true;
      for (const auto& k : t.keys)
        if (k.name == "max_newton_iterations") {
          EXPECT_EQ(k.default_value, "25");
          ASSERT_EQ(k.renamed_from.size(), 1u);
          EXPECT_EQ(k.renamed_from[0], "max_iterations");
        }
    }
  EXPECT_TRUE(solver);
}

TEST(MacroScene, HugeBoxIsRefusedUpFrontWithAnEstimate) {
  // 1000 x 1000 x 10 cells ≈ 3.3e7 dofs: far beyond any machine these tests run on (the estimate's
  // factorization alone is hundreds of GiB), refused while parsing, before any mesh is built.
  const std::string plate = R"(
[geometry]
type = "plate"
size = [10.0, 10.0, 0.5]
cells = [1000, 1000, 10]
[material]
preset = "ecoflex"
[load]
control = "stretch"
path = [[0.0, 1.0], [1.0, 1.5]]
)";
  const std::string msg = error_of(plate);
  EXPECT_NE(msg.find("geometry.cells"), std::string::npos) << msg;
  EXPECT_NE(msg.find("too large for this machine"), std::string::npos) << msg;
  EXPECT_NE(msg.find("GiB"), std::string::npos) << msg;
}

TEST(MacroScene, PetscSceneIsEstimatedWithoutAFactor) {
  // The same 3.3e7-dof box on the PETSc path is still refused (mesh and Krylov storage alone ~250 GiB),
  // but its estimate holds no factorization: the solver is read before the refusal.
  const std::string plate = R"(
[geometry]
type = "plate"
size = [10.0, 10.0, 0.5]
cells = [1000, 1000, 10]
[material]
preset = "ecoflex"
[load]
control = "stretch"
path = [[0.0, 1.0], [1.0, 1.5]]
[solver]
linear_solver = "petsc"
)";
  const std::string msg = error_of(plate);
  EXPECT_NE(msg.find("too large for this machine"), std::string::npos) << msg;
  EXPECT_NE(msg.find("PETSc"), std::string::npos) << msg;
  EXPECT_EQ(msg.find("factorization"), std::string::npos) << msg;
  EXPECT_NE(error_of(replaced(plate, "\"petsc\"", "\"cholmod\"")).find("factorization"), std::string::npos);
}
