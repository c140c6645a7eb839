// The pure pieces of the `softhom demo` report (softhom/jobs/demo_report.hpp): parameters at their bounds are
// named with the bound they sit on, and the tube's last row is shown by name, not as a raw CSV line.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "softhom/jobs/demo_report.hpp"

using softhom::jobs::bound_notes;
using softhom::jobs::join_state;
using softhom::jobs::tube_final_state;

namespace {
// The shape of calibration/summary.json "parameters" (studies/src/calibration.cpp).
nlohmann::json parameter(const std::string& name, double value, bool free, bool at_bound, double lo, double hi) {
  nlohmann::json p{{"name", name}, {"value", value}, {"free", free}};
  if (free) {
    p["min"] = lo;
    p["max"] = hi;
    p["at_bound"] = at_bound;
    p["std_error"] = 0.39;
  }
  return p;
}
}  // namespace

TEST(DemoReport, ParameterAtItsLowerBoundGetsACalmNote) {
  nlohmann::json summary;
  summary["parameters"] = {parameter("G", 0.0195, true, false, 0.0034, 0.85),
                           parameter("K", 2000, false, false, 0, 0),
                           parameter("k2", 0.001, true, true, 0.001, 50.0)};
  const auto notes = bound_notes(summary);
  ASSERT_EQ(notes.size(), 1u);
  EXPECT_EQ(notes[0], "k2 at its lower bound 0.001: the curves do not determine it");
}

TEST(DemoReport, UpperBoundIsNamedAsUpperAndInteriorOrFixedParametersGetNone) {
  nlohmann::json summary;
  summary["parameters"] = {parameter("Jm", 200.0, true, true, 1.0, 200.0),
                           parameter("k1", 0.01, true, false, 1e-5, 3.4)};
  const auto notes = bound_notes(summary);
  ASSERT_EQ(notes.size(), 1u);
  EXPECT_EQ(notes[0], "Jm at its upper bound 200: the curves do not determine it");
  EXPECT_TRUE(bound_notes(nlohmann::json::object()).empty());  // a summary without parameters
}

TEST(DemoReport, TubeStateNamesTheColumnsInsteadOfARawRow) {
  const std::string header = "time,pressure,volume,inner_radius,stretch,axial_stretch,twist_deg";
  const std::string row = "1,0.01,4321.5,5.4803,1.09607811,0.926753678,0.0001";
  const auto state = tube_final_state(header, row);
  ASSERT_EQ(state.size(), 5u);
  EXPECT_EQ(state[0].first, "pressure [MPa]");
  EXPECT_EQ(state[0].second, "0.01");
  EXPECT_EQ(state[1].first, "axial stretch");
  EXPECT_EQ(state[1].second, "0.9268");  // 4 significant digits
  EXPECT_EQ(state[2].first, "inner-radius stretch");
  EXPECT_EQ(state[2].second, "1.096");
  const std::string line = join_state(state);
  EXPECT_EQ(line.find(','), line.find(", "));  // only the separators, no CSV commas
  EXPECT_EQ(line.find("inner_radius"), std::string::npos);
  // The twist of a symmetric double helix is round-off (1e-15 deg): shown as 0.
  EXPECT_EQ(tube_final_state("twist_deg", "2.2e-15").at(0).second, "0");
  // Columns the file does not have are left out.
  EXPECT_EQ(tube_final_state("time,pressure", "1,0.2").size(), 1u);
}
