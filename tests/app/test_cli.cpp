// The `softhom` program as a user meets it: shipped point scenes, output contract, error handling.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "app/cli_helpers.hpp"

using namespace softhom::test;
namespace fs = std::filesystem;

namespace {
double mu_eff(double G, double Jm, double I1) { return G * Jm / (Jm - I1 + 3.0); }

std::vector<std::string> point_columns(int fibers) {
  std::vector<std::string> c{"t"};
  for (const char* n : {"F", "P", "sigma"})
    for (int i = 1; i <= 3; ++i)
      for (int j = 1; j <= 3; ++j) c.push_back(n + std::to_string(i) + std::to_string(j));
  for (int f = 1; f <= fibers; ++f) c.push_back("fiber" + std::to_string(f) + "_angle_deg");
  return c;
}

}  // namespace

TEST(Cli, VersionAndHelp) {
  const auto v = run_softhom("--version");
  EXPECT_EQ(v.exit_code, 0);
  EXPECT_NE(v.output.find("softhom 0."), std::string::npos) << v.output;
  const auto h = run_softhom("--help");
  EXPECT_EQ(h.exit_code, 0);
  for (const char* sub : {"point", "rve", "macro", "demo"}) EXPECT_NE(h.output.find(sub), std::string::npos);
  EXPECT_EQ(run_softhom("point --help").exit_code, 0);
}

TEST(Cli, UniaxialEcoflexSceneMatchesClosedForm) {
  const auto out = fresh_dir("uniaxial-ecoflex");
  const auto r = run_softhom("point " + scene("point_uniaxial_ecoflex") + " --out " + out.string() + " -q");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Csv csv = read_csv(out / "response.csv");
  EXPECT_EQ(csv.columns, point_columns(0));
  ASSERT_EQ(csv.rows.size(), 101u);  // t = 0 plus 100 steps
  const double l = csv.at(100, "F11");
  EXPECT_NEAR(l, 3.0, 1e-12);
  // spec §5 eq. 3.2 at λ = 3; K = 2000 vs K → ∞ differs by O(G/K): 1e-3 relative is the required bound.
  const double expected = (l * l - 1 / l) * mu_eff(0.017, 14.0, l * l + 2 / l);
  EXPECT_NEAR(csv.at(100, "sigma11") / expected, 1.0, 1e-3);
  const auto summary = read_json(out / "summary.json");
  EXPECT_TRUE(summary["completed"].get<bool>());
  EXPECT_EQ(summary["command"], "point");
  EXPECT_TRUE(summary.contains("softhom_version"));
  EXPECT_TRUE(summary["scene"].contains("material"));
}

TEST(Cli, FiberScenesMatchClosedForms) {
  {
    const auto out = fresh_dir("uniaxial-fiber");
    const auto r = run_softhom("point " + scene("point_uniaxial_fiber") + " --out " + out.string() + " -q");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const Csv csv = read_csv(out / "response.csv");
    EXPECT_EQ(csv.columns, point_columns(1));
    const std::size_t last = csv.rows.size() - 1;
    const double l = csv.at(last, "F11"), I4 = l * l;
    const double expected = (l * l - 1 / l) * mu_eff(0.017, 14.0, l * l + 2 / l) +
                            2 * 0.8 * (I4 - 1) * std::exp(18 * (I4 - 1) * (I4 - 1)) * l * l;
    EXPECT_NEAR(l, 1.2, 1e-12);
    EXPECT_NEAR(csv.at(last, "sigma11") / expected, 1.0, 1e-3);
  }
  {
    const auto out = fresh_dir("equibiaxial-fiber30");
    const auto r = run_softhom("point " + scene("point_equibiaxial_fiber30") + " --out " + out.string() + " -q");
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const Csv csv = read_csv(out / "response.csv");
    const std::size_t last = csv.rows.size() - 1;
    const double l = csv.at(last, "F11"), I4 = l * l, phi = M_PI / 6;
    const double iso = (l * l - std::pow(l, -4)) * mu_eff(0.017, 14.0, 2 * l * l + std::pow(l, -4));
    const double f = 2 * 0.8 * (I4 - 1) * std::exp(18 * (I4 - 1) * (I4 - 1)) * l * l;
    EXPECT_NEAR(csv.at(last, "sigma11") / (iso + f * std::cos(phi) * std::cos(phi)), 1.0, 1e-3);
    EXPECT_NEAR(csv.at(last, "sigma22") / (iso + f * std::sin(phi) * std::sin(phi)), 1.0, 1e-3);
    EXPECT_NEAR(csv.at(last, "sigma12") / (f * std::sin(phi) * std::cos(phi)), 1.0, 1e-3);
    EXPECT_NEAR(csv.at(last, "sigma33"), 0.0, 1e-8);
  }
}

TEST(Cli, RelaxationSceneRelaxesTowardLongTermValue) {
  const auto out = fresh_dir("relaxation");
  const auto r = run_softhom("point " + scene("point_relaxation") + " --out " + out.string() + " -q");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const Csv csv = read_csv(out / "response.csv");
  ASSERT_EQ(csv.rows.size(), 401u);
  const double peak = csv.at(200, "sigma11");  // t = 20 s: end of the ramp
  const double end = csv.at(400, "sigma11");   // t = 40 s: 20 τ into the hold
  EXPECT_NEAR(csv.at(200, "t"), 20.0, 1e-12);
  EXPECT_LT(end, peak);
  // After 20 τ the deviatoric stress has relaxed to g∞ = 0.5 of its elastic value (e^-20 ≈ 2e-9).
  const double l = 3.0;
  const double elastic = (l * l - 1 / l) * mu_eff(0.024, 14.0, l * l + 2 / l);
  EXPECT_NEAR(end / (0.5 * elastic), 1.0, 1e-3);
}

TEST(Cli, LockingSceneStopsWithMessageAndKeepsRows) {
  const auto out = fresh_dir("locking");
  const auto r = run_softhom("point " + scene("point_locking") + " --out " + out.string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("locking"), std::string::npos) << r.output;
  const Csv csv = read_csv(out / "response.csv");
  ASSERT_GT(csv.rows.size(), 30u);  // λ from 1 to ≈ 1.155 in steps of 0.005
  EXPECT_LT(csv.at(csv.rows.size() - 1, "F11"), 1.1560);
  for (const auto& row : csv.rows)
    for (double v : row) EXPECT_TRUE(std::isfinite(v));
  const auto summary = read_json(out / "summary.json");
  EXPECT_FALSE(summary["completed"].get<bool>());
  EXPECT_NE(summary["error"].get<std::string>().find("locking"), std::string::npos);
}

TEST(Cli, BadInputNamesFieldAndWritesNothing) {
  struct Case {
    std::string scene, expect;
  };
  const Case cases[] = {
      {"[material]\npreset = \"ecoflex\"\nG = -1.0\n[load]\ntype = \"uniaxial\"\nstretch = 2.0\n", "material.G = -1"},
      {"[material]\npreset = \"ecoflex\"\nGG = 1.0\n[load]\ntype = \"uniaxial\"\nstretch = 2.0\n", "material.GG"},
      {"[material]\npreset = \"ecoflex\"\n[load]\ntype = \"uniaxal\"\nstretch = 2.0\n", "load.type = \"uniaxal\": must be \"uniaxial\""},
      {"[material]\npreset = \"ecoflex\"\n[load]\ntype = \"uniaxial\"\nstretch = -2.0\n", "load.stretch"},
      {"[material]\npreset = \"ecoflex-anisotropic\"\n[[material.fibers]]\nangle_deg = 30\n[load]\ntype = \"uniaxial\"\nstretch = 1.1\n",
       "material.fiber_invariant"},
      {"[material]\nlaw = \"gent\"\nG = 0.1\nJm = 10\nK = 100\n[material.viscoelastic]\ng_inf = 0.0\ntau = 1\n[load]\ntype = \"uniaxial\"\nstretch = 1.1\n",
       "material.viscoelastic.g_inf = 0"},
      {"[material]\npreset = \"ecoflex\"\n[load]\ntype = \"uniaxial\"\nstretch = 2.0\nsteps = 0\n", "load.steps"},
      {"[material\npreset = \"ecoflex\"\n", "TOML syntax error"},
  };
  int k = 0;
  for (const auto& c : cases) {
    const auto out = fresh_dir("bad-" + std::to_string(k));
    const auto path = write_temp_scene("bad-" + std::to_string(k++), c.scene);
    const auto r = run_softhom("point " + path + " --out " + out.string());
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find(c.expect), std::string::npos) << "expected '" << c.expect << "' in: " << r.output;
    EXPECT_FALSE(fs::exists(out / "response.csv"));
  }
  EXPECT_NE(run_softhom("point /nonexistent/scene.toml").exit_code, 0);
}
