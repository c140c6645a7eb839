// A scene's .geo may describe geometry and meshing only (macro/src/geo_policy.hpp): commands that run
// programs or write files, and reads outside its folder, are refused naming the file and line; the
// shipped .geo files pass.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "../macro/src/geo_policy.hpp"
#include "softhom/core/input_error.hpp"

using namespace softhom;

namespace {

std::string refusal(const std::string& text) {
  try {
    macro::check_geo_text(text, "t.geo", "geometry.geo");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(GeoPolicy, ShippedGeoFilesPass) {
  namespace fs = std::filesystem;
  int checked = 0;
  for (const char* dir : {"studies/meshes", "tests/data/gmsh"})
    for (const auto& e : fs::directory_iterator(fs::path(SOFTHOM_SOURCE_DIR) / dir)) {
      if (e.path().extension() != ".geo") continue;
      std::ifstream in(e.path());
      std::stringstream ss;
      ss << in.rdbuf();
      EXPECT_EQ(refusal(ss.str()), "") << e.path();
      ++checked;
    }
  EXPECT_GE(checked, 4);
}

TEST(GeoPolicy, ProgramsFileWritesAndOutsideReadsAreRefusedWithTheLine) {
  const std::string m = refusal("Point(1) = {0, 0, 0};\nSystem \"touch /tmp/pwned\";\n");
  EXPECT_NE(m.find("geometry.geo"), std::string::npos) << m;
  EXPECT_NE(m.find("t.geo:2"), std::string::npos) << m;
  for (const char* bad : {"SystemCall \"ls\";", "NonBlockingSystemCall \"ls\";", "Save \"/tmp/x.msh\";",
                          "Print \"/tmp/x.png\";", "Printf(\"%g\", 1) > \"/tmp/x\";", "Printf(\"%g\", 1) >> \"/tmp/x\";",
                          "Include \"/etc/passwd\";", "Merge \"../../x.step\";", "Include StrCat(\"/et\", \"c/x\");",
                          "CreateDir \"/tmp/d\";", "Delete File \"/tmp/x\";", "Plugin(MeshVolume).Run;"})
    EXPECT_NE(refusal(bad), "") << bad;
}

TEST(GeoPolicy, CommentsStringsAndReadsInsideTheFolderPass) {
  for (const char* ok : {"// System \"x\";\nPoint(1) = {0, 0, 0};", "/* Save \"x\"; */ Point(1) = {0, 0, 0};",
                         "Printf(\"System is %g\", 1);", "Include \"parts/base.geo\";", "Merge \"shape.step\";",
                         "If (a > 1) Point(1) = {0, 0, 0}; EndIf", "Printf(\"%g\", a > b);"})
    EXPECT_EQ(refusal(ok), "") << ok;
}
