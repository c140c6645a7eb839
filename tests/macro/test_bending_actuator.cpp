// The fiber-wrapped bending actuator (studies/structures/bending_actuator_*.toml) and its gauge
// (macro/bending_gauge.hpp): the end rotation of a rigid motion is its angle, also beyond 180°; the
// coarse actuator with tied fibers bends toward its strain-limiting half with its free end turned by
// twice its chord angle, as a circular arc does.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "softhom/io/scene.hpp"
#include "softhom/macro/bending_gauge.hpp"
#include "softhom/macro/devices.hpp"
#include "softhom/macro/scene.hpp"

using namespace softhom;

TEST(BendingActuator, EndRotationOfARigidMotionIsItsAngle) {
  // A ring of the free end at z = 100 turned about the x axis through the clamp's centre and shifted:
  // the polar factor of a rigid motion is its rotation, so θ comes back to round-off (1e-9 deg).
  std::vector<Vec3> X, x;
  std::vector<int> end;
  for (int k = 0; k < 12; ++k) {
    const double a = 2 * M_PI * k / 12;
    X.emplace_back(7.0 * std::cos(a), 7.0 * std::sin(a), 100.0);
    end.push_back(k);
  }
  for (double theta : {30.0, 150.0, 250.0}) {
    const Mat3 R = Eigen::AngleAxisd(-theta * M_PI / 180, Vec3::UnitX()).toRotationMatrix();  // toward −y
    x.clear();
    for (const Vec3& p : X) x.push_back(R * p + Vec3(0.0, 3.0, -2.0));
    const double chord = theta / 2;  // what the arc's chord angle tells the gauge
    EXPECT_NEAR(macro::end_rotation_deg(end, X, x, chord), theta, 1e-9) << theta;
  }
}

TEST(BendingActuator, TiedFibersBendItTowardTheStrainLimitingHalfAsAnArc) {
  const std::filesystem::path file =
      std::filesystem::path(SOFTHOM_SOURCE_DIR) / "studies/structures/bending_actuator_coarse.toml";
  std::ifstream in(file);
  std::stringstream text;
  text << in.rdbuf();
  const macro::MacroScene ms = macro::parse_macro_scene(io::parse_scene(text.str(), file.string()), file);
  ASSERT_EQ(ms.device.kind, macro::DeviceKind::bending);
  const macro::Structure s = macro::build_structure(ms.spec);
  fe::Simulation sim(s.model, ms.newton);
  for (double t : ms.times) ASSERT_TRUE(sim.advance_to(t).reached());
  const macro::DeviceProbe probe(ms.device, s);
  const std::vector<std::string> columns = probe.columns();
  const std::vector<double> row = probe.values(sim);
  auto at = [&](const std::string& name) {
    return row[std::find(columns.begin(), columns.end(), name) - columns.begin()];
  };
  const double theta = at("bending_angle_deg"), phi = at("chord_angle_deg");
  std::cerr << "coarse actuator at " << at("pressure_kPa") << " kPa: bending " << theta << " deg, chord " << phi
            << " deg, tip u_y " << at("tip_uy_mm") << " mm\n";
  EXPECT_GT(theta, 10.0);           // it bends (the study's mesh: 38 deg at 4 kPa)
  EXPECT_LT(at("tip_uy_mm"), 0.0);  // toward the stiff half y < 0
  // A circular arc's chord turns by half its end's rotation; the clamp and the cap (3 of 168 mm)
  // bend less than the wall: 3 % of θ.
  EXPECT_NEAR(phi, theta / 2, 0.03 * theta);
}
