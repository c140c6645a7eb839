// Calibration files: every shipped calibration parses (the campaign-based ones up to their store,
// which a sweep creates), renamed spellings say their new name, CSV errors name the curve field, the
// file and the line, and response.csv names its curves.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "softhom/io/scene.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/studies/calibration.hpp"
#include "studies/studies_test_helpers.hpp"

namespace fs = std::filesystem;
using namespace softhom;
using softhom::studies::testing::fresh_dir;

namespace {

const fs::path kCalibrations = fs::path(SOFTHOM_SOURCE_DIR) / "studies/calibrations";

std::string error_of(const std::string& text, const fs::path& dir) {
  try {
    studies::parse_calibration(io::parse_scene(text, "<test>"), dir);
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

const char* kKeysModel = "[model]\nG = {value = 0.05, min = 0.001, max = 1.0}\nJm = 10\nK = 2000\n";
const char* kCurve = "\n[[curves]]\nname = \"tension\"\nfile = \"u.csv\"\nx = \"F11\"\ny = \"P11\"\n"
                     "[curves.load]\ntype = \"uniaxial\"\nstretch = 1.2\nsteps = 4\n";

void write(const fs::path& p, const std::string& text) {
  std::ofstream(p) << text;
}

}  // namespace

TEST(CalibrationKeys, EveryShippedCalibrationParses) {
  int n = 0;
  for (const auto& e : fs::directory_iterator(kCalibrations)) {
    if (e.path().extension() != ".toml") continue;
    SCOPED_TRACE(e.path().filename().string());
    const toml::table t = io::load_scene(e.path());
    try {
      const studies::CalibrationInput in = studies::parse_calibration(t, e.path().parent_path());
      EXPECT_FALSE(in.curves.empty());
    } catch (const InputError& err) {
      // Campaign curves read a sweep store made by `softhom sweep studies/campaigns/chapter4.toml`;
      // everything before the store (model, solver, output, the curve's keys) has been checked then.
      EXPECT_NE(std::string(err.what()).find("no campaign store there"), std::string::npos) << err.what();
    }
    ++n;
  }
  EXPECT_GE(n, 5);
}

TEST(CalibrationKeys, RenamedAndMistypedKeys) {
  const fs::path dir = fresh_dir("renamed");
  write(dir / "u.csv", "F11,P11\n1.0,0\n1.1,0.01\n1.2,0.02\n");
  EXPECT_EQ(error_of(std::string(kKeysModel) + kCurve, dir), "no error");
  std::string msg = error_of(std::string(kKeysModel) + "[solver]\nmethod = \"levenberg_marquardt\"\n" + kCurve, dir);
  EXPECT_NE(msg.find("solver.method = \"levenberg_marquardt\": renamed to \"levenberg-marquardt\""), std::string::npos) << msg;
  msg = error_of(std::string(kKeysModel) + "[solver]\nstarts = 2.5\n" + kCurve, dir);
  EXPECT_NE(msg.find("solver.starts = 2.5: must be a whole number"), std::string::npos) << msg;
  msg = error_of(std::string(kKeysModel) + "[output]\nplot = \"no\"\n" + kCurve, dir);
  EXPECT_NE(msg.find("output.plot = \"no\": must be true or false"), std::string::npos) << msg;
  msg = error_of(std::string(kKeysModel) + "[solver]\npoint_tolerence = 1e-9\n" + kCurve, dir);
  EXPECT_NE(msg.find("did you mean 'point_tolerance'"), std::string::npos) << msg;
  msg = error_of(std::string(kKeysModel) + kCurve + "weigth = 2\n", dir);
  EXPECT_NE(msg.find("curves[0].load.weigth"), std::string::npos) << msg;  // after [curves.load]: its key
}

TEST(CalibrationKeys, CsvErrorsNameTheCurveFieldFileAndLine) {
  const fs::path dir = fresh_dir("csv");
  write(dir / "u.csv", "F11,P11\n1.0,0\n1.1,abc\n1.2,0.02\n");
  std::string msg = error_of(std::string(kKeysModel) + kCurve, dir);
  EXPECT_NE(msg.find("curves[0].file"), std::string::npos) << msg;
  EXPECT_NE(msg.find("u.csv line 3"), std::string::npos) << msg;
  EXPECT_NE(msg.find("'abc'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("column P11"), std::string::npos) << msg;
  write(dir / "u.csv", "F11,P11\n1.0,0\n1.1\n");
  msg = error_of(std::string(kKeysModel) + kCurve, dir);
  EXPECT_NE(msg.find("u.csv line 3"), std::string::npos) << msg;
  EXPECT_NE(msg.find("1 fields, the header has 2"), std::string::npos) << msg;
}

TEST(CalibrationKeys, CsvWithAByteOrderMarkReadsLikeWithout) {
  // "CSV UTF-8" of spreadsheet programs starts with EF BB BF; before its comment line was taken for the
  // header (3 fields by its commas) and line 2 was refused ("2 fields, the header has 3").
  const fs::path dir = fresh_dir("csv-bom");
  write(dir / "u.csv", "\xEF\xBB\xBF# exported, two columns, no units\nF11,P11\n1.0,0\n1.1,abc\n");
  const std::string msg = error_of(std::string(kKeysModel) + kCurve, dir);
  EXPECT_NE(msg.find("u.csv line 4"), std::string::npos) << msg;  // the header was read, the data row named
  EXPECT_NE(msg.find("column P11"), std::string::npos) << msg;
}

TEST(CalibrationKeys, ResponseCsvNamesItsCurves) {
  studies::CalibrationResult r;
  studies::CurveFit a;
  a.name = "tension";
  a.ok = true;
  a.x = {1.0, 1.1};
  a.data = {0.0, 0.1};
  a.model = {0.0, 0.125};
  r.curves.push_back(a);
  a.name = "shear";
  a.x = {0.5};
  a.data = {0.25};
  a.model = {0.3};
  r.curves.push_back(a);
  EXPECT_EQ(studies::comparison_csv(r), "curve,index,x,data,model\ntension,0,1,0,0\ntension,0,1.1,0.1,0.125\nshear,1,0.5,0.25,0.3\n");
}

TEST(CalibrationKeys, KeyTablesForTheCalibrateCommand) {
  bool method = false;
  for (const auto& t : studies::calibration_tables())
    for (const auto& key : t.keys)
      if (t.path == "solver" && key.name == "method") {
        method = true;
        EXPECT_EQ(key.default_value, "\"levenberg-marquardt\"");
      }
  EXPECT_TRUE(method);
}
