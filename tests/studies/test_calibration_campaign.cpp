// Calibration curves read from a campaign store (campaign = "DIR", case = "ID", load_rotation_deg).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <numbers>

#include "softhom/io/scene.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/studies/calibration.hpp"
#include "softhom/studies/campaign.hpp"
#include "softhom/studies/rve_scene.hpp"

namespace fs = std::filesystem;
using namespace softhom;
using namespace softhom::studies;

namespace {

/// A store with one case: a scene whose [load] is tension to 1.3 in 3 steps, and three response rows.
fs::path make_store() {
  const fs::path d = fs::temp_directory_path() / ("softhom_test_calcamp_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  CaseRecord r;
  r.id = "cellA-tension";
  r.status = "ok";
  r.parameters = {{"matrix", std::string("pdms")}, {"angle", 60.0}};
  r.scene_text = "[load]\ntype = \"uniaxial\"\nstretch = 1.3\nduration = 1.0\nsteps = 3\n";
  r.scene_hash = std::string("0");  // not a literal assign: GCC 12 -Wrestrict false positive
  r.columns = rve_response_columns();
  const std::size_t nc = r.columns.size();
  for (int row = 0; row < 4; ++row) {
    std::vector<double> v(nc, 0.0);
    v[0] = row / 3.0;              // t
    v[1] = 1.0 + 0.1 * row;        // F11
    v[10] = 0.5 * row;             // P11
    r.data.insert(r.data.end(), v.begin(), v.end());
  }
  write_store(d / "campaign.h5", {{r.id, r}}, "test store");
  return d;
}

const char* kModel = R"(
[model]
G = {value = 0.5, min = 0.1, max = 2.0}
Jm = 5
K = 2000
k1 = 0.1
k2 = 1.0
fiber_invariant = "full"
[[model.fibers]]
angle_deg = 45
)";

}  // namespace

TEST(CalibrationCampaign, CurvesFromAStoreWithTheCaseLoadAndARotation) {
  const fs::path d = make_store();
  const std::string text = std::string(kModel) +
                           "[[curves]]\ncampaign = \"" + d.string() + "\"\ncase = \"cellA-tension\"\n"
                           "load_rotation_deg = 15\nx = \"F11\"\ny = \"P11\"\n";
  const CalibrationInput in = parse_calibration(io::parse_scene(text, "<test>"), d);
  ASSERT_EQ(in.curves.size(), 1u);
  const CalCurve& c = in.curves[0];
  EXPECT_EQ(c.name, "cellA-tension");  // default name: the case id
  ASSERT_EQ(c.x_data.size(), 4u);
  EXPECT_DOUBLE_EQ(c.x_data[3], 1.3);
  EXPECT_DOUBLE_EQ(c.y_data[2], 1.0);
  // The load comes from the stored scene: 3 output steps to t = 1, F11 prescribed to 1.3.
  ASSERT_EQ(c.control.times.size(), 3u);
  EXPECT_NEAR(c.control.value[0](1.0), 1.3, 1e-15);
  // The load frame is turned by +15° about e3: load axis (cos 15°, sin 15°, 0).
  const double b = 15.0 * std::numbers::pi / 180.0;
  EXPECT_NEAR(c.control.frame(0, 0), std::cos(b), 1e-15);
  EXPECT_NEAR(c.control.frame(1, 0), std::sin(b), 1e-15);
  EXPECT_NEAR(c.control.frame(0, 1), -std::sin(b), 1e-15);
  EXPECT_NEAR(c.control.frame(2, 2), 1.0, 1e-15);

  // A missing case names the field and the store.
  const std::string bad = std::string(kModel) + "[[curves]]\ncampaign = \"" + d.string() + "\"\ncase = \"nope\"\n"
                          "x = \"F11\"\ny = \"P11\"\n";
  try {
    parse_calibration(io::parse_scene(bad, "<test>"), d);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "curves[0].case");
  }
  // Two sources at once are rejected.
  const std::string two = std::string(kModel) + "[[curves]]\ncampaign = \"" + d.string() +
                          "\"\ncase = \"cellA-tension\"\nfile = \"x.csv\"\nx = \"F11\"\ny = \"P11\"\n";
  EXPECT_THROW(parse_calibration(io::parse_scene(two, "<test>"), d), InputError);
  fs::remove_all(d);
}
