// Scene keys of the point and RVE scenes: every shipped scene, campaign and calibration parses with the
// declared keys, every declared key is documented in docs/keys.md, and the bad-input cases of the RVE
// scene are refused by name.
#include <gtest/gtest.h>

#include <hdf5.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <sstream>

#include "softhom/io/fields.hpp"
#include "softhom/io/scene.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/materials/scene_keys.hpp"
#include "softhom/materials/system_memory.hpp"
#include "softhom/studies/calibration.hpp"
#include "softhom/studies/campaign.hpp"
#include "softhom/studies/rve_fe_scene.hpp"
#include "softhom/studies/rve_scene.hpp"

using namespace softhom;
namespace fs = std::filesystem;

namespace {

const fs::path kSource = SOFTHOM_SOURCE_DIR;

std::vector<fs::path> tomls(const fs::path& dir, const std::string& prefix) {
  std::vector<fs::path> out;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ".toml" && e.path().filename().string().rfind(prefix, 0) == 0) out.push_back(e.path());
  std::sort(out.begin(), out.end());
  return out;
}

/// The InputError message of parsing `text` as an RVE scene (FFT engine), or "".
std::string rve_error(const std::string& text, const fs::path& out = {}) {
  try {
    studies::parse_rve_scene(io::parse_scene(text, "test.toml"), true, out);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

const std::string kPhasesLoad =
    "[phases.matrix]\nlaw = \"neo-hookean\"\nmu = 1\nK = 10\n[phases.fiber]\nlaw = \"neo-hookean\"\nmu = 10\nK = 100\n"
    "[load]\ntype = \"uniaxial\"\nstretch = 1.1\nsteps = 4\n";

/// A chunked uint8 dataset of `dims` with no chunk written: a few kB on disk whatever its shape.
void write_empty_chunked(const fs::path& file, const std::vector<hsize_t>& dims) {
  const hid_t f = H5Fcreate(file.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  ASSERT_GE(f, 0);
  const hid_t s = H5Screate_simple(int(dims.size()), dims.data(), nullptr);
  const hid_t plist = H5Pcreate(H5P_DATASET_CREATE);
  std::vector<hsize_t> chunk(dims.size(), 64);
  H5Pset_chunk(plist, int(chunk.size()), chunk.data());
  const hid_t d = H5Dcreate2(f, "/phase", H5T_NATIVE_UINT8, s, H5P_DEFAULT, plist, H5P_DEFAULT);
  ASSERT_GE(d, 0);
  H5Dclose(d);
  H5Pclose(plist);
  H5Sclose(s);
  H5Fclose(f);
}

}  // namespace

TEST(SceneKeys, EveryShippedPointAndRveSceneParses) {
  int point = 0, rve = 0;
  for (const auto& f : tomls(kSource / "studies/scenes", "point_")) {
    EXPECT_NO_THROW(parse_point_scene(io::load_scene(f))) << f;
    ++point;
  }
  for (const auto& f : tomls(kSource / "studies/scenes", "rve_")) {
    const toml::table t = io::load_scene(f);
    const std::string engine = t["solver"]["engine"].value_or(std::string("fft"));
    if (engine == "fe") {
      double vf = 0.0;
      std::string note;
      const rve::Section s = studies::parse_fe_section(*t["microstructure"].as_table(), vf, note);
      EXPECT_NO_THROW(studies::parse_fe_rve_solver(t, s.L1)) << f;
      EXPECT_NO_THROW(studies::parse_rve_phases(t)) << f;
      EXPECT_NO_THROW(studies::parse_rve_load(t)) << f;
    } else {
      EXPECT_NO_THROW(studies::parse_rve_scene(t)) << f;
    }
    ++rve;
  }
  EXPECT_GE(point, 5);  // the shipped sets: five point scenes, twelve RVE scenes
  EXPECT_GE(rve, 12);
}

TEST(SceneKeys, EveryShippedCampaignAndCalibrationParses) {
  // Their cases are RVE scenes and point scenes: expanding them parses every key they write.
  for (const auto& f : tomls(kSource / "studies/campaigns", ""))
    EXPECT_NO_THROW(studies::expand_campaign(io::load_scene(f), f.parent_path())) << f;
  // The chapter-4 calibrations read the store of a chapter-4 sweep (not in the source tree): past
  // their keys, that missing store is the only error they may give here.
  for (const auto& f : tomls(kSource / "studies/calibrations", "")) {
    try {
      studies::parse_calibration(io::load_scene(f), f.parent_path());
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("no campaign store there"), std::string::npos) << f << ": " << e.what();
    }
  }
}

TEST(SceneKeys, EveryDeclaredKeyIsDocumented) {
  std::ifstream in(kSource / "docs/keys.md");
  std::stringstream s;
  s << in.rdbuf();
  const std::string md = s.str();
  std::size_t keys = 0;
  for (const auto& [command, tables] : {std::pair{std::string("point"), point_scene_tables()},
                                        std::pair{std::string("rve"), studies::rve_scene_tables()}}) {
    const std::size_t scene = md.find("## softhom " + command + "\n");
    ASSERT_NE(scene, std::string::npos) << command;
    for (const auto& t : tables) {
      const std::size_t section = md.find("### [" + t.path + "]", scene);
      ASSERT_NE(section, std::string::npos) << command << " " << t.path;
      const std::size_t end = md.find("\n### ", section + 1);
      const std::string body = md.substr(section, end == std::string::npos ? std::string::npos : end - section);
      for (const auto& k : t.keys) {
        EXPECT_FALSE(k.doc.empty()) << t.path << "." << k.name;
        EXPECT_FALSE(k.type.empty()) << t.path << "." << k.name;
        EXPECT_FALSE(k.default_value.empty()) << t.path << "." << k.name;
        EXPECT_NE(body.find("| `" + k.name + "` |"), std::string::npos) << command << " " << t.path << "." << k.name;
        ++keys;
      }
    }
  }
  EXPECT_GT(keys, 100u);
}

TEST(SceneKeys, OutputFieldTimesMustBeOutputTimesOfTheLoadPath) {
  const std::string micro = "[microstructure]\ngrid = 8\n";
  EXPECT_EQ(rve_error(micro + kPhasesLoad + "[output]\nfields = [0.5, 1.0]\n"), "");
  EXPECT_NE(rve_error(micro + kPhasesLoad + "[output]\nfields = [0.5, -1.0]\n").find("output.fields[1] = -1: must be >= 0"),
            std::string::npos);
  EXPECT_NE(rve_error(micro + kPhasesLoad + "[output]\nfields = [2.0]\n").find("output.fields[0] = 2: after the end of the load path"),
            std::string::npos);
  EXPECT_NE(rve_error(micro + kPhasesLoad + "[output]\nfields = [0.3]\n").find("not an output time of the load path (nearest: 0.25)"),
            std::string::npos);
  EXPECT_NE(rve_error(micro + kPhasesLoad + "[output]\nfields = \"lats\"\n").find("(did you mean 'last'?)"), std::string::npos);
}

TEST(SceneKeys, GridAndFiberCountAreBounded) {
  for (const auto& [grid, message] : {std::pair{"1e12", "microstructure.grid = 1e+12: must lie in [1, 65536]"},
                                      std::pair{"[64, 3e9]", "microstructure.grid[1] = 3e+09: must lie in [1, 65536]"},
                                      std::pair{"0.5", "microstructure.grid = 0.5: must be a whole number"},
                                      std::pair{"-16", "microstructure.grid = -16: must lie in [1, 65536]"},
                                      std::pair{"[8]", "microstructure.grid = [8]: must be a list of 2 to 3 integers"}})
    EXPECT_NE(rve_error(std::string("[microstructure]\ngrid = ") + grid + "\n" + kPhasesLoad).find(message), std::string::npos)
        << grid;
  const std::string random = "[microstructure]\nshape = \"circle\"\narrangement = \"random\"\nvolume_fraction = 0.2\n";
  EXPECT_NE(rve_error(random + "fiber_count = 1e6\ngrid = 32\n" + kPhasesLoad).find("microstructure.fiber_count = 1e+06: must lie in [1, 10000]"),
            std::string::npos);
  // 0.2 · 32² / 100 = 2 pixels per fiber < 4: at most 51 fibers on this grid.
  EXPECT_NE(rve_error(random + "fiber_count = 100\ngrid = 32\n" + kPhasesLoad).find("at least 4 are needed (at most 51 fibers)"),
            std::string::npos);
  EXPECT_NE(rve_error("[microstructure]\nseed = -1\n" + kPhasesLoad).find("microstructure.seed = -1: must be >= 0"), std::string::npos);
  EXPECT_NE(rve_error("[microstructure]\nseed = 1e300\n" + kPhasesLoad).find("microstructure.seed = 1e+300: must be a whole number"),
            std::string::npos);
}

TEST(SceneKeys, SolverKeysAreTypedAndRenamedOnesRefused) {
  const std::string base = "[microstructure]\ngrid = 8\n" + kPhasesLoad;
  EXPECT_NE(rve_error(base + "[solver]\nmixed_pressure = \"no\"\n").find("solver.mixed_pressure = \"no\": must be true or false"),
            std::string::npos);
  EXPECT_NE(rve_error(base + "[solver]\nmax_cutbacks = 1e12\n").find("solver.max_cutbacks = 1e+12: must lie in [0, 60]"),
            std::string::npos);
  EXPECT_NE(rve_error(base + "[solver]\nscheme = \"newton_cg\"\n").find("renamed to \"newton-cg\""), std::string::npos);
  EXPECT_NE(rve_error(base + "[solver]\ntarget_error = 0.01\n").find("only with engine = \"auto\""), std::string::npos);
  EXPECT_NE(rve_error(base + "[solver]\nmax_step_seconds = -1\n").find("solver.max_step_seconds = -1: must be >= 0"),
            std::string::npos);
  const auto s = studies::parse_rve_scene(io::parse_scene(base + "[solver]\nmax_step_seconds = 30\nmax_newton_iterations = 7\n", "x"));
  EXPECT_EQ(s.solver.max_step_seconds, 30.0);
  EXPECT_EQ(s.solver.max_newton_iterations, 7);
}

TEST(SceneKeys, WisdomFilesStayUnderOutOrTheCache) {
  const fs::path out = fs::temp_directory_path() / "softhom-keys-out";
  const std::string base = "[microstructure]\ngrid = 8\n" + kPhasesLoad + "[solver]\nfftw_wisdom = ";
  const auto wisdom = [&](const std::string& value) {
    return studies::parse_rve_scene(io::parse_scene(base + "\"" + value + "\"\n", "x"), true, out).solver.plan.wisdom_file;
  };
  EXPECT_EQ(wisdom("plans/fftw.wisdom"), out / "plans/fftw.wisdom");
  EXPECT_EQ(wisdom((out / "w").string()), out / "w");
  EXPECT_EQ(wisdom((studies::user_cache_dir() / "w").string()), studies::user_cache_dir() / "w");
  EXPECT_NE(rve_error(base + "\"../escape\"\n", out).find("solver.fftw_wisdom = \"../escape\": escapes"), std::string::npos);
  EXPECT_NE(rve_error(base + "\"/etc/fftw.wisdom\"\n", out).find("solver.fftw_wisdom = \"/etc/fftw.wisdom\": outside --out"),
            std::string::npos);
  // Without an output directory (campaign cases), relative paths are relative to the cache.
  EXPECT_EQ(studies::resolve_run_file("w", {}, "f"), studies::user_cache_dir() / "w");
}

TEST(SceneKeys, ImageWithAllZeroNormalsIsRefused) {
  const fs::path dir = fs::temp_directory_path() / ("softhom-keys-image-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  io::VoxelGrid g;
  g.cells = {4, 4, 1};
  std::vector<double> fraction(16, 0.0);
  fraction[5] = 0.5;  // one composite voxel
  fraction[6] = 1.0;
  io::write_voxel_image(dir / "cell", g, {{"fiber_fraction", fraction, 1, false}, {"normal", std::vector<double>(48, 0.0), 3, false}});
  const std::string scene = "[microstructure.image]\nfile = \"" + (dir / "cell.h5").string() +
                            "\"\ndataset = \"/fiber_fraction\"\nnormal_dataset = \"/normal\"\n" + kPhasesLoad;
  EXPECT_NE(rve_error(scene).find("microstructure.image.normal_dataset = /normal: every vector is zero"), std::string::npos)
      << rve_error(scene);
  fs::remove_all(dir);
}

TEST(SceneKeys, FeSolverKeysFillTheFeOptions) {
  const auto settings = [](const std::string& solver) {
    return studies::parse_fe_rve_solver(io::parse_scene("[solver]\nengine = \"fe\"\n" + solver, "x"), 0.8);
  };
  // Defaults follow the cell side: L1 / 16 and a third of it at the interfaces (section mesh).
  const auto d = settings("");
  EXPECT_DOUBLE_EQ(d.mesh.mesh_size, 0.05);
  EXPECT_DOUBLE_EQ(d.mesh.interface_size, 0.05 / 3.0);
  EXPECT_EQ(d.solver.pressure, rve::FePressure::p1_bubble);
  const auto three = settings("fe_mesh = \"3d\"\nlength = 2\nmax_step_seconds = 5\nlinear_solver = \"umfpack\"\n");
  EXPECT_TRUE(three.three_d);
  EXPECT_DOUBLE_EQ(three.mesh3d.mesh_size, 0.8 / 6.0);
  EXPECT_DOUBLE_EQ(three.mesh3d.length, 2.0);
  EXPECT_EQ(three.solver.pressure, rve::FePressure::p0);
  EXPECT_EQ(three.solver.max_step_seconds, 5.0);
  EXPECT_TRUE(three.solver.use_umfpack);
  const auto error = [&](const std::string& solver) {
    try {
      settings(solver);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(error("fe_mesh = \"3d\"\npressure = \"p1\"\n").find("solver.pressure = \"p1\": the 3D tetrahedral mesh supports p0"),
            std::string::npos);
  EXPECT_NE(error("length = 2\n").find("solver.length = 2: only with fe_mesh = \"3d\""), std::string::npos);
  EXPECT_NE(error("corner_exponent = 1\n").find("solver.corner_exponent = 1: must lie in (0, 1)"), std::string::npos);
  EXPECT_NE(error("discretization = \"rotated\"\n").find("solver.discretization = \"rotated\": unknown key"), std::string::npos);
}

TEST(SceneKeys, PointSolverKeys) {
  const auto t = io::parse_scene("[solver]\nmax_newton_iterations = 40\nmax_step_seconds = 2.5\ntolerance = 1e-9\n", "x");
  const PointSolverOptions o = parse_point_solver(t.get("solver"));
  EXPECT_EQ(o.max_iterations, 40);
  EXPECT_EQ(o.max_step_seconds, 2.5);
  EXPECT_EQ(o.tolerance, 1e-9);
  EXPECT_EQ(o.max_cutbacks, PointSolverOptions{}.max_cutbacks);
}

// 65536² pixels hold 32 B each (fraction and normal) = 128 GiB: beyond any machine that runs this suite,
// so the refusal is certain; the matrix-only path allocated it and ended in std::bad_alloc.
TEST(SceneKeys, MatrixOnlyGridIsEstimatedLikeAFiberGrid) {
  if (available_memory_bytes() == 0) GTEST_SKIP() << "available memory unknown";
  for (const char* grid : {"[65536, 65536]", "[65536, 65536, 65536]"}) {
    const std::string e = rve_error(std::string("[microstructure]\nvolume_fraction = 0.0\ngrid = ") + grid + "\n" + kPhasesLoad);
    EXPECT_NE(e.find("microstructure.grid = [65536, 65536]: needs about 128 GiB"), std::string::npos) << e;
  }
  EXPECT_EQ(rve_error("[microstructure]\nvolume_fraction = 0.0\ngrid = [16, 8]\n" + kPhasesLoad), "");
}

// The image's shape is read first and refused before its values are: 60000² voxels need 40 B each
// (134 GiB), 4096³ voxels 2.6 TiB. Before, reading them ended in std::bad_alloc.
TEST(SceneKeys, ChunkedImageIsRefusedFromItsShape) {
  if (available_memory_bytes() == 0) GTEST_SKIP() << "available memory unknown";
  const fs::path dir = fs::temp_directory_path() / ("softhom_test_big_image_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  for (const auto& [dims, shape] : {std::pair{std::vector<hsize_t>{60000, 60000}, std::string("[60000, 60000]")},
                                    std::pair{std::vector<hsize_t>{4096, 4096, 4096}, std::string("[4096, 4096, 4096]")}}) {
    const fs::path file = dir / "big.h5";
    write_empty_chunked(file, dims);
    ASSERT_LT(fs::file_size(file), 1u << 20);
    const std::string e = rve_error("[microstructure.image]\nfile = \"" + file.string() + "\"\n" + kPhasesLoad);
    EXPECT_NE(e.find("microstructure.image.dataset = /phase " + shape + ": needs about"), std::string::npos) << e;
  }
  fs::remove_all(dir);
}

TEST(SceneKeys, CellKeysThatContradictTheShapeAreRefused) {
  const std::string circle = "[microstructure]\nshape = \"circle\"\nvolume_fraction = 0.2\ngrid = 16\n";
  const std::string rect = "[microstructure]\nshape = \"rectangle\"\nvolume_fraction = 0.2\ngrid = 16\n";
  const std::string square = "[microstructure]\nshape = \"square\"\nvolume_fraction = 0.2\ngrid = 16\n";
  EXPECT_NE(rve_error(circle + "width = 0.1\n" + kPhasesLoad).find("microstructure.width = 0.1: applies to rectangle and square"),
            std::string::npos);
  EXPECT_NE(rve_error(circle + "section_rotation_deg = 10\n" + kPhasesLoad).find("microstructure.section_rotation_deg = 10"),
            std::string::npos);
  EXPECT_NE(rve_error(rect + "radius = 0.1\n" + kPhasesLoad).find("microstructure.radius = 0.1: applies to circular fibers"),
            std::string::npos);
  EXPECT_NE(rve_error(square + "width = 0.1\nheight = 0.2\n" + kPhasesLoad).find("microstructure.height = 0.2: a square's height"),
            std::string::npos);
  EXPECT_EQ(rve_error(square + "width = 0.1\nheight = 0.1\n" + kPhasesLoad), "");
  EXPECT_NE(rve_error(circle + "fiber_count = 3\n" + kPhasesLoad).find("microstructure.fiber_count = 3: applies to arrangement = \"random\""),
            std::string::npos);
  // A composite scene at fraction 0 is its matrix's reference: the fiber keys stay accepted.
  EXPECT_EQ(rve_error("[microstructure]\nshape = \"circle\"\nradius = 0.2\nwidth = 0.1\nvolume_fraction = 0\ngrid = 8\n" + kPhasesLoad), "");
}
