// [[contact.obstacles]] of macro scenes (macro/contact.hpp): a scene's obstacle becomes a contact
// contribution on the named surface; each refusal names its field: a surface that does not exist, a
// Coulomb coefficient out of [0, 3], keys of another shape, a missing radius, and a body that starts
// inside the obstacle (naming the point and its depth).
#include <gtest/gtest.h>

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
