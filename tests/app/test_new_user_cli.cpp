// What a new user meets at the command line: a mistyped subcommand, the shipped examples, the OpenMP
// wait policy the program starts itself with, the default thread count of a small cell, and
// plausibility warnings of implausible moduli.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>

#include "cli_helpers.hpp"
#include "softhom/core/input_error.hpp"
#include "softhom/jobs/thread_defaults.hpp"
#include "softhom/materials/plausibility.hpp"
#include "softhom/studies/cell.hpp"

namespace fs = std::filesystem;
using softhom::test::fresh_dir;
using softhom::test::read_json;
using softhom::test::run_softhom;

namespace {

}  // namespace

TEST(NewUserCli, MistypedSubcommandSuggestsTheNearestOne) {
  const auto r = run_softhom("rev studies/scenes/rve_ecoflex_circ45.toml");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("unknown subcommand 'rev' (did you mean 'rve'?)"), std::string::npos) << r.output;
  const auto far = run_softhom("frobnicate");
  EXPECT_EQ(far.exit_code, 2);
  EXPECT_EQ(far.output.find("did you mean"), std::string::npos) << far.output;  // nothing within two edits
}

TEST(NewUserCli, ExamplesAreListedAndCopiedWithWhatTheyName) {
  const auto list = run_softhom("examples list");
  ASSERT_EQ(list.exit_code, 0) << list.output;
  for (const char* name : {"scenes/rve_ecoflex_circ45", "devices/gripper_coarse", "campaigns/chapter4",
                           "calibrations/example_point", "python/fiber_angle_sweep", "plots/plot_campaign"})
    EXPECT_NE(list.output.find(name), std::string::npos) << name;
  const fs::path dir = fresh_dir("examples");
  const auto copy = run_softhom("examples copy macro_gmsh_tube " + dir.string());
  ASSERT_EQ(copy.exit_code, 0) << copy.output;
  EXPECT_TRUE(fs::is_regular_file(dir / "scenes" / "macro_gmsh_tube.toml"));
  EXPECT_TRUE(fs::is_regular_file(dir / "meshes" / "tube_quarter_tet10.msh"));  // ../meshes as the scene names it
  const auto cal = run_softhom("examples copy calibrations/example_point " + dir.string());
  ASSERT_EQ(cal.exit_code, 0) << cal.output;
  EXPECT_TRUE(fs::is_regular_file(dir / "calibrations" / "data" / "uniaxial_fiber45.csv"));
  // The same copy again is a no-op; a changed file is not overwritten.
  EXPECT_EQ(run_softhom("examples copy macro_gmsh_tube " + dir.string()).exit_code, 0);
  std::ofstream(dir / "scenes" / "macro_gmsh_tube.toml") << "# mine\n";
  const auto again = run_softhom("examples copy macro_gmsh_tube " + dir.string());
  EXPECT_EQ(again.exit_code, 2);
  EXPECT_NE(again.output.find("exists with other contents"), std::string::npos) << again.output;
  const auto unknown = run_softhom("examples copy rve_ecoflex_circ46 " + dir.string());
  EXPECT_EQ(unknown.exit_code, 2);
  EXPECT_NE(unknown.output.find("scenes/rve_ecoflex_circ45"), std::string::npos) << unknown.output;
  fs::remove_all(dir);
}

TEST(NewUserCli, SmallCellRunsOnOneThreadWithPassiveWaiting) {
  // The program starts itself again with OMP_WAIT_POLICY=passive (the run's own environment is read from
  // /proc by a wrapper that prints it); without --threads a 32² cell (1024 voxels) runs on one thread.
  const fs::path dir = fresh_dir("threads");
  fs::create_directories(dir);
  const auto r = run_softhom("rve " + softhom::test::scene("rve_homogeneous") + " --out " + dir.string() + " -q",
                             "-u OMP_NUM_THREADS -u OMP_WAIT_POLICY -u SOFTHOM_REEXEC");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(read_json(dir / "summary.json")["threads"].get<int>(), 1);
  EXPECT_EQ(read_json(dir / "summary.json")["omp_wait_policy"].get<std::string>(), "passive");
  // A policy the user set is kept (and no restart happens).
  const auto active = run_softhom("rve " + softhom::test::scene("rve_homogeneous") + " --out " + dir.string() + " -q",
                                  "-u OMP_NUM_THREADS OMP_WAIT_POLICY=active");
  ASSERT_EQ(active.exit_code, 0) << active.output;
  EXPECT_EQ(read_json(dir / "summary.json")["omp_wait_policy"].get<std::string>(), "active");
  fs::remove_all(dir);
}

TEST(NewUserCli, ImplausibleModuliWarnInTheSummaryAndOnStderr) {
  // G = 17000 "MPa" (17 kPa in Pa) with K = 2000: Poisson's ratio (3K - 2G) / (2 (3K + G)) = -0.6087.
  const std::string scene = softhom::test::write_temp_scene(
      "plausibility", "[material]\nlaw = \"neo-hookean\"\nmu = 17000\nK = 2000\n"
                      "[load]\ntype = \"uniaxial\"\nstretch = 1.01\nsteps = 1\n");
  const fs::path dir = fresh_dir("plausibility");
  const auto r = run_softhom("point " + scene + " --out " + dir.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;  // a warning, not an error
  EXPECT_NE(r.output.find("warning: plausibility: material: G = 17000 MPa, K = 2000 MPa give Poisson's ratio -0.6087"),
            std::string::npos)
      << r.output;
  const auto warnings = read_json(dir / "summary.json")["warnings"];
  ASSERT_GE(warnings.size(), 2u);  // the negative ratio and the modulus of a hard solid
  EXPECT_NE(warnings[1].get<std::string>().find("17000 Pa would be 0.017 MPa"), std::string::npos) << warnings;
  fs::remove_all(dir);
}

TEST(Plausibility, ClosedFormPoissonRatioAndThresholds) {
  using softhom::MaterialRole;
  using softhom::plausibility_warnings;
  // Ecoflex (G = 0.017, K = 2000) as a matrix: ν = 0.499996, K/G ≈ 1.2e5: nothing to say.
  EXPECT_TRUE(plausibility_warnings(0.017, 2000.0, MaterialRole::matrix, "phases.matrix").empty());
  // Real glass as a fiber (G = 29508, K = 42857 MPa for E = 72 GPa, ν = 0.22): fine as a fiber.
  EXPECT_TRUE(plausibility_warnings(29508.0, 42857.0, MaterialRole::fiber, "phases.fiber").empty());
  // The same as a matrix: a hard solid, and K/G = 1.45 compressible.
  EXPECT_EQ(plausibility_warnings(29508.0, 42857.0, MaterialRole::matrix, "phases.matrix").size(), 2u);
  // K/G = 50 as a matrix: ν = 0.490 < 0.495 → compressible; K/G = 100 (ν = 0.4950) is not flagged.
  EXPECT_EQ(plausibility_warnings(0.1, 5.0, MaterialRole::matrix, "m").size(), 1u);
  EXPECT_TRUE(plausibility_warnings(0.1, 10.0, MaterialRole::matrix, "m").empty());
  // K = 2G/3 is ν = 0 exactly: not negative; just below it is.
  EXPECT_TRUE(plausibility_warnings(3.0, 2.0, MaterialRole::fiber, "f").empty());
  EXPECT_EQ(plausibility_warnings(3.0, 1.99, MaterialRole::fiber, "f").size(), 1u);
}

TEST(ThreadDefaults, OneThreadPer2048VoxelsUpToTheCores) {
  using softhom::jobs::default_thread_count;
  EXPECT_EQ(default_thread_count(32 * 32, 2048, 2), 1);   // the 32² section of rve_ecoflex_circ45
  EXPECT_EQ(default_thread_count(64 * 64, 2048, 2), 2);
  EXPECT_EQ(default_thread_count(64 * 64, 2048, 1), 1);   // never more than OpenMP would use
  EXPECT_EQ(default_thread_count(256 * 256 * 256, 2048, 8), 8);
  EXPECT_EQ(default_thread_count(0, 2048, 4), 1);
  // Macro meshes: one thread per 16 384 free dofs (BENCHMARKS.md, "Default threads").
  using softhom::jobs::kFreeDofsPerDefaultThread;
  EXPECT_EQ(default_thread_count(1152, kFreeDofsPerDefaultThread, 2), 1);    // macro_tube_plane_strain
  EXPECT_EQ(default_thread_count(30188, kFreeDofsPerDefaultThread, 2), 1);   // cpasmo_gent_coarse
  EXPECT_EQ(default_thread_count(103680, kFreeDofsPerDefaultThread, 2), 2);  // the tube at 80 x 320 cells
}

TEST(NewUserCli, ProgressLinesShowSixDigitsOfTime) {
  // 3 steps over 1 s: t = 1/3 is 0.3333333333333333 to round-trip digits, 0.333333 to six.
  const std::string scene = softhom::test::write_temp_scene(
      "progress", "[material]\npreset = \"ecoflex\"\n[load]\ntype = \"uniaxial\"\nstretch = 1.1\nsteps = 3\n");
  const fs::path dir = fresh_dir("progress");
  const auto r = run_softhom("point " + scene + " --out " + dir.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("t = 0.333333 / 1"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("0.3333333"), std::string::npos) << r.output;
  fs::remove_all(dir);
}

TEST(CellFacade, FromFileAndFromTomlAgreeAndAPathAsTextIsNamed) {
  const std::string path = softhom::test::scene("rve_homogeneous");
  auto a = softhom::studies::Cell::from_file(path);
  std::ifstream in(path);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto b = softhom::studies::Cell::from_toml(text);
  EXPECT_EQ(a.describe(), b.describe());
  try {
    softhom::studies::Cell c(path);  // the text constructor given a file name
    FAIL() << "a file name was parsed as TOML";
  } catch (const softhom::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("from_file"), std::string::npos) << e.what();
  }
}
