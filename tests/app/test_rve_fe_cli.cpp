// `softhom rve` with [solver] engine = "fe": same response.csv columns and summary.json keys as the FFT
// engine (plus mesh statistics), T6 fields for ParaView, and clear errors for bad engine input.
#include <gtest/gtest.h>

#include <fstream>

#include <nlohmann/json.hpp>

#include "app/cli_helpers.hpp"

using namespace softhom::test;

namespace {

std::string pdms_cell(const std::string& solver) {
  return "[microstructure]\nshape = \"circle\"\nvolume_fraction = 0.23\nradius = 0.2\nfiber_angle_deg = 45\n"
         "grid = [16, 16]\n[phases.matrix]\npreset = \"pdms\"\n[phases.fiber]\npreset = \"glass\"\n"
         "[load]\ntype = \"uniaxial\"\nstretch = 1.2\nsteps = 1\n[solver]\n" +
         solver + "\n[output]\nfields = \"last\"\n";
}

}  // namespace

// The FE and FFT runs of one cell: identical CSV header, every FFT summary key present in the FE
// summary, P11 within 0.5 % (FFT 16² discretization error on this cell is ~1e-3, test_fe_solver.cpp).
// One thread: OpenMP spin-waiting on this shared 2-core box made the 2-thread FFT run 25x slower.
TEST(RveFeCli, SameOutputContractAsFftEngine) {
  const auto fe_dir = fresh_dir("rve-fe"), fft_dir = fresh_dir("rve-fft");
  const auto fe = run_softhom("rve " + write_temp_scene("rve-fe", pdms_cell("engine = \"fe\"\nmesh_size = 0.1")) +
                              " --out " + fe_dir.string() + " --quiet --threads 1");
  ASSERT_EQ(fe.exit_code, 0) << fe.output;
  const auto fft = run_softhom("rve " + write_temp_scene("rve-fft", pdms_cell("engine = \"fft\"\nfftw = \"estimate\"")) +
                               " --out " + fft_dir.string() + " --quiet --threads 1");
  ASSERT_EQ(fft.exit_code, 0) << fft.output;
  const Csv a = read_csv(fe_dir / "response.csv"), b = read_csv(fft_dir / "response.csv");
  EXPECT_EQ(a.columns, b.columns);
  ASSERT_EQ(a.rows.size(), 2u);
  ASSERT_EQ(b.rows.size(), 2u);
  EXPECT_NEAR(a.at(1, "P11") / b.at(1, "P11"), 1.0, 5e-3);
  const auto ja = read_json(fe_dir / "summary.json"), jb = read_json(fft_dir / "summary.json");
  for (const auto& item : jb.items()) EXPECT_TRUE(ja.contains(item.key())) << item.key();
  EXPECT_EQ(ja["engine"], "fe");
  EXPECT_GT(ja["mesh"]["elements"].get<int>(), 100);
  EXPECT_GT(ja["mesh"]["min_angle_deg"].get<double>(), 20.0);
  EXPECT_TRUE(std::filesystem::exists(fe_dir / "fields.h5"));
  std::ifstream x(fe_dir / "fields.xdmf");
  const std::string xdmf((std::istreambuf_iterator<char>(x)), std::istreambuf_iterator<char>());
  EXPECT_NE(xdmf.find("Triangle_6"), std::string::npos);
  EXPECT_NE(xdmf.find("displacement"), std::string::npos);
}

TEST(RveFeCli, BadEngineInputNamesTheField) {
  const auto dir = fresh_dir("rve-fe-bad");
  auto r = run_softhom("rve " + write_temp_scene("rve-fe-bad1", pdms_cell("engine = \"fem\"")) + " --out " + dir.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("solver.engine"), std::string::npos) << r.output;
  r = run_softhom("rve " + write_temp_scene("rve-fe-bad2", pdms_cell("engine = \"fe\"\nmesh_size = -0.1")) + " --out " +
                  dir.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("solver.mesh_size"), std::string::npos) << r.output;
  r = run_softhom("rve " + write_temp_scene("rve-fe-bad3", pdms_cell("engine = \"fe\"\ndiscretization = \"hex\"")) +
                  " --out " + dir.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("solver.discretization"), std::string::npos) << r.output;
}

// engine = "auto" + target_error: the benchmark's choice (BENCHMARKS.md, FE RVE): FFT 16² for a PDMS
// matrix at 0.1 %, FE on the coarsest mesh (L/4) for ecoflex (K/G = 1.2e5) at the same target; a
// scene giving both a resolution and a target is refused.
TEST(RveFeCli, AutoEngineFollowsTheBenchmark) {
  auto cell = [](const std::string& matrix, const std::string& solver, bool grid) {
    return "[microstructure]\nshape = \"circle\"\nvolume_fraction = 0.23\nradius = 0.2\nfiber_angle_deg = 45\n" +
           std::string(grid ? "grid = [16, 16]\n" : "") + "[phases.matrix]\npreset = \"" + matrix +
           "\"\n[phases.fiber]\npreset = \"glass\"\n[load]\ntype = \"uniaxial\"\nstretch = 1.1\nsteps = 1\n[solver]\n" +
           solver + "\n[output]\nfields = \"none\"\n";
  };
  const auto d1 = fresh_dir("rve-auto-pdms"), d2 = fresh_dir("rve-auto-eco");
  auto r = run_softhom("rve " + write_temp_scene("rve-auto-pdms", cell("pdms", "engine = \"auto\"\ntarget_error = 1e-3", false)) +
                       " --out " + d1.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("FFT 16"), std::string::npos) << r.output;
  EXPECT_EQ(read_json(d1 / "summary.json")["grid"][0], 16);
  r = run_softhom("rve " + write_temp_scene("rve-auto-eco", cell("ecoflex", "engine = \"auto\"\ntarget_error = 1e-3", false)) +
                  " --out " + d2.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto j = read_json(d2 / "summary.json");
  EXPECT_EQ(j["engine"], "fe");
  EXPECT_NEAR(j["mesh"]["mesh_size"].get<double>() / j["cell_size"][0].get<double>(), 0.25, 1e-12);
  r = run_softhom("rve " + write_temp_scene("rve-auto-both", cell("pdms", "engine = \"auto\"\ntarget_error = 1e-3", true)) +
                  " --out " + d1.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("solver.target_error"), std::string::npos) << r.output;
}
