// The jobs layer (softhom/jobs/jobs.hpp): a `softhom rve` scene is parsed once on its way to the
// solver (the job holds the parsed structures and run() takes only the job), and the memory sink
// receives exactly what the file sink writes: the same rows (response.csv holds round-trip digits, so
// equal doubles) and the same summary apart from timings and memory.
#include <gtest/gtest.h>

#include <fstream>

#include <nlohmann/json.hpp>

#include "app/cli_helpers.hpp"
#include "softhom/io/scene.hpp"
#include "softhom/jobs/jobs.hpp"

namespace jobs = softhom::jobs;
using softhom::test::fresh_dir;
using softhom::test::read_json;
using softhom::test::read_csv;

namespace {

// A 12² section cell, 3 steps to λ = 1.2: a second on one thread.
const char* kCell = R"(
[microstructure]
shape = "circle"
volume_fraction = 0.23
radius = 0.2
fiber_angle_deg = 45
grid = [12, 12]
[phases.matrix]
preset = "ecoflex"
[phases.fiber]
preset = "glass"
[load]
type = "uniaxial"
stretch = 1.2
steps = 3
[solver]
tolerance = 1e-6
[output]
fields = "none"
)";

jobs::LoadedScene cell_scene(const std::string& text = kCell) {
  jobs::LoadedScene s;
  s.name = "cell";
  s.table = softhom::io::parse_scene(text, "cell.toml");
  return s;
}

/// The summary without what differs from run to run (times, memory, dates) or by sink (checkpoints).
nlohmann::json comparable(nlohmann::json s) {
  for (const char* k : {"wall_time_s", "solve_time_s", "fft_planning_s", "peak_memory_bytes",
                        "peak_memory_bytes_per_voxel", "started_utc", "checkpoint", "steps"})
    s.erase(k);
  return s;
}

void expect_rows_equal(const jobs::MemorySink& memory, const std::filesystem::path& csv) {
  const softhom::test::Csv file = read_csv(csv);
  const softhom::io::CsvTable* table = memory.table("response");
  ASSERT_NE(table, nullptr);
  ASSERT_EQ(table->columns(), file.columns);
  ASSERT_EQ(table->rows(), file.rows.size());
  for (std::size_t i = 0; i < file.rows.size(); ++i)
    for (std::size_t j = 0; j < file.columns.size(); ++j)
      EXPECT_EQ(table->values()[i * file.columns.size() + j], file.rows[i][j]) << file.columns[j] << " row " << i;
}

}  // namespace

TEST(Jobs, RveSceneIsParsedOnceAndRunFromTheJob) {
  const std::size_t before = jobs::rve_scene_parses();
  jobs::RveJob job = jobs::parse_rve(cell_scene());
  EXPECT_EQ(jobs::rve_scene_parses(), before + 1);
  ASSERT_TRUE(std::holds_alternative<jobs::FftRveJob>(job.engine));
  EXPECT_EQ(std::get<jobs::FftRveJob>(job.engine).setup.image.n[0], 12);
  jobs::MemorySink memory;
  jobs::RunOptions quiet;
  quiet.quiet = true;
  EXPECT_TRUE(jobs::run_rve(job, memory, quiet));
  EXPECT_EQ(jobs::rve_scene_parses(), before + 1);  // the run parsed nothing
  ASSERT_NE(memory.table("response"), nullptr);
  EXPECT_EQ(memory.table("response")->rows(), 4u);  // t = 0 and 3 steps
}

TEST(Jobs, MemorySinkHoldsWhatTheFileSinkWrites) {
  const auto dir = fresh_dir("jobs-sinks");
  jobs::RunOptions quiet;
  quiet.quiet = true;
  jobs::RveJob to_files = jobs::parse_rve(cell_scene(), {dir});
  jobs::FileSink files(dir);
  ASSERT_TRUE(jobs::run_rve(to_files, files, quiet));
  jobs::RveJob to_memory = jobs::parse_rve(cell_scene());
  jobs::MemorySink memory;
  ASSERT_TRUE(jobs::run_rve(to_memory, memory, quiet));
  expect_rows_equal(memory, dir / "response.csv");
  const nlohmann::json from_memory = nlohmann::json::parse(memory.summary_text());
  EXPECT_EQ(comparable(from_memory), comparable(read_json(dir / "summary.json")));
  EXPECT_EQ(from_memory["checkpoint"]["writes"], 0);  // no directory, no checkpoint
  std::filesystem::remove_all(dir);
}

TEST(Jobs, PointIntoMemoryEqualsItsFile) {
  const auto dir = fresh_dir("jobs-point");
  jobs::RunOptions quiet;
  quiet.quiet = true;
  const jobs::PointJob job = jobs::parse_point(jobs::load_scene_or_default({}, "point_uniaxial_fiber"));
  jobs::FileSink files(dir);
  jobs::MemorySink memory;
  const auto a = jobs::run_point(job, files, quiet);
  const auto b = jobs::run_point(job, memory, quiet);
  ASSERT_TRUE(a.completed && b.completed);
  expect_rows_equal(memory, dir / "response.csv");
  EXPECT_EQ(comparable(nlohmann::json::parse(memory.summary_text())), comparable(read_json(dir / "summary.json")));
  std::filesystem::remove_all(dir);
}
