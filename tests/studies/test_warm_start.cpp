// Warm starts: the FFT solver's state API (rve::FftRveState) and campaign chains whose cases lie on
// one load path. Tiny cells (8² PDMS + glass, 2-4 load steps) keep the file at a few seconds.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "softhom/io/scene.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/rve/fft_solver.hpp"
#include "softhom/studies/campaign.hpp"
#include "softhom/studies/rve_scene.hpp"
#include "studies/studies_test_helpers.hpp"

namespace fs = std::filesystem;
using namespace softhom;
using namespace softhom::studies;
using softhom::studies::testing::fresh_dir;

namespace {

RveSceneSetup cell(const std::string& matrix_table) {
  const std::string text = "[microstructure]\nshape = \"circle\"\nradius = 0.2\nvolume_fraction = 0.23\ngrid = [8, 8]\nfiber_angle_deg = 45\n"
                           "[phases.matrix]\n" + matrix_table + "\n[phases.fiber]\npreset = \"glass\"\n"
                           "[solver]\ntolerance = 1e-6\nfftw = \"estimate\"\n"
                           "[load]\ntype = \"uniaxial\"\nstretch = 1.2\nduration = 1.0\nsteps = 2\n";
  return parse_rve_scene(io::parse_scene(text, "<test>"));
}

std::unique_ptr<rve::FftRveSolver> solver_for(const RveSceneSetup& s) {
  rve::FftSolverOptions o = s.solver;
  o.plan.threads = 1;  // one thread: bitwise reproducible sums
  return std::make_unique<rve::FftRveSolver>(s.image, s.matrix, s.fiber, s.fiber_angle_deg, s.control.frame, o);
}

/// Uniaxial tension continued from λ = 1.2 to 1.3 in two steps (t restarts at 0).
MixedControl continuation(const RveSceneSetup& s) {
  MixedControl c = s.control;
  c.value[0] = PiecewiseLinear{{0.0, 1.0}, {1.2, 1.3}};
  c.times = {0.5, 1.0};
  return c;
}

}  // namespace

// A run continued from a saved state in a fresh solver repeats the original solver's continuation
// operation for operation (elastic matrix, and a QLV matrix whose history is part of the state).
TEST(WarmStart, SolverStateRestartsBitForBit) {
  for (const std::string& matrix : {std::string("preset = \"pdms\""),
                                   std::string("preset = \"pdms\"\nviscoelastic = {g_inf = 0.7, tau = 0.5}")}) {
    SCOPED_TRACE(matrix);
    const RveSceneSetup s = cell(matrix);
    auto a = solver_for(s);
    const rve::RveRunResult first = a->run(s.control);
    ASSERT_TRUE(first.completed) << first.error;
    const rve::FftRveState saved = a->state();
    EXPECT_NEAR(saved.F(0, 0), 1.2, 1e-15);  // prescribed component exactly at its end value
    if (matrix.find("viscoelastic") != std::string::npos) { EXPECT_FALSE(saved.history_matrix.empty()); }
    else EXPECT_TRUE(saved.history_matrix.empty());

    const rve::RveRunResult cont_a = a->run(continuation(s));
    auto b = solver_for(s);
    b->set_state(saved);
    const rve::RveRunResult cont_b = b->run(continuation(s));
    ASSERT_TRUE(cont_a.completed && cont_b.completed);
    ASSERT_EQ(cont_a.steps.size(), 3u);
    ASSERT_EQ(cont_b.steps.size(), 3u);
    for (std::size_t i = 0; i < 3; ++i) {
      EXPECT_EQ(cont_a.steps[i].P, cont_b.steps[i].P) << i;  // exact: same operations, one thread
      EXPECT_EQ(cont_a.steps[i].F, cont_b.steps[i].F) << i;
      EXPECT_EQ(cont_a.steps[i].newton_iterations, cont_b.steps[i].newton_iterations) << i;
    }
    // The continuation really loads the cell further (not a no-op).
    EXPECT_GT(cont_b.steps[2].P(0, 0), 1.1 * cont_b.steps[0].P(0, 0));
    EXPECT_NEAR(cont_b.steps[2].F(0, 0), 1.3, 1e-15);
  }
}

// A restart (softhom rve --resume): a run stopped at an output time continues from the state and the
// mixed iteration's pressures saved there with run(control, ..., t_start), and repeats the uninterrupted
// run's remaining steps operation for operation (PDMS: K/G = 3e3, so the mixed (u, p) iteration is
// active; elastic and QLV).
TEST(WarmStart, RunContinuedAtAnOutputTimeRepeatsTheUninterruptedRun) {
  for (const std::string& matrix : {std::string("preset = \"pdms\""),
                                   std::string("preset = \"pdms\"\nviscoelastic = {g_inf = 0.7, tau = 0.5}")}) {
    SCOPED_TRACE(matrix);
    const RveSceneSetup s = cell(matrix);
    MixedControl control = s.control;
    control.times = {0.25, 0.5, 0.75, 1.0};
    auto whole = solver_for(s);
    const rve::RveRunResult all = whole->run(control);
    ASSERT_TRUE(all.completed) << all.error;
    ASSERT_EQ(all.steps.size(), 5u);

    MixedControl first_half = control;
    first_half.times = {0.25, 0.5};
    auto stopped = solver_for(s);
    ASSERT_TRUE(stopped->run(first_half).completed);
    const rve::FftRveState state = stopped->state();
    rve::FftRveSolver::MixedPressures pressures = stopped->mixed_pressures();
    EXPECT_FALSE(pressures.committed.empty());
    EXPECT_EQ(pressures.committed.size(), stopped->state_view().pressure.size());

    auto resumed = solver_for(s);
    resumed->set_state(state);
    resumed->set_mixed_pressures(std::move(pressures));
    const rve::RveRunResult rest = resumed->run(control, {}, {}, 0.5);
    ASSERT_TRUE(rest.completed) << rest.error;
    ASSERT_EQ(rest.steps.size(), 2u);  // t = 0.75 and 1: no t = 0 row
    for (std::size_t i = 0; i < 2; ++i) {
      EXPECT_EQ(rest.steps[i].t, all.steps[3 + i].t);
      EXPECT_EQ(rest.steps[i].P, all.steps[3 + i].P) << i;  // exact: same operations, one thread
      EXPECT_EQ(rest.steps[i].newton_iterations, all.steps[3 + i].newton_iterations) << i;
      EXPECT_EQ(rest.steps[i].krylov_iterations, all.steps[3 + i].krylov_iterations) << i;
    }
  }
}

TEST(WarmStart, MixedPressuresOfAnotherSizeAreRejected) {
  const RveSceneSetup s = cell("preset = \"pdms\"");
  auto a = solver_for(s);
  rve::FftRveSolver::MixedPressures p = a->mixed_pressures();
  p.committed.push_back(0.0f);
  EXPECT_THROW(a->set_mixed_pressures(p), InputError);
  // None at all (a checkpoint saved without them): derived by the next run.
  EXPECT_NO_THROW(a->set_mixed_pressures({}));
}

TEST(WarmStart, SolverStateOfAnotherCellIsRejected) {
  const RveSceneSetup s = cell("preset = \"pdms\"");
  auto a = solver_for(s);
  rve::FftRveState st = a->state();
  st.u.resize(st.u.size() / 2);
  try {
    a->set_state(st);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("state"), std::string::npos) << e.what();
  }
  rve::FftRveState bad = a->state();
  bad.F(0, 0) = -1.0;
  EXPECT_THROW(a->set_state(bad), InputError);
}

// Campaign chains. Elastic: tension to λ = 1.2 (2 steps), 1.25 (2 steps, twice as slow) and 1.3 (3
// steps) lie on one path, which is run once with the union of their output points. QLV: a ramp and the
// same ramp followed by a hold (exact prefix). Compression does not lie on the tension path.
TEST(WarmStart, CampaignChainsEqualColdRuns) {
  const char* text = R"(
description = "warm-start chains"
[base.solver]
tolerance = 1e-6
[matrices.pdms_qlv]
preset = "pdms"
viscoelastic = {g_inf = 0.7, tau = 1.0}
[loads.t12]
type = "uniaxial"
stretch = 1.2
steps = 2
[loads.t125]
type = "uniaxial"
stretch = 1.25
duration = 2.0
steps = 2
[loads.t13]
type = "uniaxial"
stretch = 1.3
steps = 3
[loads.c09]
type = "uniaxial"
stretch = 0.9
steps = 2
[loads.ramp]
type = "uniaxial"
stretch = [[0.0, 1.0], [1.0, 1.2]]
dt = 0.5
[loads.ramp_hold]
type = "uniaxial"
stretch = [[0.0, 1.0], [1.0, 1.2], [2.0, 1.2]]
dt = 0.5
[[sweep]]
matrix = ["pdms"]
angle = [45]
volume_fraction = [0.23]
resolution = 8
load = ["t13", "t12", "c09", "t125"]
[[sweep]]
matrix = ["pdms_qlv"]
angle = [45]
volume_fraction = [0.23]
resolution = 8
load = ["ramp_hold", "ramp"]
)";
  const Campaign c = expand_campaign(io::parse_scene(text, "<test>"), fs::temp_directory_path());
  ASSERT_EQ(c.cases.size(), 6u);
  SweepOptions o;
  o.jobs = 1;
  o.threads = 1;
  o.quiet = true;
  const fs::path wdir = fresh_dir("warm"), cdir = fresh_dir("cold");
  const SweepReport warm = run_campaign(c, wdir, o);
  o.warm_start = false;
  const SweepReport cold = run_campaign(c, cdir, o);
  EXPECT_EQ(warm.failed, 0);
  EXPECT_EQ(cold.failed, 0);
  // t125 and t13 continue the tension path, ramp_hold the ramp; c09 runs on its own.
  EXPECT_EQ(warm.warm_started, 3);
  EXPECT_EQ(cold.warm_started, 0);
  // The shared path computes 1.2 → 1.25 → 1.3 once (plus the inserted point 1.125): fewer iterations.
  EXPECT_LT(warm.newton_iterations, cold.newton_iterations);

  const auto ws = read_store(wdir / "campaign.h5"), cs = read_store(cdir / "campaign.h5");
  const std::string base = "pdms-circle-a45-vf0.23-square-n8x8-";
  EXPECT_EQ(ws.at(base + "t125").info.at("warm_start_from"), base + "t12");
  EXPECT_EQ(ws.at(base + "t13").info.at("warm_start_from"), base + "t125");
  EXPECT_EQ(ws.at(base + "t12").info.at("on_path_of"), base + "t13");
  EXPECT_EQ(ws.at(base + "c09").info.count("warm_start_from"), 0u);
  EXPECT_EQ(ws.at("pdms_qlv-circle-a45-vf0.23-square-n8x8-ramp_hold").info.at("warm_start_from"),
            "pdms_qlv-circle-a45-vf0.23-square-n8x8-ramp");
  for (const auto& [id, w] : ws) {
    SCOPED_TRACE(id);
    const CaseRecord& k = cs.at(id);
    ASSERT_EQ(w.status, "ok") << w.error;
    ASSERT_EQ(w.rows(), k.rows());
    ASSERT_EQ(w.columns, k.columns);
    const std::size_t nc = w.columns.size();
    for (std::size_t row = 0; row < w.rows(); ++row)
      for (std::size_t col = 0; col < 2 * 9 + 1; ++col) {  // t, F, P (load frame)
        const double a = w.data[row * nc + col], b = k.data[row * nc + col];
        if (col <= 9) {
          // t and F: the same prescribed values / the same converged free components up to tolerance.
          EXPECT_NEAR(a, b, 1e-6 * std::max(1.0, std::abs(b))) << "row " << row << " " << w.columns[col];
        } else {
          // P: relative residual 1e-6 of the stress scale (PDMS + glass: |P11| ~ 0.1-1 MPa) → a few
          // 1e-6 MPa at most between two converged states reached by different steps.
          EXPECT_NEAR(a, b, 2e-5 * std::max(0.1, std::abs(b))) << "row " << row << " " << w.columns[col];
        }
      }
  }
  // The chain members' own rows: t12 at λ = 1.1, 1.2; t125 at 1.125, 1.25 (its own times 1, 2).
  const CaseRecord& r125 = ws.at(base + "t125");
  ASSERT_EQ(r125.rows(), 3u);
  EXPECT_DOUBLE_EQ(r125.data[2 * r125.columns.size() + 0], 2.0);
  EXPECT_NEAR(r125.data[2 * r125.columns.size() + 1], 1.25, 1e-12);

  // Resume: drop the middle member of the tension chain and rerun warm. The chain is recomputed from
  // its start with the output points of all its members (t13's too, though it is not rerun), so the
  // recomputed case is bitwise the stored one (one thread).
  auto records = ws;
  records.erase(base + "t125");
  write_store(wdir / "campaign.h5", records, c.description);
  o.warm_start = true;
  const SweepReport resumed = run_campaign(c, wdir, o);
  EXPECT_EQ(resumed.finished, 1);
  EXPECT_EQ(resumed.skipped, 5);
  const auto rs = read_store(wdir / "campaign.h5");
  EXPECT_EQ(rs.at(base + "t125").data, ws.at(base + "t125").data);
  EXPECT_EQ(rs.at(base + "t125").info, ws.at(base + "t125").info);
  fs::remove_all(wdir);
  fs::remove_all(cdir);
}
