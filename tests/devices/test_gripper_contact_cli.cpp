// Contact in the device scenes through `softhom macro`: the micro-gripper closing past the first contact
// of its fingers (gripper_contact_coarse: the fingers against their mirror planes), holding a soft sample
// (gripper_sample_coarse: frictionless pairs between the fingers and a deformable sphere), and the
// bending actuator's blocked force against a rigid plane (bending_actuator_blocked_force_coarse). Short
// runs on coarser meshes and fewer steps than the shipped scenes: the fewest that show the contact.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>

#include "app/cli_helpers.hpp"

using namespace softhom::test;
namespace fs = std::filesystem;

namespace {

/// A shipped scene (studies/<folder>/<stem>.toml) with the .geo path made absolute and `edits` (from → to)
/// applied; the run's device.csv and response.csv.
struct ContactRun {
  Csv device, response;
};

ContactRun run_contact_scene(const std::string& folder, const std::string& stem,
                             const std::vector<std::pair<std::string, std::string>>& edits) {
  std::ifstream in(fs::path(SOFTHOM_SOURCE_DIR) / "studies" / folder / (stem + ".toml"));
  std::stringstream ss;
  ss << in.rdbuf();
  std::string text = ss.str();
  auto replace = [&](const std::string& from, const std::string& to) {
    const auto at = text.find(from);
    if (at == std::string::npos) throw std::runtime_error(stem + ": no '" + from + "'");
    text.replace(at, from.size(), to);
  };
  if (text.find("geo = \"../meshes/") != std::string::npos)
    replace("geo = \"../meshes/", "geo = \"" + (fs::path(SOFTHOM_SOURCE_DIR) / "studies/meshes").string() + "/");
  for (const auto& [from, to] : edits) replace(from, to);
  const auto out = fresh_dir("contact-" + stem);
  const std::string file = write_temp_scene(stem + "-contact-" + std::to_string(::getpid()), text);
  const auto r = run_softhom("macro " + file + " --out " + out.string() + " -q",
                             "SOFTHOM_MESH_CACHE=" + (out / "mesh").string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  return {read_csv(out / "device.csv"), read_csv(out / "response.csv")};
}

std::size_t final_row(const Csv& c) { return c.rows.size() - 1; }

/// The first row where `column` is positive (rows.size() when none).
std::size_t first_positive(const Csv& c, const std::string& column) {
  std::size_t k = 0;
  while (k < c.rows.size() && !(c.at(k, column) > 0.0)) ++k;
  return k;
}

}  // namespace

// The gripper closing past first contact on a 1 mm mesh (1 107 tets), 50 kPa steps to 300 kPa: 36 Newton
// iterations, 3.6 s CPU. The fingers are free up to 200 kPa (tips 0.70 mm from the axis) and touch in the
// step to 250 kPa. Three plane contacts, all the same force between two neighbouring fingers in the
// symmetric solution: finger 0 and finger 120 on the plane at 60° (action and reaction) and finger 120 on
// y = 0 (against finger 240); the two fingers' meshes differ (finger 0 is cut in half) and each contact
// is carried by one to three quadrature points on this mesh, so they agree to 24 % here (measured), 35 %
// allowed. The fingertips are then blocked: the angle changes by less than 0.3 × its rise over the last
// free step (measured −0.9° against +6.3°). A converged penetration is at most the step's pressure
// increment over the penalty (100 G/h: 1 % of a face at the pressure G): measured 9e-4 mm, h/100 allowed.
TEST(GripperContact, FingersPressOnEachOther) {
  const ContactRun run = run_contact_scene(
      "devices", "gripper_contact_coarse",
      {{"mesh_size = 0.5", "mesh_size = 1.0"}, {"[1.0, 0.4]]", "[1.0, 0.3]]"}, {"steps = 16", "steps = 6"},
       {"fields = [1.0]", "fields = false"}});
  const Csv& c = run.device;
  ASSERT_EQ(c.rows.size(), 7u);
  const std::size_t first = first_positive(c, "finger_contact_force_N");
  ASSERT_EQ(first, 5u);  // the step to 250 kPa
  for (std::size_t k = first; k < c.rows.size(); ++k) {
    const double mean = c.at(k, "finger_contact_force_N");
    for (const char* col : {"contact_0_normal_force_N", "contact_1_normal_force_N", "contact_2_normal_force_N"})
      EXPECT_NEAR(c.at(k, col), mean, 0.35 * mean) << col << " row " << k;
  }
  EXPECT_GT(c.at(final_row(c), "finger_contact_force_N"), c.at(first, "finger_contact_force_N"));
  const double free_rise = c.at(first - 1, "finger_angle_deg") - c.at(first - 2, "finger_angle_deg");
  EXPECT_LT(std::abs(c.at(final_row(c), "finger_angle_deg") - c.at(first, "finger_angle_deg")), 0.3 * free_rise);
  for (std::size_t k = 0; k < run.response.rows.size(); ++k)
    for (const char* col : {"contact_0_max_penetration [mm]", "contact_1_max_penetration [mm]", "contact_2_max_penetration [mm]"})
      EXPECT_LT(run.response.at(k, col), 0.01) << col << " row " << k;
}

// The blocked force of the coarse bending actuator (12 × 12 × 1 cells), 1 kPa steps to 4 kPa: 2.1 s CPU
// with 8 steps (the shipped scene), less with 4. The actuator bends towards its stiff side, so its tip
// meets the plane 0.5 mm under it in the first step and is held there; the rest of it arches away. Once
// the gap is closed the blocked force is linear in the pressure (a held tip: the pressure's moment about
// the clamp balanced by the force's; the free actuator's angle is itself almost linear in p), so its
// increments per step agree: measured 2.75 … 2.80 mN per 0.5 kPa over the shipped scene's steps (1.7 %),
// 5 % allowed here. The end still turns a little (the tube's section and the arch deform), far less than
// free: measured 7.1° at 4 kPa against 38° free; below 15° asserted. Penetration: a converged point lies
// at most its step's pressure increment over the penalty inside (measured 5e-4 mm; h/100 of the 3 mm
// wall cells allowed: 0.03 mm).
TEST(GripperContact, BendingActuatorBlockedForce) {
  const ContactRun run = run_contact_scene("structures", "bending_actuator_blocked_force_coarse", {{"steps = 8", "steps = 4"}});
  const Csv& r = run.response;
  ASSERT_EQ(r.rows.size(), 5u);
  EXPECT_EQ(r.at(0, "contact_normal_force [N]"), 0.0);
  for (std::size_t k = 1; k < r.rows.size(); ++k) {
    EXPECT_GT(r.at(k, "contact_normal_force [N]"), 0.0) << "row " << k;
    EXPECT_LT(r.at(k, "contact_max_penetration [mm]"), 0.03) << "row " << k;
  }
  const double first = r.at(2, "contact_normal_force [N]") - r.at(1, "contact_normal_force [N]");
  for (std::size_t k = 3; k < r.rows.size(); ++k) {
    const double step = r.at(k, "contact_normal_force [N]") - r.at(k - 1, "contact_normal_force [N]");
    EXPECT_NEAR(step, first, 0.05 * first) << "row " << k;
  }
  EXPECT_LT(run.device.at(final_row(run.device), "bending_angle_deg"), 15.0);
  EXPECT_GT(run.device.at(final_row(run.device), "bending_angle_deg"), 0.0);
}

// The gripper holding the soft sample (a separate body of the mesh: the 1.4 mm hydrogel sphere, E =
// 3.39 kPa, on its fixed flat), the gripper on the 1 mm mesh, 100 kPa steps to 200 kPa and one step of
// 18.75 kPa to 218.75 kPa: 31 Newton iterations, no cut-back. The fingertips reach the sample in the last
// step (tips 0.51 mm from the axis at 212.5 kPa in 6.25 kPa steps, first force there 5e-7 N). Before it
// the sample is untouched (no force, compression exactly 0: it is held at its flat only); then both
// fingers press it: each pair's force positive (measured 3.6 and 2.0 µN), the sample's reach towards the
// fingers reduced by 8.7 % (more than 1 %, less than 20 % asserted: the fingers have not yet met each
// other). The pairs' penalty is the default, 100 G/h of the sample's faces (h = 0.233 mm), and an
// iterate adds at most 10 G to a point's pressure in a step, so a converged point of this first touch
// lies at most h/10 inside a finger; measured 0.0013 mm, h/20 = 0.0117 mm asserted (a point beside a
// fingertip's edge taken for a penetration, as the face plane's signed distance did, lies deeper).
TEST(GripperContact, HoldsASoftSample) {
  const ContactRun run = run_contact_scene(
      "devices", "gripper_sample_coarse",
      {{"mesh_size = 0.5", "mesh_size = 1.0"},
       {"[[0.0, 0.0], [0.5, 0.2], [1.0, 0.3]]", "[[0.0, 0.0], [0.6667, 0.2], [1.0, 0.21875]]"},
       {"steps = 16", "steps = 3"},
       {"fields = [1.0]", "fields = false"}});
  const Csv& c = run.device;
  ASSERT_EQ(c.rows.size(), 4u);
  for (std::size_t k = 0; k < final_row(c); ++k) {
    EXPECT_EQ(c.at(k, "grip_force_N"), 0.0) << "row " << k;
    EXPECT_EQ(c.at(k, "sample_compression_percent"), 0.0) << "row " << k;
  }
  const std::size_t k = final_row(c);
  EXPECT_GT(c.at(k, "contact_pair_0_normal_force_N"), 0.0);
  EXPECT_GT(c.at(k, "contact_pair_1_normal_force_N"), 0.0);
  EXPECT_GT(c.at(k, "grip_force_N"), 0.0);
  EXPECT_GT(c.at(k, "sample_compression_percent"), 1.0);
  EXPECT_LT(c.at(k, "sample_compression_percent"), 20.0);
  for (std::size_t r = 0; r < run.response.rows.size(); ++r)
    for (const char* col : {"contact_pair_0_max_penetration [mm]", "contact_pair_1_max_penetration [mm]"})
      EXPECT_LT(run.response.at(r, col), 0.0117) << col << " row " << r;
}

// The stop before the fingers touch belongs to scenes without their contact: with the mirror planes it
// is refused (exit 2, naming the key), nothing run.
TEST(GripperContact, StopDistanceRefusedWithFingerContact) {
  std::ifstream in(fs::path(SOFTHOM_SOURCE_DIR) / "studies/devices/gripper_contact_coarse.toml");
  std::stringstream ss;
  ss << in.rdbuf();
  std::string text = ss.str();
  const std::string geo = "geo = \"../meshes/", size = "mesh_size = 0.5", root = "root_z = 1.5";
  text.replace(text.find(geo), geo.size(), "geo = \"" + (fs::path(SOFTHOM_SOURCE_DIR) / "studies/meshes").string() + "/");
  text.replace(text.find(size), size.size(), "mesh_size = 1.0");
  text.replace(text.find(root), root.size(), "stop_distance = 0.5\nroot_z = 1.5");
  const auto out = fresh_dir("contact-stop");
  const auto r = run_softhom("macro " + write_temp_scene("contact-stop-" + std::to_string(::getpid()), text) + " --out " +
                                 out.string() + " -q",
                             "SOFTHOM_MESH_CACHE=" + (out / "mesh").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("device.stop_distance"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(out / "device.csv"));
}
