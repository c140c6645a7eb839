// Calibration work that cannot finish is refused from its worst case before it starts, and curve data
// that would overflow the residual's norm are refused naming the curve.
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "softhom/io/scene.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/studies/calibration.hpp"
#include "studies/studies_test_helpers.hpp"

using namespace softhom;
using softhom::studies::testing::fresh_dir;
namespace fs = std::filesystem;

namespace {

}  // namespace

// starts × max_iterations × (2 · 1 free + 1) × 4 output times = 1000 · 100000 · 3 · 4 = 1.2e9 point
// steps > 1e9; a tenth of the starts (1.2e8) is accepted.
TEST(CalibrationEstimates, CalibrationWorkIsBoundedBeforeItStarts) {
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
  EXPECT_NE(e.find("solver.max_iterations = 100000: the fit may need up to 1.2e+09 material-point steps (1000 starts x 100000 "
                   "iterations x 3 evaluations per iteration x 4 load steps"),
            std::string::npos)
      << e;
  EXPECT_EQ(error_of("[solver]\nstarts = 100\nmax_iterations = 100000\n"), "");
  fs::remove_all(dir);
}

// A control byte in a curve cell went into the message raw (a NUL, now refused as a binary file, cut it
// and once reached the user as basic_string::substr's error); values of ±1e308 made the residual's normalising range inf and summary.json refused the fit's
// non-finite numbers after the run. Both are input errors naming the curve, the file and the line.
TEST(CalibrationEstimates, CurveCellsAreShownAsWrittenAndTheirRangeBounded) {
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
