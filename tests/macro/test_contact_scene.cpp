// [[contact.obstacles]] of macro scenes (macro/contact.hpp): a scene's obstacle becomes a contact
// contribution on the named surface; each refusal names its field: a surface that does not exist, a
// Coulomb coefficient out of [0, 3], keys of another shape, a missing radius, and a body that starts
// inside the obstacle (naming the point and its depth).
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <string>

#include "softhom/fe/contact.hpp"
#include "softhom/fe/solver.hpp"
#include "softhom/fe/surface_contact.hpp"
#include "softhom/io/scene.hpp"
#include "softhom/macro/scene.hpp"
#include "softhom/materials/errors.hpp"

using namespace softhom;

namespace {

/// A 2 × 2 × 1 mm plate in tension along x with `obstacle` as its [[contact.obstacles]] table.
std::string plate_with(const std::string& obstacle) {
  return R"(
[geometry]
type = "plate"
size = [2.0, 2.0, 1.0]
cells = [2, 2, 1]
[material]
preset = "ecoflex"
[load]
control = "stretch"
path = [[0.0, 1.0], [1.0, 1.1]]
steps = 2
[[contact.obstacles]]
)" + obstacle;
}

/// The InputError of parsing, building and setting up the scene's simulation, or "no error".
std::string contact_error_of(const std::string& text) {
  try {
    const macro::MacroScene m = macro::parse_macro_scene(io::parse_scene(text, "<test>"));
    const macro::Structure s = macro::build_structure(m.spec);
    fe::Simulation sim(s.model);
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

}  // namespace

TEST(ContactScene, ObstacleBecomesAContribution) {
  const macro::MacroScene m = macro::parse_macro_scene(io::parse_scene(
      plate_with("type = \"sphere\"\nsurface = \"zmax\"\nposition = [1.0, 1.0, 3.0]\nradius = 1.5\nfriction = 0.4\n"
                 "path = [[0.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, -0.6]]\n"),
      "<test>"));
  const macro::Structure s = macro::build_structure(m.spec);
  ASSERT_EQ(s.model.contributions.size(), 1u);
  const auto* c = dynamic_cast<const fe::ObstacleContact*>(s.model.contributions[0].get());
  ASSERT_NE(c, nullptr);
  EXPECT_EQ(c->name(), "contact.obstacles[0]");
  EXPECT_EQ(c->options().label, "contact");
  EXPECT_EQ(c->obstacle().shape, fe::RigidObstacle::Shape::sphere);
  EXPECT_EQ(c->quads().size(), 4u);               // the 2 × 2 faces of zmax
  EXPECT_DOUBLE_EQ(c->options().law.friction, 0.4);
  EXPECT_DOUBLE_EQ(c->obstacle().translation(0.5)[2], -0.3);
  EXPECT_GT(c->options().shear_modulus, 0.0);      // the automatic penalty's G
}

TEST(ContactScene, RefusalsNameTheirField) {
  const std::string plane = "type = \"plane\"\nposition = [0.0, 0.0, -0.5]\nnormal = [0.0, 0.0, 1.0]\n";
  EXPECT_NE(contact_error_of(plate_with(plane + "surface = \"nope\"\n")).find("contact.obstacles[0].surface"), std::string::npos);
  EXPECT_NE(contact_error_of(plate_with(plane + "surface = \"zmin\"\nfriction = 4.0\n")).find("contact.obstacles[0].friction"),
            std::string::npos);
  EXPECT_NE(contact_error_of(plate_with(plane + "surface = \"zmin\"\nradius = 1.0\n")).find("contact.obstacles[0].radius"),
            std::string::npos);
  EXPECT_NE(contact_error_of(plate_with("type = \"sphere\"\nsurface = \"zmin\"\nposition = [0.0, 0.0, -3.0]\n"))
                .find("contact.obstacles[0].radius"),
            std::string::npos);
  EXPECT_NE(contact_error_of(plate_with("type = \"plane\"\nsurface = \"zmin\"\nposition = [0.0, 0.0, -0.5]\nnormal = [0, 0, 0]\n"))
                .find("contact.obstacles[0].normal"),
            std::string::npos);
  EXPECT_NE(contact_error_of(plate_with(plane + "surface = \"zmin\"\npath = [[1.0, 0, 0, 0], [0.5, 0, 0, 1]]\n"))
                .find("contact.obstacles[0].path[1][0]"),
            std::string::npos);
  EXPECT_EQ(contact_error_of(plate_with(plane + "surface = \"zmin\"\n")), "no error");
  // The plane 0.25 mm inside the plate's bottom face.
  const std::string overlap = contact_error_of(
      plate_with("type = \"plane\"\nsurface = \"zmin\"\nposition = [0.0, 0.0, 0.25]\nnormal = [0.0, 0.0, 1.0]\n"));
  EXPECT_NE(overlap.find("contact.obstacles[0]"), std::string::npos) << overlap;
  EXPECT_NE(overlap.find("overlaps the body"), std::string::npos) << overlap;
  EXPECT_NE(overlap.find("0.25 mm inside"), std::string::npos) << overlap;
}

namespace {

/// The plate without obstacles, with `tables` ([[contact.pairs]], [[contact.self]]) as its [contact].
std::string plate_with_surface_contacts(const std::string& tables) {
  std::string scene = plate_with("");
  scene.erase(scene.find("[[contact.obstacles]]"));
  return scene + tables;
}

}  // namespace

// [[contact.pairs]] and [[contact.self]] become fe::SurfaceContact contributions with their labels
// (the plate's two faces zmax, zmin are a pair that never touches: a point on the far side of a wall
// is no contact), and the run goes through with the pairing updated every step.
TEST(ContactScene, PairsAndSelfContactBecomeContributions) {
  const macro::MacroScene m = macro::parse_macro_scene(io::parse_scene(
      plate_with_surface_contacts("[[contact.pairs]]\nslave = \"zmax\"\nmaster = \"zmin\"\ntwo_pass = true\n"
                                  "[[contact.self]]\nsurface = \"xmax\"\npenalty = 5.0\n"),
      "<test>"));
  const macro::Structure s = macro::build_structure(m.spec);
  ASSERT_EQ(s.model.contributions.size(), 2u);
  const auto* pair = dynamic_cast<const fe::SurfaceContact*>(s.model.contributions[0].get());
  const auto* self = dynamic_cast<const fe::SurfaceContact*>(s.model.contributions[1].get());
  ASSERT_NE(pair, nullptr);
  ASSERT_NE(self, nullptr);
  EXPECT_EQ(pair->name(), "contact.pairs[0]");
  EXPECT_EQ(self->name(), "contact.self[0]");
  // A pair on segments (its default: kSegmentSlots per slave face), two passes over the 2 × 2 quads of
  // each face; a self-contact on the Gauss points (its default), the two quads of xmax.
  EXPECT_EQ(pair->options().integration, fe::SurfaceContact::Options::Integration::segments);
  EXPECT_EQ(pair->num_points(), 2 * 4 * fe::SurfaceContact::kSegmentSlots);
  EXPECT_EQ(self->options().integration, fe::SurfaceContact::Options::Integration::points);
  EXPECT_EQ(self->num_points(), 2 * 9);
  fe::Simulation sim(s.model);
  EXPECT_TRUE(sim.advance_to(1.0).reached());
  fe::ContributionReport report;
  sim.report(report);
  bool pair_probe = false, self_probe = false;
  for (const auto& [name, value] : report.probes) {
    pair_probe |= name == "contact_pair_normal_force [N]" && value == 0.0;
    self_probe |= name == "contact_self_active_points [1]";
  }
  EXPECT_TRUE(pair_probe);
  EXPECT_TRUE(self_probe);
}

TEST(ContactScene, SurfaceContactRefusalsNameTheirField) {
  EXPECT_NE(contact_error_of(plate_with_surface_contacts("[[contact.pairs]]\nslave = \"nope\"\nmaster = \"zmin\"\n"))
                .find("contact.pairs[0].slave"),
            std::string::npos);
  EXPECT_NE(contact_error_of(plate_with_surface_contacts("[[contact.pairs]]\nslave = \"zmax\"\nmaster = \"nope\"\n"))
                .find("contact.pairs[0].master"),
            std::string::npos);
  EXPECT_NE(contact_error_of(plate_with_surface_contacts("[[contact.pairs]]\nslave = \"zmax\"\n")).find("contact.pairs[0].master"),
            std::string::npos);
  EXPECT_NE(contact_error_of(plate_with_surface_contacts("[[contact.self]]\nsurface = \"nope\"\n")).find("contact.self[0].surface"),
            std::string::npos);
  // Friction out of range (the key's bound), and a negative stick penalty.
  EXPECT_NE(contact_error_of(plate_with_surface_contacts("[[contact.self]]\nsurface = \"xmax\"\nfriction = 4.0\n"))
                .find("contact.self[0].friction"),
            std::string::npos);
  EXPECT_NE(contact_error_of(plate_with_surface_contacts("[[contact.self]]\nsurface = \"xmax\"\nfriction = 0.5\ntangential_penalty = -1\n"))
                .find("contact.self[0].tangential_penalty"),
            std::string::npos);
  EXPECT_NE(contact_error_of(plate_with_surface_contacts("[[contact.pairs]]\nslave = \"zmax\"\nmaster = \"zmin\"\npenalty = -1.0\n"))
                .find("contact.pairs[0].penalty"),
            std::string::npos);
  EXPECT_NE(contact_error_of(plate_with_surface_contacts("[[contact.self]]\nsurface = \"xmax\"\nself = 1\n")).find("contact.self[0].self"),
            std::string::npos);
  EXPECT_NE(contact_error_of(plate_with_surface_contacts("[[contact.pairs]]\nslave = \"zmax\"\nmaster = \"zmin\"\nintegration = \"mortar\"\n"))
                .find("contact.pairs[0].integration"),
            std::string::npos);
}

namespace {

/// The Gent balloon octant of macro_shell_balloon.toml (R = 10, H = 0.1), inflated by volume to
/// V/V0 = 2.197 (λ = 1.3) under a rigid plate z = 12 facing down: the pole reaches the plate when the
/// shell's outer face does, its mid-surface 0.05 below.
std::string balloon_under_plate(int cells) {
  return R"(
[geometry]
type = "shell"
shape = "sphere_octant"
radius = 10.0
cells = )" + std::to_string(cells) + R"(
[shell]
plane_stress = "incompressible"
[[shell.layers]]
thickness = 0.1
points = 3
[shell.layers.material]
law = "gent"
G = 0.026
Jm = 30.0
K = 2000.0
[load]
control = "volume"
path = [[0.0, 1.0], [1.0, 2.197]]
steps = 20
[[contact.obstacles]]
type = "plane"
surface = "shell"
position = [0.0, 0.0, 12.0]
normal = [0.0, 0.0, -1.0]
)";
}

}  // namespace

// A shell's mid-surface (the triangles as faces, "shell" or a named group) against a rigid obstacle:
// the contact surface is the outer face, half the thickness towards the obstacle, and the penalty
// scales with the section's shear modulus. Inflated against the plate, the shell's highest node stops
// 0.05 below it (the half thickness; the contact's penetration, below 1e-3, is the tolerance: without
// the offset it would reach z = 12), and the flat patch carries the cavity pressure: the force over
// p × the active points' area is 1.185 at 16 cells and 1.110 at 32 (the active area falls short of
// the flat patch's at the rim), bounded here by [1, 1.25].
TEST(ContactScene, ShellPressedOnAPlateTouchesWithItsOuterFace) {
  const macro::MacroScene m = macro::parse_macro_scene(io::parse_scene(balloon_under_plate(16), "<test>"));
  const macro::Structure s = macro::build_structure(m.spec);
  const fe::ObstacleContact* contact = nullptr;
  for (const auto& c : s.model.contributions)
    if (const auto* o = dynamic_cast<const fe::ObstacleContact*>(c.get())) contact = o;
  ASSERT_NE(contact, nullptr);
  EXPECT_DOUBLE_EQ(contact->options().offset, 0.05);
  EXPECT_NEAR(contact->options().shear_modulus, 0.026, 1e-12);
  fe::Simulation sim(s.model);
  ASSERT_TRUE(sim.advance_to(1.0).reached());
  const std::vector<double>& u = sim.displacement();
  double top = -1e9;
  for (int n = 0; n < s.model.mesh.num_nodes(); ++n) top = std::max(top, s.model.mesh.nodes[n][2] + u[3 * n + 2]);
  fe::ContributionReport report;
  sim.report(report);
  std::map<std::string, double> probe(report.probes.begin(), report.probes.end());
  EXPECT_GT(probe["contact_active_points [1]"], 10.0);
  EXPECT_LT(probe["contact_max_penetration [mm]"], 1e-3);
  EXPECT_NEAR(top, 12.0 - 0.05, 1e-3);
  const double ratio = probe["contact_normal_force [N]"] / (sim.cavity_pressure() * probe["contact_area [mm^2]"]);
  EXPECT_GT(ratio, 1.0);
  EXPECT_LT(ratio, 1.25);
}

// A shell scene's named surfaces for contact: "shell" is all of it; a name that is not one is refused,
// naming the field, and so are pairs and self-contact (obstacles only on shells).
TEST(ContactScene, ShellContactRefusesAnUnknownSurfaceAndPairs) {
  std::string scene = balloon_under_plate(4);
  scene.replace(scene.find("surface = \"shell\""), 17, "surface = \"skin\"");
  EXPECT_NE(contact_error_of(scene).find("contact.obstacles[0].surface"), std::string::npos);
  EXPECT_NE(contact_error_of(balloon_under_plate(4) + "[[contact.self]]\nsurface = \"shell\"\n").find("contact.self[0]"),
            std::string::npos);
}
