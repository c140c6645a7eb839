// Sweep campaigns: expansion, store round trip, resume after a simulated kill, failed cases, cases.csv,
// warm starts. Tiny cells (8² PDMS + glass, 2-3 load steps) keep the whole file at a few seconds.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "softhom/io/scene.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/studies/campaign.hpp"
#include "studies/studies_test_helpers.hpp"

namespace fs = std::filesystem;
using namespace softhom;
using namespace softhom::studies;
using softhom::studies::testing::fresh_dir;
using softhom::studies::testing::expand;

namespace {

// Two prefix-related tension loads (t12 is the start of t13), 2 matrices x 2 angles on 8² grids,
// the pure matrix, and one case that must fail (one Newton iteration allowed, no cut-back).
const char* kTiny = R"(
description = "tiny test campaign"
[base.solver]
tolerance = 1e-6
[loads.t12]
type = "uniaxial"
stretch = [[0.0, 1.0], [2.0, 1.2]]
dt = 1.0
[loads.t13]
type = "uniaxial"
stretch = [[0.0, 1.0], [3.0, 1.3]]
dt = 1.0
[sweep]
matrix = ["pdms"]
angle = [30, 60]
volume_fraction = [0.0, 0.23]
resolution = 8
load = ["t12", "t13"]
[[cases]]
name = "failing"
matrix = "pdms"
load = "t12"
resolution = 8
override = {solver = {max_newton_iterations = 1, max_cutbacks = 0}}
)";

SweepOptions quiet_options(int jobs) {
  SweepOptions o;
  o.jobs = jobs;
  o.threads = jobs;  // one OpenMP thread per case: bitwise reproducible sums
  o.quiet = true;
  return o;
}

/// Store equality up to the timings (the only thing allowed to differ between two runs).
void expect_same_store(const std::map<std::string, CaseRecord>& a, const std::map<std::string, CaseRecord>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (const auto& [id, ra] : a) {
    ASSERT_TRUE(b.count(id)) << id;
    const CaseRecord& rb = b.at(id);
    EXPECT_EQ(ra.status, rb.status) << id;
    EXPECT_EQ(ra.error, rb.error) << id;
    EXPECT_EQ(ra.scene_hash, rb.scene_hash) << id;
    EXPECT_EQ(ra.columns, rb.columns) << id;
    ASSERT_EQ(ra.parameters.size(), rb.parameters.size());
    for (std::size_t k = 0; k < ra.parameters.size(); ++k) {
      EXPECT_EQ(ra.parameters[k].name, rb.parameters[k].name);
      EXPECT_EQ(ra.parameters[k].text(), rb.parameters[k].text());
    }
    // Exact: same chain, same thread count → the same floating-point operations.
    EXPECT_EQ(ra.data, rb.data) << id;
    EXPECT_EQ(ra.info, rb.info) << id;
    for (const auto& [k, v] : ra.stats) {
      if (!is_timing_stat(k)) {
        EXPECT_EQ(v, rb.stats.at(k)) << id << " " << k;
      }
    }
  }
}

}  // namespace

TEST(Campaign, ExpandsProductsCasesAndDefaults) {
  const Campaign c = expand(kTiny);
  // 1 matrix x 2 angles x {0, 0.23} x 2 loads, but the pure matrix does not depend on the angle:
  // 2 x 2 composite + 2 matrix + 1 explicit = 7.
  ASSERT_EQ(c.cases.size(), 7u);
  EXPECT_EQ(c.description, "tiny test campaign");
  EXPECT_EQ(c.cases[0].id, "pdms-matrix-n8x8-t12");
  EXPECT_EQ(c.cases[2].id, "pdms-circle-a30-vf0.23-square-n8x8-t12");
  EXPECT_EQ(c.cases.back().id, "failing");
  // Parameters in axis order, defaults filled in (section circle, arrangement square).
  const auto& p = c.cases[2].parameters;
  ASSERT_EQ(p.size(), campaign_axes().size());
  for (std::size_t k = 0; k < p.size(); ++k) EXPECT_EQ(p[k].name, campaign_axes()[k]);
  EXPECT_EQ(p[1].text(), "circle");
  EXPECT_DOUBLE_EQ(std::get<double>(p[2].value), 30.0);
  EXPECT_EQ(p[4].text(), "square");
  // The scene is a complete `softhom rve` scene.
  const toml::table& s = c.cases[2].scene;
  EXPECT_EQ(s["phases"]["matrix"]["preset"].value_or(std::string()), "pdms");
  EXPECT_EQ(s["phases"]["fiber"]["preset"].value_or(std::string()), "glass");  // default fiber
  EXPECT_DOUBLE_EQ(s["microstructure"]["radius"].value_or(0.0), 0.2);          // built-in circle
  EXPECT_DOUBLE_EQ(s["microstructure"]["fiber_angle_deg"].value_or(0.0), 30.0);
  EXPECT_EQ(s["microstructure"]["grid"].as_array()->size(), 2u);
  EXPECT_DOUBLE_EQ(s["solver"]["tolerance"].value_or(0.0), 1e-6);               // from [base]
  EXPECT_EQ(c.cases.back().scene["solver"]["max_newton_iterations"].value_or(0), 1);  // override
  // Cases differing only in the load share the microstructure hash, not the scene hash.
  EXPECT_EQ(c.cases[2].microstructure_hash, c.cases[3].microstructure_hash);
  EXPECT_NE(c.cases[2].scene_hash, c.cases[3].scene_hash);
  EXPECT_NE(c.cases[2].microstructure_hash, c.cases[4].microstructure_hash);
}

TEST(Campaign, BaseSceneKeepsItsSectionGridAndSolver) {
  // base_scene: the shipped square-fiber scene; only the angle is swept.
  const std::string text = "base_scene = \"" + (fs::path(SOFTHOM_SOURCE_DIR) / "studies/scenes/rve_ecoflex_rect45_vf23.toml").string() +
                           "\"\n[sweep]\nmatrix = [\"ecoflex\"]\nangle = [30, 60]\nload = [\"tension\"]\n";
  const Campaign c = expand(text);
  ASSERT_EQ(c.cases.size(), 2u);
  EXPECT_EQ(c.cases[0].id, "ecoflex-square-a30-vf0.23-square-n32x32-tension");
  const toml::table& m = *c.cases[1].scene["microstructure"].as_table();
  EXPECT_EQ(m["shape"].value_or(std::string()), "square");
  EXPECT_DOUBLE_EQ(m["width"].value_or(0.0), 0.07);
  EXPECT_FALSE(m.contains("radius"));
  EXPECT_DOUBLE_EQ(m["fiber_angle_deg"].value_or(0.0), 60.0);
  EXPECT_EQ(c.cases[1].scene["solver"]["discretization"].value_or(std::string()), "rotated");
  EXPECT_FALSE(c.cases[1].scene.contains("output"));  // campaigns store no fields
}

TEST(Campaign, ShippedChapter4CampaignExpands) {
  const fs::path file = fs::path(SOFTHOM_SOURCE_DIR) / "studies/campaigns/chapter4.toml";
  const Campaign c = expand_campaign(io::load_scene(file), file.parent_path());
  // 2 matrices x 2 sections x 3 angles x 2 VF x 2 loads + 2 QLV matrices x 2 sections x 3 angles
  // relaxation + 4 + 2 pure matrix cases.
  EXPECT_EQ(c.cases.size(), 48u + 12u + 6u);
}

TEST(Campaign, BadInputNamesTheField) {
  auto message = [](const std::string& text) {
    try {
      expand(text);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message("[sweep]\nmatrix = [\"pdms\"]\nload = [\"tension\"]\nangel = [30]\n").find("sweep.angel"), std::string::npos);
  EXPECT_NE(message("[sweep]\nmatrix = [\"pdms\"]\nload = [\"pull\"]\n").find("sweep.load = pull"), std::string::npos);
  EXPECT_NE(message("[sweep]\nmatrix = [\"pdms\"]\nload = [\"tension\"]\nvolume_fraction = [0.9]\n").find("volume_fraction"),
            std::string::npos);
  EXPECT_NE(message("[sweep]\nmatrix = [\"jelly\"]\nload = [\"tension\"]\n").find("phases.matrix"), std::string::npos);
  EXPECT_NE(message("[sweep]\nload = [\"tension\"]\n").find("sweep.matrix"), std::string::npos);
  EXPECT_NE(message("description = \"empty\"\n").find("no cases"), std::string::npos);
}

TEST(Campaign, RunRecordsFailuresWritesCsvAndWarmStarts) {
  const fs::path dir = fresh_dir("run");
  const Campaign c = expand(kTiny);
  const SweepReport r = run_campaign(c, dir, quiet_options(2));
  EXPECT_EQ(r.total, 7);
  EXPECT_EQ(r.finished, 7);
  EXPECT_EQ(r.failed, 1);
  // t13 continues from t12 on each of the 3 microstructures.
  EXPECT_EQ(r.warm_started, 3);
  const auto store = read_store(dir / "campaign.h5");
  ASSERT_EQ(store.size(), 7u);

  // The failing case is recorded with its error and its converged t = 0 row; the others are ok.
  const CaseRecord& f = store.at("failing");
  EXPECT_EQ(f.status, "failed");
  EXPECT_NE(f.error.find("Newton"), std::string::npos) << f.error;
  EXPECT_EQ(f.rows(), 1u);
  for (const auto& [id, rec] : store) {
    if (id != "failing") {
      EXPECT_EQ(rec.status, "ok") << id << ": " << rec.error;
    }
  }

  // Warm start: the continued case starts with the prefix case's rows (copied exactly) and its
  // remaining rows agree with a cold run to the solver tolerance (1e-6 relative residual → a few 1e-6
  // on stresses at most; measured ≈ 3e-8).
  const CaseRecord& a = store.at("pdms-circle-a60-vf0.23-square-n8x8-t12");
  const CaseRecord& b = store.at("pdms-circle-a60-vf0.23-square-n8x8-t13");
  EXPECT_EQ(b.info.at("warm_start_from"), a.id);
  ASSERT_EQ(a.rows(), 3u);
  ASSERT_EQ(b.rows(), 4u);
  for (std::size_t i = 0; i < a.data.size(); ++i) EXPECT_EQ(a.data[i], b.data[i]);
  const fs::path cold_dir = fresh_dir("cold");
  SweepOptions cold = quiet_options(1);
  cold.warm_start = false;
  run_campaign(c, cold_dir, cold);
  const auto cold_store = read_store(cold_dir / "campaign.h5");
  const CaseRecord& bc = cold_store.at(b.id);
  EXPECT_EQ(bc.info.count("warm_start_from"), 0u);
  const std::size_t P11 = 10, nc = b.columns.size();
  ASSERT_EQ(b.columns[P11], "P11");
  for (std::size_t row = 1; row < 4; ++row)
    EXPECT_NEAR(b.data[row * nc + P11], bc.data[row * nc + P11], 1e-5 * std::abs(bc.data[row * nc + P11])) << row;
  // Tension at λ = 1.3 must give a positive, growing nominal stress (the run is not a no-op).
  EXPECT_GT(bc.data[3 * nc + P11], bc.data[2 * nc + P11]);
  EXPECT_GT(bc.data[2 * nc + P11], 0.0);

  // cases.csv: header, one row per case and step (the failed case: its one row).
  std::ifstream in(dir / "cases.csv");
  std::string header;
  std::getline(in, header);
  EXPECT_EQ(header.rfind("case,status,matrix,section,angle,volume_fraction,arrangement,resolution,load,step,t,F11,", 0), 0u)
      << header;
  EXPECT_NE(header.find(",P11,"), std::string::npos);
  EXPECT_NE(header.find(",delta_fiber_angle_deg,"), std::string::npos);
  std::size_t lines = 0, expected = 0, commas = std::count(header.begin(), header.end(), ',');
  for (const auto& [id, rec] : store) expected += std::max<std::size_t>(rec.rows(), 1);
  bool saw_failed = false;
  for (std::string line; std::getline(in, line); ++lines) {
    EXPECT_EQ(std::size_t(std::count(line.begin(), line.end(), ',')), commas) << line.substr(0, 80);
    if (line.rfind("failing,failed,pdms,", 0) == 0) saw_failed = true;
  }
  EXPECT_EQ(lines, expected);
  EXPECT_TRUE(saw_failed);
  fs::remove_all(dir);
  fs::remove_all(cold_dir);
}

TEST(Campaign, ResumeAfterKillGivesTheSameStore) {
  const Campaign c = expand(kTiny);
  const fs::path full = fresh_dir("full"), part = fresh_dir("part");
  run_campaign(c, full, quiet_options(2));
  const auto reference = read_store(full / "campaign.h5");

  // "Kill" after two committed cases: the cases in flight are lost, the store stays readable.
  SweepOptions killed = quiet_options(2);
  killed.max_new_cases = 2;
  run_campaign(c, part, killed);
  const auto partial = read_store(part / "campaign.h5");
  EXPECT_GE(partial.size(), 2u);
  EXPECT_LT(partial.size(), 7u);
  EXPECT_FALSE(fs::exists(part / "campaign.h5.tmp"));

  // Rerun: finished cases are skipped, the rest computed; same store as the uninterrupted run.
  const SweepReport r = run_campaign(c, part, quiet_options(2));
  EXPECT_EQ(r.skipped, int(partial.size()));
  EXPECT_EQ(r.finished, 7 - int(partial.size()));
  expect_same_store(reference, read_store(part / "campaign.h5"));

  // Delete one case (the warm-started one, so its chain must be recomputed from the start) and rerun.
  auto records = read_store(part / "campaign.h5");
  records.erase("pdms-circle-a30-vf0.23-square-n8x8-t13");
  write_store(part / "campaign.h5", records, c.description);
  const SweepReport r2 = run_campaign(c, part, quiet_options(1));
  EXPECT_EQ(r2.skipped, 6);
  EXPECT_EQ(r2.finished, 1);
  expect_same_store(reference, read_store(part / "campaign.h5"));

  // A third run has nothing to do; the failed case is retried only on request.
  EXPECT_EQ(run_campaign(c, part, quiet_options(1)).finished, 0);
  SweepOptions retry = quiet_options(1);
  retry.retry_failed = true;
  const SweepReport r3 = run_campaign(c, part, retry);
  EXPECT_EQ(r3.finished, 1);
  EXPECT_EQ(r3.failed, 1);
  fs::remove_all(full);
  fs::remove_all(part);
}

TEST(Campaign, ChangedCaseIsRerun) {
  const fs::path dir = fresh_dir("changed");
  const std::string one = "[sweep]\nmatrix = [\"pdms\"]\nvolume_fraction = [0.0]\nresolution = 8\nload = [\"t\"]\n"
                          "[loads.t]\ntype = \"uniaxial\"\nstretch = 1.1\nsteps = 1\n";
  EXPECT_EQ(run_campaign(expand(one), dir, quiet_options(1)).finished, 1);
  EXPECT_EQ(run_campaign(expand(one), dir, quiet_options(1)).finished, 0);
  std::string changed = one;
  changed.replace(changed.find("1.1"), 3, "1.2");  // same id, different scene
  EXPECT_EQ(run_campaign(expand(changed), dir, quiet_options(1)).finished, 1);
  const auto store = read_store(dir / "campaign.h5");
  ASSERT_EQ(store.size(), 1u);
  const CaseRecord& r = store.begin()->second;
  EXPECT_DOUBLE_EQ(r.data[r.columns.size() + 1], 1.2);  // F11 of the last row
  fs::remove_all(dir);
}
