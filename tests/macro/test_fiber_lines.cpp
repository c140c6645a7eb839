// [[fibers]] geometry = "gmsh": the lines of a Gmsh physical curve group as fibers. A straight group
// through a block in uniaxial tension carries the same force as the built-in straight family, which is
// the rule-of-mixtures force E A (λ − 1) on top of the block's own; 2-node and 3-node lines, read from
// the host's mesh file or from a file of lines only; a missing group, a group without lines and lines
// outside the block refused naming their keys.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "softhom/io/gmsh.hpp"
#include "softhom/io/scene.hpp"
#include "softhom/macro/scene.hpp"
#include "softhom/macro/structures.hpp"
#include "softhom/materials/errors.hpp"

namespace fs = std::filesystem;
using namespace softhom;

namespace {

/// MSH 4.1 text: optionally the block [0, 2] × [0, 1] × [0, 1] of 4 × 2 × 2 hexahedra (physical volume
/// "block"), and the line y = y0, z = z0 from x = 0 to 2 as 5 lines of 2 nodes (curve group "glass") and
/// of 3 nodes (group "glass3"), their nodes numbered from the far end (the chain must reorder them).
std::string block_msh(bool volume, double y0, double z0) {
  std::ostringstream nodes, elements;
  int node_count = 0, element_count = 0;
  if (volume) {
    const int n[3] = {4, 2, 2};
    nodes << "3 1 0 " << 5 * 3 * 3 << "\n";
    for (int t = 1; t <= 45; ++t) nodes << t << "\n";
    for (int k = 0; k <= n[2]; ++k)
      for (int j = 0; j <= n[1]; ++j)
        for (int i = 0; i <= n[0]; ++i) nodes << 2.0 * i / n[0] << " " << 1.0 * j / n[1] << " " << 1.0 * k / n[2] << "\n";
    node_count = 45;
    auto id = [](int i, int j, int k) { return 1 + i + 5 * (j + 3 * k); };
    elements << "3 1 5 16\n";
    for (int k = 0; k < 2; ++k)
      for (int j = 0; j < 2; ++j)
        for (int i = 0; i < 4; ++i)
          elements << ++element_count << " " << id(i, j, k) << " " << id(i + 1, j, k) << " " << id(i + 1, j + 1, k) << " "
                   << id(i, j + 1, k) << " " << id(i, j, k + 1) << " " << id(i + 1, j, k + 1) << " " << id(i + 1, j + 1, k + 1)
                   << " " << id(i, j + 1, k + 1) << "\n";
  }
  // 11 points along the line (x = 0.2 k), numbered backwards.
  const int first = node_count + 1;
  nodes << "1 1 0 11\n";
  for (int k = 0; k <= 10; ++k) nodes << first + k << "\n";
  for (int k = 0; k <= 10; ++k) nodes << 2.0 - 0.2 * k << " " << y0 << " " << z0 << "\n";
  node_count += 11;
  elements << "1 1 1 5\n";
  for (int e = 0; e < 5; ++e) elements << ++element_count << " " << first + 2 * e << " " << first + 2 * e + 2 << "\n";
  elements << "1 2 8 5\n";
  for (int e = 0; e < 5; ++e)
    elements << ++element_count << " " << first + 2 * e << " " << first + 2 * e + 2 << " " << first + 2 * e + 1 << "\n";
  std::ostringstream msh;
  msh << "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$PhysicalNames\n" << (volume ? 4 : 3)
      << "\n1 7 \"glass\"\n1 8 \"glass3\"\n1 10 \"bare\"\n" << (volume ? "3 9 \"block\"\n" : "") << "$EndPhysicalNames\n";
  msh << "$Entities\n0 2 0 " << (volume ? 1 : 0) << "\n1 0 0 0 2 1 1 1 7 0\n2 0 0 0 2 1 1 1 8 0\n"
      << (volume ? "1 0 0 0 2 1 1 1 9 0\n" : "") << "$EndEntities\n";
  msh << "$Nodes\n" << (volume ? 2 : 1) << " " << node_count << " 1 " << node_count << "\n" << nodes.str() << "$EndNodes\n";
  msh << "$Elements\n" << (volume ? 3 : 2) << " " << element_count << " 1 " << element_count << "\n"
      << elements.str() << "$EndElements\n";
  return msh.str();
}

/// A plate 2 × 1 × 1 of 4 × 2 × 2 cells stretched to 1.3 with the given [[fibers]] table; the reaction.
std::string plate_scene(const std::string& fibers) {
  return R"(
[geometry]
type = "plate"
size = [2.0, 1.0, 1.0]
cells = [4, 2, 2]
[material]
law = "neo-hookean"
mu = 1.0
K = 10.0
[load]
control = "stretch"
path = [[0.0, 1.0], [1.0, 1.3]]
steps = 1
)" + fibers;
}

double plate_force(const std::string& scene, const fs::path& file) {
  const macro::MacroScene m = macro::parse_macro_scene(io::parse_scene(scene, file.string()), file);
  macro::Structure s = macro::build_structure(m.spec);
  fe::NewtonOptions o = m.newton;
  o.tolerance = 1e-13;  // the uniform state is the discrete solution: Newton reaches round-off
  fe::Simulation sim(s.model, o);
  EXPECT_TRUE(sim.advance_to(1.0).reached());
  return macro::probe_values(s, sim)[2];
}

const char* kGlass = "modulus = 100.0\narea = 0.05\n";

struct TempDir {
  fs::path path = fs::temp_directory_path() / ("softhom-fiber-lines-" + std::to_string(::getpid()));
  TempDir() { fs::create_directories(path); }
  ~TempDir() { fs::remove_all(path); }
  void write(const std::string& name, const std::string& text) const { std::ofstream(path / name) << text; }
};

}  // namespace

TEST(FiberLines, GroupsChainIntoOrderedPolylinesOf2And3NodeLines) {
  std::istringstream in(block_msh(true, 0.37, 0.61));
  const io::GmshLineGroup two = io::parse_gmsh_line_group(in, "block.msh", "glass", "fibers[0].group");
  ASSERT_EQ(two.polylines.size(), 1u);
  EXPECT_EQ(two.nodes_per_line, 2);
  EXPECT_EQ(two.polylines[0].size(), 6u);  // 5 lines: 6 points
  std::istringstream in3(block_msh(false, 0.37, 0.61));
  const io::GmshLineGroup three = io::parse_gmsh_line_group(in3, "lines.msh", "8", "fibers[0].group");  // by tag
  ASSERT_EQ(three.polylines.size(), 1u);
  EXPECT_EQ(three.nodes_per_line, 3);
  ASSERT_EQ(three.polylines[0].size(), 11u);  // end, middle, end, ...: x monotone along the chain
  for (std::size_t k = 1; k < 11; ++k)
    EXPECT_NEAR(std::abs(three.polylines[0][k][0] - three.polylines[0][k - 1][0]), 0.2, 1e-12);
}

TEST(FiberLines, AStraightGroupCarriesTheStraightFamilysRuleOfMixturesForce) {
  TempDir dir;
  dir.write("block.msh", block_msh(true, 0.37, 0.61));
  dir.write("lines.msh", block_msh(false, 0.37, 0.61));
  const fs::path scene = dir.path / "plate.toml";
  const double matrix = plate_force(plate_scene(""), scene);
  const double straight = plate_force(
      plate_scene(std::string("[[fibers]]\ngeometry = \"straight\"\ncount = 1\nfrom = [0.0, 0.37, 0.61]\nto = [2.0, 0.37, 0.61]\nelements = 5\n") + kGlass),
      scene);
  // Uniform uniaxial state: the fiber adds exactly E A (λ − 1) = 100 · 0.05 · 0.3 (Newton at 1e-13).
  EXPECT_NEAR(straight - matrix, 100.0 * 0.05 * 0.3, 1e-10 * straight);
  for (const char* group : {"glass", "glass3"}) {
    const double lines = plate_force(
        plate_scene(std::string("[[fibers]]\ngeometry = \"gmsh\"\nfile = \"lines.msh\"\ngroup = \"") + group + "\"\n" + kGlass), scene);
    EXPECT_NEAR(lines, straight, 1e-10 * straight) << group;
  }
}

TEST(FiberLines, MissingGroupsAndLinesOutsideTheHostAreRefusedNamingTheirKeys) {
  TempDir dir;
  dir.write("lines.msh", block_msh(false, 0.37, 0.61));
  dir.write("outside.msh", block_msh(false, 1.5, 0.61));
  const fs::path scene = dir.path / "plate.toml";
  auto error_of = [&](const std::string& table) -> std::string {
    try {
      plate_force(plate_scene("[[fibers]]\ngeometry = \"gmsh\"\n" + table + kGlass), scene);
    } catch (const InputError& e) {
      return e.what();
    }
    return "no error";
  };
  std::string e = error_of("file = \"lines.msh\"\ngroup = \"nylon\"\n");
  EXPECT_NE(e.find("fibers[0].group"), std::string::npos) << e;
  EXPECT_NE(e.find("\"glass3\""), std::string::npos) << e;  // the groups it has
  e = error_of("file = \"outside.msh\"\ngroup = \"glass\"\n");
  EXPECT_NE(e.find("outside every host element"), std::string::npos) << e;
  EXPECT_NE(e.find("fibers[0].group = \"glass\""), std::string::npos) << e;
  e = error_of("group = \"glass\"\n");  // a generated plate has no Gmsh mesh to take the group from
  EXPECT_NE(e.find("fibers[0].file"), std::string::npos) << e;
  e = error_of("file = \"lines.msh\"\ngroup = \"glass\"\norder = 2\n");
  EXPECT_NE(e.find("fibers[0].order"), std::string::npos) << e;
  e = error_of("file = \"lines.msh\"\ngroup = \"bare\"\n");  // named, but no curve of it has lines
  EXPECT_NE(e.find("no line elements"), std::string::npos) << e;
  e = error_of("file = \"lines.msh\"\n");
  EXPECT_NE(e.find("fibers[0].group"), std::string::npos) << e;
}
