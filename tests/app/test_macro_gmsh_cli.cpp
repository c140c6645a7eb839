// `softhom macro` on an imported Gmsh mesh: a small run writes its probes and Tetrahedron_10 fields,
// and bad scene keys (missing file, unknown physical surface or region) stop with the field named.
#include <gtest/gtest.h>

#include <cmath>

#include "app/cli_helpers.hpp"
#include "softhom/io/fields.hpp"

using namespace softhom::test;

namespace {

std::string box_scene(const std::string& extra_boundary, const std::string& file = "") {
  const std::string mesh = file.empty() ? std::string(SOFTHOM_SOURCE_DIR) + "/tests/data/gmsh/box_tet4.msh" : file;
  return "[geometry]\ntype = \"gmsh\"\nfile = \"" + mesh +
         "\"\n[material]\npreset = \"ecoflex\"\n"
         "[[boundary]]\nsurface = \"xmin\"\nfix = [\"x\", \"y\", \"z\"]\n" +
         extra_boundary +
         "[load]\ncontrol = \"pressure\"\nsurface = \"xmax\"\npath = [[0.0, 0.0], [1.0, -0.002]]\nsteps = 2\n"
         "[probe]\nsurface = \"xmax\"\n";
}

}  // namespace

TEST(MacroGmshCli, PulledBoxWritesProbesAndTet10Fields) {
  // Box 2 × 1 × 1 (tet4 promoted to tet10) clamped at x = 0, a suction (negative pressure) of 2 kPa
  // on x = 2 pulls it: the end moves along +x by roughly σ L / E = 0.002 · 2 / (3 · 0.017) ≈ 0.08.
  const auto out = fresh_dir("macro-gmsh-box");
  const auto r = run_softhom("macro " + write_temp_scene("gmsh-box", box_scene("")) + " --out " + out.string() + " -q");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Csv csv = read_csv(out / "response.csv");
  ASSERT_EQ(csv.rows.size(), 3u);
  const double ux = csv.at(2, "probe_ux");
  EXPECT_GT(ux, 0.04);  // within a factor of two of the small-strain estimate (clamping stiffens)
  EXPECT_LT(ux, 0.12);
  std::ifstream xdmf(out / "fields.xdmf");
  std::stringstream ss;
  ss << xdmf.rdbuf();
  EXPECT_NE(ss.str().find("Tetrahedron_10"), std::string::npos);
  // VTK/XDMF node order: nodes 4..9 are the midpoints of the edges (0,1), (1,2), (2,0), (0,3), (1,3),
  // (2,3) (the straight mid-edge nodes of promoted tet4 make this exact).
  const auto conn = softhom::io::read_dataset(out / "fields.h5", "/mesh/connectivity");
  const auto xyz = softhom::io::read_dataset(out / "fields.h5", "/mesh/coordinates");
  ASSERT_EQ(conn.dims.size(), 2u);
  ASSERT_EQ(conn.dims[1], 10u);
  const int edges[6][2] = {{0, 1}, {1, 2}, {2, 0}, {0, 3}, {1, 3}, {2, 3}};
  double worst = 0.0;
  for (std::size_t e = 0; e < conn.dims[0]; ++e)
    for (int k = 0; k < 6; ++k)
      for (int i = 0; i < 3; ++i) {
        auto X = [&](int a) { return xyz.values[3 * std::size_t(conn.values[10 * e + a]) + i]; };
        worst = std::max(worst, std::abs(X(4 + k) - 0.5 * (X(edges[k][0]) + X(edges[k][1]))));
      }
  EXPECT_LT(worst, 1e-12);
}

TEST(MacroGmshCli, BadImportedSceneNamesTheField) {
  const auto out = fresh_dir("macro-gmsh-bad");
  const auto missing = run_softhom("macro " + write_temp_scene("gmsh-missing", box_scene("", "/nonexistent/mesh.msh")) +
                                   " --out " + out.string() + " -q");
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_NE(missing.output.find("geometry.file"), std::string::npos) << missing.output;
  const auto surface = run_softhom(
      "macro " + write_temp_scene("gmsh-surface", box_scene("[[boundary]]\nsurface = \"nowhere\"\nfix = [\"y\"]\n")) +
      " --out " + out.string() + " -q");
  EXPECT_EQ(surface.exit_code, 2);
  EXPECT_NE(surface.output.find("nowhere"), std::string::npos) << surface.output;
  const auto region = run_softhom("macro " +
                                  write_temp_scene("gmsh-region", box_scene("") + "[regions.core]\npreset = \"pdms\"\n") +
                                  " --out " + out.string() + " -q");
  EXPECT_EQ(region.exit_code, 2);
  EXPECT_NE(region.output.find("regions.core"), std::string::npos) << region.output;
}
