// summary.json: metadata fields, scene echo, pretty atomic write, NaN refused.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <regex>
#include <sstream>
#include <thread>

#include <unistd.h>

#include "io/io_test_helpers.hpp"
#include "softhom/io/summary.hpp"

using namespace softhom;
using softhom::test::listing;
using softhom::test::slurp;
namespace fs = std::filesystem;

namespace {

}  // namespace

TEST(Summary, BaseFieldsAndSceneEcho) {
  const auto scene = toml::parse(
      "[load]\ntype = \"uniaxial\"\nstretch = [[0, 1.0], [20, 1.5]]\nsteps = 7\n"
      "[material]\npreset = \"ecoflex\"\nlimit = inf\n");
  const auto j = io::summary_base("point", "scenes/a.toml", scene);
  EXPECT_TRUE(std::regex_match(j["softhom_version"].get<std::string>(), std::regex(R"(\d+\.\d+\.\d+.*)")));
  EXPECT_EQ(j["softhom_version"], io::softhom_version());
  EXPECT_EQ(j["command"], "point");
  EXPECT_EQ(j["scene_file"], "scenes/a.toml");
  EXPECT_EQ(j["scene"]["load"]["type"], "uniaxial");
  EXPECT_EQ(j["scene"]["load"]["steps"], 7);
  EXPECT_EQ(j["scene"]["load"]["stretch"][1][1], 1.5);
  EXPECT_TRUE(j["scene"]["material"]["limit"].is_string());  // TOML inf has no JSON number: quoted
  EXPECT_GE(j["threads"].get<int>(), 1);
  EXPECT_TRUE(std::regex_match(j["started_utc"].get<std::string>(),
                               std::regex(R"(\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ)")));
  EXPECT_EQ(io::summary_base("point", "", toml::table{})["scene_file"], "");  // embedded scene
}

// A summary is written when the run ends: its start must be the time mark_run_started() recorded, not
// the time of writing (they were the same, so a 3.6 h run reported its end as its start).
TEST(Summary, StartIsTheMarkedStartNotTheTimeOfWriting) {
  io::mark_run_started();
  const std::string start = io::run_started_utc();
  std::this_thread::sleep_for(std::chrono::milliseconds(1100));  // the timestamps have one-second resolution
  EXPECT_EQ(io::summary_base("point", "", toml::table{})["started_utc"], start);
  io::mark_run_started();
  EXPECT_GT(io::run_started_utc(), start);  // ISO 8601 strings order as the times
}

TEST(Summary, WritesPrettyJsonAtomically) {
  test::TempDir tmp{"summary", false};
  auto j = io::summary_base("point", "", toml::parse("x = 1\n"));
  j["results"] = {{"peak_stress", 0.1}, {"stretch", {1.0, 1.25}}};
  io::write_summary(tmp.path / "out", j);  // creates the directory
  const std::string text = slurp(tmp.path / "out" / "summary.json");
  EXPECT_EQ(nlohmann::json::parse(text), j);
  EXPECT_NE(text.find("\n  \"command\": \"point\""), std::string::npos) << text;  // 2-space indent
  EXPECT_EQ(std::distance(fs::directory_iterator(tmp.path / "out"), fs::directory_iterator()), 1);
}

TEST(Summary, RefusesNonFiniteNumbersNamingWhere) {
  test::TempDir tmp{"summary", false};
  nlohmann::json j = {{"command", "point"}, {"results", {{"stress", {1.0, std::nan("")}}}}};
  try {
    io::write_summary(tmp.path, j);
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("/results/stress/1"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(tmp.path / "summary.json"));
  j["results"]["stress"][1] = HUGE_VAL;
  EXPECT_THROW(io::write_summary(tmp.path, j), std::invalid_argument);
  j["results"]["stress"][1] = 2.0;
  EXPECT_NO_THROW(io::write_summary(tmp.path, j));
}
