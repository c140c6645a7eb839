// Gmsh MSH 4.1 import on small committed meshes (tests/data/gmsh/*.msh, generated from the .geo files
// next to them): element promotion, regions and surfaces from physical groups, outward orientation,
// and clear errors for unsupported or inconsistent input.
#include <gtest/gtest.h>

#include <set>
#include <sstream>

#include "softhom/io/gmsh.hpp"
#include "softhom/fe/model.hpp"
#include "softhom/fe/tet10_element.hpp"
#include "softhom/materials/errors.hpp"

using namespace softhom;
using namespace softhom::fe;
using namespace softhom::io;

namespace {

std::string data(const std::string& name) { return std::string(SOFTHOM_SOURCE_DIR) + "/tests/data/gmsh/" + name; }

double mesh_volume(const Mesh& m) {
  double v = 0.0;
  for (const Tet10& t : m.tets) {
    Tet10Coords X;
    for (int a = 0; a < 10; ++a) X.row(a) = m.nodes[t[a]].transpose();
    v += tet10_geometry(X).volume;
  }
  for (const Hex& h : m.hexes) {
    Mat83 X;
    for (int a = 0; a < 8; ++a) X.row(a) = m.nodes[h[a]].transpose();
    v += hex8_geometry(X).volume;
  }
  return v;
}

/// Unit outward normal of a straight triangle face and its centroid.
std::pair<Vec3, Vec3> tri_normal(const Mesh& m, const Tri6& f) {
  const Vec3 n = (m.nodes[f[1]] - m.nodes[f[0]]).cross(m.nodes[f[2]] - m.nodes[f[0]]).normalized();
  return {n, (m.nodes[f[0]] + m.nodes[f[1]] + m.nodes[f[2]]) / 3.0};
}

std::string error_of(const std::string& text) {
  std::istringstream in(text);
  try {
    parse_gmsh(in, "inline.msh");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

const char* kHeader = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n";
// One tet4 (nodes 1..4) in volume entity 1 with physical group 7 "body".
const char* kOneTet =
    "$PhysicalNames\n1\n3 7 \"body\"\n$EndPhysicalNames\n"
    "$Entities\n0 0 0 1\n1 0 0 0 1 1 1 1 7 0\n$EndEntities\n"
    "$Nodes\n1 4 1 4\n3 1 0 4\n1\n2\n3\n4\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n$EndNodes\n";

}  // namespace

TEST(Gmsh, LinearTetsArePromotedWithSurfacesOriented) {
  const Mesh m = read_gmsh(data("box_tet4.msh"));
  EXPECT_TRUE(m.hexes.empty());
  ASSERT_GT(m.tets.size(), 50u);
  ASSERT_EQ(m.region_names.size(), 1u);
  EXPECT_EQ(m.region_names[0], "solid");
  // Straight mid-edge nodes: exact volume of the box, and every mid node halfway along its edge.
  EXPECT_NEAR(mesh_volume(m), 2.0, 1e-12);
  for (const Tet10& t : m.tets)
    for (int e = 0; e < 6; ++e)
      EXPECT_LT((m.nodes[t[4 + e]] - 0.5 * (m.nodes[t[kTet10Edges[e][0]]] + m.nodes[t[kTet10Edges[e][1]]])).norm(), 1e-14);
  // Physical surfaces: outward normals (−x on xmin, +x on xmax, ...) and full areas (flux identity).
  for (const auto& [name, normal] : std::vector<std::pair<std::string, Vec3>>{
           {"xmin", Vec3(-1, 0, 0)}, {"xmax", Vec3(1, 0, 0)}, {"ymin", Vec3(0, -1, 0)}, {"zmin", Vec3(0, 0, -1)}}) {
    const auto& faces = m.tri_surface(name);
    ASSERT_FALSE(faces.empty()) << name;
    double area = 0.0;
    for (const Tri6& f : faces) {
      EXPECT_LT((tri_normal(m, f).first - normal).norm(), 1e-12) << name;
      area += 0.5 * (m.nodes[f[1]] - m.nodes[f[0]]).cross(m.nodes[f[2]] - m.nodes[f[0]]).norm();
    }
    EXPECT_NEAR(area, name[0] == 'x' ? 1.0 : 2.0, 1e-12) << name;
  }
  EXPECT_FALSE(m.has_surface("ymax"));  // not a physical group
  EXPECT_GT(min_scaled_jacobian(m), 0.0);
}

TEST(Gmsh, QuadraticTetsWithTwoRegionsKeepTheirNodes) {
  const Mesh m = read_gmsh(data("two_regions_tet10.msh"));
  ASSERT_EQ(m.region_names.size(), 2u);
  int soft = -1;
  for (int r = 0; r < 2; ++r)
    if (m.region_names[r] == "soft") soft = r;
  ASSERT_GE(soft, 0);
  // Regions follow the geometry: "soft" is x < 1.
  for (int e = 0; e < m.num_elements(); ++e) {
    Vec3 c = Vec3::Zero();
    for (int a = 0; a < 4; ++a) c += 0.25 * m.nodes[m.element_nodes(e)[a]];
    EXPECT_EQ(m.region[e] == soft, c[0] < 1.0) << "element " << e;
  }
  EXPECT_NEAR(mesh_volume(m), 2.0, 1e-12);
  // No new nodes are created for tet10 input (Gmsh nodes only), and the two blocks share the interface:
  // the whole boundary is closed (flux = −3 V with outward faces).
  std::set<int> used;
  for (const Tet10& t : m.tets) used.insert(t.begin(), t.end());
  EXPECT_EQ(int(used.size()), m.num_nodes());
  EXPECT_NEAR(cavity_volume(m.nodes, {}, Vec3(1, 1, 1), boundary_tri_faces(m)), -2.0, 1e-12);
  // "top" (z = 1, both regions) has outward +z normals; "xmin" the area of one face.
  double area = 0.0;
  for (const Tri6& f : m.tri_surface("top")) {
    EXPECT_LT((tri_normal(m, f).first - Vec3(0, 0, 1)).norm(), 1e-12);
    area += 0.5 * (m.nodes[f[1]] - m.nodes[f[0]]).cross(m.nodes[f[2]] - m.nodes[f[0]]).norm();
  }
  EXPECT_NEAR(area, 2.0, 1e-12);
  EXPECT_EQ(surface_nodes(m, "xmin").size() > 0, true);
}

TEST(Gmsh, HexahedraWithQuadrangleSurfaces) {
  const Mesh m = read_gmsh(data("hex_block.msh"));
  EXPECT_EQ(m.hexes.size(), 16u);
  EXPECT_TRUE(m.tets.empty());
  EXPECT_NEAR(mesh_volume(m), 2.0, 1e-12);
  ASSERT_EQ(m.surface("bottom").size(), 4u);
  ASSERT_EQ(m.surface("top").size(), 4u);
  for (const Quad& q : m.surface("top")) {
    const Vec3 n = (m.nodes[q[2]] - m.nodes[q[0]]).cross(m.nodes[q[3]] - m.nodes[q[1]]).normalized();
    EXPECT_LT((n - Vec3(0, 0, 1)).norm(), 1e-12);
  }
  for (const Quad& q : m.surface("bottom")) {
    const Vec3 n = (m.nodes[q[2]] - m.nodes[q[0]]).cross(m.nodes[q[3]] - m.nodes[q[1]]).normalized();
    EXPECT_LT((n - Vec3(0, 0, -1)).norm(), 1e-12);
  }
}

TEST(Gmsh, SingleInlineTetAndOrientation) {
  // Elements written with negative orientation are flipped (here vertices 2 and 3 swapped). Node 5
  // (no element uses it) is dropped.
  std::string one_tet = kOneTet;
  const std::string four = "1 4 1 4\n3 1 0 4\n1\n2\n3\n4\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n";
  one_tet.replace(one_tet.find(four), four.size(), "1 5 1 5\n3 1 0 5\n1\n2\n3\n4\n5\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n9 9 9\n");
  const std::string text = std::string(kHeader) + one_tet + "$Elements\n1 1 1 1\n3 1 4 1\n1 1 3 2 4\n$EndElements\n";
  std::istringstream in(text);
  const Mesh m = parse_gmsh(in, "inline.msh");
  ASSERT_EQ(m.tets.size(), 1u);
  EXPECT_EQ(m.num_nodes(), 10);
  EXPECT_EQ(m.region_names, std::vector<std::string>{"body"});
  Tet10Coords X;
  for (int a = 0; a < 10; ++a) X.row(a) = m.nodes[m.tets[0][a]].transpose();
  EXPECT_NEAR(tet10_geometry(X).volume, 1.0 / 6.0, 1e-15);
}

TEST(Gmsh, ErrorsNameFileLineAndProblem) {
  // MSH 2 is refused with the remedy.
  EXPECT_NE(error_of("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n").find("inline.msh:2"), std::string::npos);
  EXPECT_NE(error_of("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n").find("msh41"), std::string::npos);
  // Binary header without the endianness marker (binary files themselves: test_gmsh_binary.cpp).
  EXPECT_NE(error_of("$MeshFormat\n4.1 1 8\n$EndMeshFormat\n").find("binary"), std::string::npos);
  // Unknown element type 99 on line 26 (the block header).
  const std::string unknown = std::string(kHeader) + kOneTet + "$Elements\n1 1 1 1\n3 1 99 1\n1 1 2 3 4\n$EndElements\n";
  const std::string e1 = error_of(unknown);
  EXPECT_NE(e1.find("inline.msh:26"), std::string::npos) << e1;
  EXPECT_NE(e1.find("unknown Gmsh element type"), std::string::npos) << e1;
  // Supported by Gmsh but not here (pyramid).
  const std::string pyr = std::string(kHeader) + kOneTet + "$Elements\n1 1 1 1\n3 1 7 1\n1 1 2 3 4 4\n$EndElements\n";
  EXPECT_NE(error_of(pyr).find("pyramid"), std::string::npos) << error_of(pyr);
  // Missing node 9.
  const std::string missing = std::string(kHeader) + kOneTet + "$Elements\n1 1 1 1\n3 1 4 1\n1 1 2 3 9\n$EndElements\n";
  const std::string e2 = error_of(missing);
  EXPECT_NE(e2.find("inline.msh:27"), std::string::npos) << e2;
  EXPECT_NE(e2.find("9"), std::string::npos) << e2;
  // Only surfaces.
  const std::string flat = std::string(kHeader) +
                           "$Nodes\n1 3 1 3\n2 1 0 3\n1\n2\n3\n0 0 0\n1 0 0\n0 1 0\n$EndNodes\n"
                           "$Elements\n1 1 1 1\n2 1 2 1\n1 1 2 3\n$EndElements\n";
  EXPECT_NE(error_of(flat).find("no volume elements"), std::string::npos) << error_of(flat);
  // Degenerate (flat) tetrahedron.
  const std::string degenerate = std::string(kHeader) + kOneTet + "$Elements\n1 1 1 1\n3 1 4 1\n1 1 2 3 3\n$EndElements\n";
  EXPECT_NE(error_of(degenerate).find("non-positive Jacobian"), std::string::npos) << error_of(degenerate);
  // Missing file.
  EXPECT_THROW(read_gmsh(data("does_not_exist.msh")), InputError);
}
