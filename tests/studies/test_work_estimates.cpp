// Work that cannot finish is refused from its size before it starts (matrix-only grids, HDF5 images by
// their shape, calibration work), and keys that contradict the cell they describe are refused by name.
#include <gtest/gtest.h>

#include <hdf5.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "softhom/io/scene.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/materials/system_memory.hpp"
#include "softhom/studies/calibration.hpp"
#include "softhom/studies/rve_scene.hpp"

using namespace softhom;
namespace fs = std::filesystem;

namespace {

fs::path fresh_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("softhom_test_work_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

std::string rve_error(const std::string& text) {
  try {
    studies::parse_rve_scene(io::parse_scene(text, "test.toml"), true, {});
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

// 65536² pixels hold 32 B each (fraction and normal) = 128 GiB: beyond any machine that runs this suite,
// so the refusal is certain; the matrix-only path allocated it and ended in std::bad_alloc.
TEST(WorkEstimates, MatrixOnlyGridIsEstimatedLikeAFiberGrid) {
  if (available_memory_bytes() == 0) GTEST_SKIP() << "available memory unknown";
  for (const char* grid : {"[65536, 65536]", "[65536, 65536, 65536]"}) {
    const std::string e = rve_error(std::string("[microstructure]\nvolume_fraction = 0.0\ngrid = ") + grid + "\n" + kPhasesLoad);
    EXPECT_NE(e.find("microstructure.grid = [65536, 65536]: needs about 128 GiB"), std::string::npos) << e;
  }
  EXPECT_EQ(rve_error("[microstructure]\nvolume_fraction = 0.0\ngrid = [16, 8]\n" + kPhasesLoad), "");
}

// The image's shape is read first and refused before its values are: 60000² voxels need 40 B each
// (134 GiB), 4096³ voxels 2.6 TiB. Before, reading them ended in std::bad_alloc.
TEST(WorkEstimates, ChunkedImageIsRefusedFromItsShape) {
  if (available_memory_bytes() == 0) GTEST_SKIP() << "available memory unknown";
  const fs::path dir = fresh_dir("image");
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

TEST(WorkEstimates, CellKeysThatContradictTheShapeAreRefused) {
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

// starts × max_iterations × (2 · 1 free + 1) × 5 output times = 1000 · 100000 · 3 · 5 = 1.5e9 point
// steps > 1e9; one start fewer by a factor 10 (1.5e8) is accepted.
TEST(WorkEstimates, CalibrationWorkIsBoundedBeforeItStarts) {
  const fs::path dir = fresh_dir("calibration");
  std::ofstream(dir / "u.csv") << "F11,P11\n1.0,0\n1.1,0.01\n1.2,0.02\n";
  const std::string model = "[model]\nG = {value = 0.05, min = 0.001, max = 1.0}\nJm = 10\nK = 2000\n";
  const std::string curve = "\n[[curves]]\nname = \"tension\"\nfile = \"u.csv\"\nx = \"F11\"\ny = \"P11\"\n"
                            "[curves.load]\ntype = \"uniaxial\"\nstretch = 1.2\nsteps = 4\n";
  auto error_of = [&](const std::string& solver) {
    try {
      studies::parse_calibration(io::parse_scene(model + solver + curve, "<test>"), dir);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  const std::string e = error_of("[solver]\nstarts = 1000\nmax_iterations = 100000\n");
  EXPECT_NE(e.find("solver.max_iterations = 100000: the fit may need up to 1.5e+09 material-point steps (1000 starts x 100000 "
                   "iterations x 3 evaluations per iteration x 5 load steps"),
            std::string::npos)
      << e;
  EXPECT_EQ(error_of("[solver]\nstarts = 100\nmax_iterations = 100000\n"), "");
  fs::remove_all(dir);
}

// A control byte in a curve cell went into the message raw (a NUL, now refused as a binary file, cut it
// and once reached the user as basic_string::substr's error); values of ±1e308 made the residual's normalising range inf and summary.json refused the fit's
// non-finite numbers after the run. Both are input errors naming the curve, the file and the line.
TEST(WorkEstimates, CurveCellsAreShownAsWrittenAndTheirRangeBounded) {
  const fs::path dir = fresh_dir("curves");
  const std::string scene = "[model]\nG = {value = 0.05, min = 0.001, max = 1.0}\nJm = 10\nK = 2000\n"
                            "[[curves]]\nname = \"tension\"\nfile = \"u.csv\"\nx = \"F11\"\ny = \"P11\"\n"
                            "[curves.load]\ntype = \"uniaxial\"\nstretch = 1.2\nsteps = 4\n";
  auto error_with = [&](const std::string& csv) {
    std::ofstream(dir / "u.csv", std::ios::binary) << csv;
    try {
      studies::parse_calibration(io::parse_scene(scene, "<test>"), dir);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  const std::string control = error_with("F11,P11\n1.0,0\n1.1,0\x01\n1.2,0.02\n");
  EXPECT_NE(control.find("u.csv line 3: '0\\x01': not a finite number (column P11)"), std::string::npos) << control;
  const std::string range = error_with("F11,P11\n1.0,-1e308\n1.1,1e308\n1.2,0\n");
  EXPECT_NE(range.find("curves[0].y = P11: data y spans -1e+308 to 1e+308: too large for the residual"), std::string::npos) << range;
  fs::remove_all(dir);
}
