// A .geo meshed at run time is estimated before gmsh meshes it: its volumes' bounding boxes (gmsh -0,
// the geometry only) at 6.8 nodes per mesh_size³ (measured), against the memory available.
#include <gtest/gtest.h>

#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>

#include "softhom/core/input_error.hpp"
#include "softhom/macro/mesh_generation.hpp"
#include "softhom/materials/system_memory.hpp"

using namespace softhom;
namespace fs = std::filesystem;

namespace {

bool have_gmsh() { return std::system("gmsh --version > /dev/null 2>&1") == 0; }

const char* kBox =
    "SetFactory(\"OpenCASCADE\");\nDefineConstant[ mesh_size = 1.0 ];\nBox(1) = {0, 0, 0, 10, 10, 10};\n"
    "Mesh.MeshSizeMax = mesh_size;\nMesh.MeshSizeMin = mesh_size;\nPhysical Volume(\"body\") = {1};\n";

}  // namespace

// A 10 mm box at mesh_size 0.01: 6.8 · 1000 / 1e-6 = 6.8e9 nodes, tens of TiB; refused within the
// time of gmsh -0 (it ran for minutes before, silently). Before: no estimate, gmsh meshed.
TEST(GeoEstimate, FineMeshOfABoxIsRefusedBeforeMeshing) {
  if (!have_gmsh()) GTEST_SKIP() << "gmsh not installed";
  if (available_memory_bytes() == 0) GTEST_SKIP() << "available memory unknown";
  const fs::path dir = fs::temp_directory_path() / ("softhom_test_geo_estimate_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::ofstream(dir / "box.geo") << kBox;
  const auto start = std::chrono::steady_clock::now();
  std::string message;
  try {
    macro::mesh_from_geo(dir / "box.geo", 0.01, dir / "cache", "geometry.geo");
  } catch (const InputError& e) {
    message = e.what();
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_NE(message.find("geometry.mesh_size = 0.01: the geometry's bounding boxes (1e+03 mm^3) meshed at this size make "
                         "about 6.8e+09 nodes"),
            std::string::npos)
      << message;
  EXPECT_LT(seconds, 20.0);  // gmsh -0 reads the geometry only (0.3 s here)
  // Nothing is left in the cache but its directory: no mesh, no temporary.
  for (const auto& e : fs::directory_iterator(dir / "cache")) ADD_FAILURE() << "left behind: " << e.path();
  fs::remove_all(dir);
}
