// geometry.geo + mesh_size: gmsh meshes the .geo at run time into a cache keyed by its text and the
// size; a missing program, a failing .geo and inconsistent keys stop with exit 2 naming the key.
#include <gtest/gtest.h>

#include <fstream>

#include "app/cli_helpers.hpp"

using namespace softhom::test;
namespace fs = std::filesystem;

namespace {

// A 2 x 1 x 1 box (faces named by their plane), quadratic tets at the passed size.
const char* kBoxGeo = R"(SetFactory("OpenCASCADE");
DefineConstant[ mesh_size = 1.0 ];
Box(1) = {0, 0, 0, 2, 1, 1};
e = 1e-6;
Physical Volume("body") = {1};
Physical Surface("xmin") = Surface In BoundingBox{-e, -e, -e, e, 1 + e, 1 + e};
Physical Surface("xmax") = Surface In BoundingBox{2 - e, -e, -e, 2 + e, 1 + e, 1 + e};
Mesh.MeshSizeMax = mesh_size;
Mesh.ElementOrder = 2;
)";

fs::path write_geo(const fs::path& dir, const std::string& name, const std::string& text) {
  fs::create_directories(dir);
  const fs::path p = dir / name;
  std::ofstream(p) << text;
  return p;
}

std::string box_scene(const std::string& geometry_keys) {
  return "[geometry]\ntype = \"gmsh\"\n" + geometry_keys +
         "[material]\npreset = \"ecoflex\"\n[[boundary]]\nsurface = \"xmin\"\nfix = [\"x\", \"y\", \"z\"]\n"
         "[load]\ncontrol = \"pressure\"\nsurface = \"xmax\"\npath = [[0.0, 0.0], [1.0, -0.001]]\nsteps = 1\n"
         "[output]\nfields = false\n[probe]\nsurface = \"xmax\"\n";
}

}  // namespace

TEST(GeoMeshing, MeshesOnceThenReusesTheCache) {
  // A directory with a space and a quote: gmsh gets an argument vector, never a shell line.
  const fs::path dir = fresh_dir("geo-cache");
  const fs::path geo = write_geo(dir / "a dir's $(name)", "box.geo", kBoxGeo);
  const fs::path cache = dir / "cache";
  const std::string scene = write_temp_scene("geo-box", box_scene("geo = \"" + geo.string() + "\"\nmesh_size = 0.5\n"));
  const auto first = run_softhom("macro " + scene + " --out " + (dir / "run1").string() + " -q", "SOFTHOM_MESH_CACHE=" + cache.string());
  ASSERT_EQ(first.exit_code, 0) << first.output;
  int meshes = 0;
  for (const auto& e : fs::directory_iterator(cache)) meshes += e.path().extension() == ".msh";
  EXPECT_EQ(meshes, 1);
  const Csv csv = read_csv(dir / "run1/response.csv");
  EXPECT_GT(csv.at(1, "probe_ux"), 0.0);  // a suction on x = 2 pulls the free end along +x
  // Cached: a second run does not need the mesher at all.
  const auto second = run_softhom("macro " + scene + " --out " + (dir / "run2").string() + " -q",
                                  "SOFTHOM_MESH_CACHE=" + cache.string() + " SOFTHOM_GMSH=/nonexistent/gmsh");
  EXPECT_EQ(second.exit_code, 0) << second.output;
  EXPECT_EQ(read_csv(dir / "run2/response.csv").at(1, "probe_ux"), csv.at(1, "probe_ux"));
  // Another size is another mesh.
  const std::string other = write_temp_scene("geo-box2", box_scene("geo = \"" + geo.string() + "\"\nmesh_size = 0.4\n"));
  const auto third = run_softhom("macro " + other + " --out " + (dir / "run3").string() + " -q",
                                 "SOFTHOM_MESH_CACHE=" + cache.string() + " SOFTHOM_GMSH=/nonexistent/gmsh");
  EXPECT_EQ(third.exit_code, 2) << third.output;
  EXPECT_NE(third.output.find("geometry.geo"), std::string::npos) << third.output;
  EXPECT_NE(third.output.find("cannot run the mesher"), std::string::npos) << third.output;
}

TEST(GeoMeshing, BadGeoAndKeysNameTheField) {
  const fs::path dir = fresh_dir("geo-bad");
  const fs::path broken = write_geo(dir, "broken.geo", "SetFactory(\"OpenCASCADE\");\nBox(1) = {0, 0, 0, 1, 1;\n");
  const std::string env = "SOFTHOM_MESH_CACHE=" + (dir / "cache").string();
  auto run = [&](const std::string& keys) {
    return run_softhom("macro " + write_temp_scene("geo-bad", box_scene(keys)) + " --out " + (dir / "out").string() + " -q", env);
  };
  const auto failing = run("geo = \"" + broken.string() + "\"\nmesh_size = 0.5\n");
  EXPECT_EQ(failing.exit_code, 2) << failing.output;
  EXPECT_NE(failing.output.find("geometry.geo"), std::string::npos) << failing.output;
  EXPECT_NE(failing.output.find("gmsh failed"), std::string::npos) << failing.output;
  EXPECT_NE(failing.output.find("Error"), std::string::npos) << failing.output;  // gmsh's own message

  const fs::path geo = write_geo(dir, "box.geo", kBoxGeo);
  const auto no_size = run("geo = \"" + geo.string() + "\"\n");
  EXPECT_EQ(no_size.exit_code, 2);
  EXPECT_NE(no_size.output.find("geometry.mesh_size"), std::string::npos) << no_size.output;
  const auto both = run("geo = \"" + geo.string() + "\"\nmesh_size = 0.5\nfile = \"x.msh\"\n");
  EXPECT_EQ(both.exit_code, 2);
  EXPECT_NE(both.output.find("not both"), std::string::npos) << both.output;
  const auto missing = run("geo = \"" + (dir / "none.geo").string() + "\"\nmesh_size = 0.5\n");
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_NE(missing.output.find("no such .geo file"), std::string::npos) << missing.output;
  const auto negative = run("geo = \"" + geo.string() + "\"\nmesh_size = -1\n");
  EXPECT_EQ(negative.exit_code, 2);
  EXPECT_NE(negative.output.find("geometry.mesh_size"), std::string::npos) << negative.output;
}

TEST(GeoMeshing, DeviceNeedsItsSurfaces) {
  const fs::path dir = fresh_dir("geo-device");
  const fs::path geo = write_geo(dir, "box.geo", kBoxGeo);
  const auto r = run_softhom("macro " +
                                 write_temp_scene("geo-device", box_scene("geo = \"" + geo.string() + "\"\nmesh_size = 0.5\n") +
                                                                    "[device]\nkind = \"gripper\"\ntips = [\"nowhere\"]\n") +
                                 " --out " + (dir / "out").string() + " -q",
                             "SOFTHOM_MESH_CACHE=" + (dir / "cache").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("device.tips[0]"), std::string::npos) << r.output;
}
