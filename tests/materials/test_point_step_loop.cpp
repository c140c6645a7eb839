// The material-point driver on the shared sub-step loop (advance_interval): halving cut-backs that keep
// the converged answer, the Gent-locking stop as a fatal outcome, and a stop request that
// keeps the converged rows.
#include <gtest/gtest.h>

#include "softhom/materials/driver.hpp"
#include "softhom/materials/interrupt.hpp"
#include "softhom/materials/library.hpp"

using namespace softhom;

namespace {
PiecewiseLinear unit_ramp(double to) { return {{0.0, 1.0}, {1.0, to}}; }
bool has(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }
}  // namespace

TEST(PointStepLoop, CutBacksHalveGrowAndKeepTheAnswer) {
  const auto m = build_material(preset_spec("ecoflex"));
  MixedControl c = uniaxial_control(unit_ramp(2.5));
  c.times = {1.0};  // one output step of stretch 1 → 2.5
  PointSolverOptions hard;
  hard.max_iterations = 3;  // too few for the whole step: it must be cut back
  const PointRunResult r = run_material_point(*m, c, hard);
  ASSERT_TRUE(r.completed) << r.error;
  EXPECT_GT(r.cutbacks, 0);
  EXPECT_GT(r.steps.back().substeps, 1);
  // Each kind of cut-back is logged once, however many there were.
  EXPECT_EQ(r.log.size(), 1u);
  MixedControl fine = uniaxial_control(unit_ramp(2.5));
  for (int k = 1; k <= 50; ++k) fine.times.push_back(k / 50.0);
  const PointRunResult ref = run_material_point(*m, fine);
  ASSERT_TRUE(ref.completed) << ref.error;
  // Both converge the free components to 1e-10 relative (PointSolverOptions::tolerance) on a
  // hyperelastic law, so the end state is path-independent to about that.
  EXPECT_NEAR(r.steps.back().P(0, 0) / ref.steps.back().P(0, 0), 1.0, 1e-8);
  EXPECT_NEAR(r.steps.back().F(1, 1), ref.steps.back().F(1, 1), 1e-9);
}

TEST(PointStepLoop, LockingIsAFatalStop) {
  const auto m = build_material(preset_spec("verify-iso"));
  MixedControl c = uniaxial_control(unit_ramp(1.3));
  for (int k = 1; k <= 60; ++k) c.times.push_back(k / 60.0);
  const PointRunResult r = run_material_point(*m, c);
  EXPECT_FALSE(r.completed);
  EXPECT_EQ(r.stop, IntervalStatus::fatal);
  EXPECT_TRUE(has(r.error, "locking")) << r.error;
  // Locking at λ ≈ 1.1559 (λ² + 2/λ − 3 = Jm = 0.067): the last row is the output step below it.
  EXPECT_GT(r.steps.back().F(0, 0), 1.1559 - 0.0055);
  EXPECT_LT(r.steps.back().F(0, 0), 1.1560);
}

TEST(PointStepLoop, StopRequestKeepsTheConvergedRows) {
  clear_stop_request();
  const auto m = build_material(preset_spec("ecoflex"));
  MixedControl c = uniaxial_control(unit_ramp(1.5));
  for (int k = 1; k <= 10; ++k) c.times.push_back(k / 10.0);
  int rows = 0;
  const PointRunResult r = run_material_point(*m, c, {}, [&](const PointState&) {
    if (++rows == 4) request_stop();  // t = 0 and three output steps
  });
  clear_stop_request();
  EXPECT_FALSE(r.completed);
  EXPECT_EQ(r.stop, IntervalStatus::interrupted);
  EXPECT_TRUE(has(r.error, "interrupted")) << r.error;
  ASSERT_EQ(r.steps.size(), 4u);
  EXPECT_DOUBLE_EQ(r.steps.back().t, 0.3);
}

TEST(PointStepLoop, WallTimeBudgetEndsTheCutBacks) {
  const auto m = build_material(preset_spec("ecoflex"));
  MixedControl c = uniaxial_control(unit_ramp(2.5));
  c.times = {1.0};
  PointSolverOptions o;
  o.max_iterations = 3;        // the whole step fails and would be cut back ...
  o.max_step_seconds = 1e-12;  // ... but its budget is spent by the first attempt
  const PointRunResult r = run_material_point(*m, c, o);
  EXPECT_FALSE(r.completed);
  EXPECT_EQ(r.stop, IntervalStatus::time_budget);
  EXPECT_EQ(r.cutbacks, 1);
  EXPECT_TRUE(has(r.error, "max_step_seconds")) << r.error;
  ASSERT_EQ(r.steps.size(), 1u) << "only the t = 0 row converged";
}
