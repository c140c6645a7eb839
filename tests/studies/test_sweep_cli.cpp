// `softhom sweep` as a process: SIGKILL in the middle of a campaign, rerun, same store as an
// uninterrupted run (timings aside); exit codes.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>

#include "softhom/studies/campaign.hpp"
#include "studies/studies_test_helpers.hpp"

namespace fs = std::filesystem;
using namespace softhom::studies;
using softhom::studies::testing::fresh_dir;

namespace {

pid_t spawn(const std::vector<std::string>& args) {
  const pid_t pid = fork();
  if (pid == 0) {
    std::vector<char*> argv;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    if (!freopen("/dev/null", "w", stderr)) _exit(126);
    if (!freopen("/dev/null", "w", stdout)) _exit(126);
    execv(argv[0], argv.data());
    _exit(127);
  }
  return pid;
}

int wait_exit(pid_t pid) {
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status);
}

// Eight PDMS cells of 16² pixels, tension in 4 steps: each case is a fraction of a second, so a kill
// after the first stored case lands in the middle of the campaign.
const char* kCampaign = R"(
[base.solver]
tolerance = 1e-6
[loads.pull]
type = "uniaxial"
stretch = 1.3
steps = 4
[loads.push]
type = "uniaxial"
stretch = 0.85
steps = 3
[sweep]
matrix = ["pdms"]
angle = [30, 45, 60, 75]
volume_fraction = [0.23]
resolution = 16
load = ["pull", "push"]
)";

}  // namespace

TEST(SweepCli, KillAndRerunGivesTheUninterruptedStore) {
  const std::string exe = SOFTHOM_BINARY;
  if (!fs::exists(exe)) GTEST_SKIP() << "softhom not built: " << exe;
  const fs::path dir = fresh_dir("kill");
  const fs::path campaign = dir / "campaign.toml";
  std::ofstream(campaign) << kCampaign;
  const fs::path full = dir / "full", part = dir / "part";
  auto args = [&](const fs::path& out) {
    // One job, one thread: bitwise reproducible.
    return std::vector<std::string>{exe, "sweep", campaign.string(), "--out", out.string(), "--jobs", "1", "-j", "1"};
  };
  ASSERT_EQ(wait_exit(spawn(args(full))), 0);
  const auto reference = read_store(full / "campaign.h5");
  ASSERT_EQ(reference.size(), 8u);

  // Kill -9 as soon as the first case is stored.
  const pid_t pid = spawn(args(part));
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (!fs::exists(part / "campaign.h5") && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  kill(pid, SIGKILL);
  EXPECT_EQ(wait_exit(pid), -SIGKILL);
  const auto partial = read_store(part / "campaign.h5");  // readable: written by rename
  EXPECT_GE(partial.size(), 1u);
  EXPECT_LT(partial.size(), 8u) << "the kill came too late to test anything";

  // A kill during a write leaves the writer's temporaries; the next writer removes them.
  std::ofstream(part / (".campaign.h5.tmp-" + std::to_string(pid))) << "partial";
  std::ofstream(part / (".cases.csv.tmp-" + std::to_string(pid))) << "partial";
  ASSERT_EQ(wait_exit(spawn(args(part))), 0);
  for (const auto& e : fs::directory_iterator(part))
    EXPECT_EQ(e.path().filename().string().find(".tmp-"), std::string::npos) << e.path();
  const auto resumed = read_store(part / "campaign.h5");
  ASSERT_EQ(resumed.size(), reference.size());
  for (const auto& [id, a] : reference) {
    ASSERT_TRUE(resumed.count(id)) << id;
    const CaseRecord& b = resumed.at(id);
    EXPECT_EQ(a.status, b.status) << id;
    EXPECT_EQ(a.scene_hash, b.scene_hash) << id;
    EXPECT_EQ(a.data, b.data) << id;  // exact: same operations in the same order
  }
  // cases.csv of the resumed run equals the uninterrupted one byte for byte (no timings in it).
  auto slurp = [](const fs::path& p) {
    std::ifstream in(p);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  EXPECT_EQ(slurp(full / "cases.csv"), slurp(part / "cases.csv"));

  // A third run has nothing to do and exits 0; a missing campaign file is an input error (exit 2).
  ASSERT_EQ(wait_exit(spawn(args(part))), 0);
  EXPECT_NE(wait_exit(spawn({exe, "sweep", (dir / "missing.toml").string(), "--out", (dir / "x").string()})), 0);
  // No campaign at all: InputError → exit code 2.
  EXPECT_EQ(wait_exit(spawn({exe, "sweep", "--out", (dir / "x").string()})), 2);
  // A bad axis value: input error before anything runs, nothing written.
  std::ofstream(dir / "bad.toml") << "[sweep]\nmatrix = [\"pdms\"]\nload = [\"pull\"]\n";
  EXPECT_EQ(wait_exit(spawn({exe, "sweep", (dir / "bad.toml").string(), "--out", (dir / "bad").string()})), 2);
  EXPECT_FALSE(fs::exists(dir / "bad" / "campaign.h5"));
  fs::remove_all(dir);
}

TEST(SweepCli, SigtermStoresFinishedCasesAndTheResumeCompletesTheCampaign) {
  const std::string exe = SOFTHOM_BINARY;
  if (!fs::exists(exe)) GTEST_SKIP() << "softhom not built: " << exe;
  const fs::path dir = fresh_dir("term");
  const fs::path campaign = dir / "campaign.toml";
  std::ofstream(campaign) << kCampaign;
  const fs::path full = dir / "full", part = dir / "part";
  auto args = [&](const fs::path& out) {
    return std::vector<std::string>{exe, "sweep", campaign.string(), "--out", out.string(), "--jobs", "1", "-j", "1"};
  };
  ASSERT_EQ(wait_exit(spawn(args(full))), 0);
  const auto reference = read_store(full / "campaign.h5");

  const pid_t pid = spawn(args(part));
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (!fs::exists(part / "campaign.h5") && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  kill(pid, SIGTERM);
  const int code = wait_exit(pid);
  if (code == -SIGTERM) GTEST_SKIP() << "this softhom binary installs no SIGTERM handler";
  EXPECT_EQ(code, 128 + SIGTERM);  // interrupted by signal N: 128 + N, as shells report it
  std::ifstream in(part / "summary.json");
  const std::string summary(std::istreambuf_iterator<char>(in), {});
  EXPECT_NE(summary.find("\"interrupted\": true"), std::string::npos) << summary;
  const auto partial = read_store(part / "campaign.h5");
  EXPECT_GE(partial.size(), 1u);
  for (const auto& [id, r] : partial) EXPECT_EQ(r.status, "ok") << id;  // the abandoned case is not a failure
  for (const auto& e : fs::directory_iterator(part))
    EXPECT_EQ(e.path().filename().string().find(".tmp-"), std::string::npos) << e.path();

  ASSERT_EQ(wait_exit(spawn(args(part))), 0);
  const auto resumed = read_store(part / "campaign.h5");
  ASSERT_EQ(resumed.size(), reference.size());
  for (const auto& [id, a] : reference) {
    ASSERT_TRUE(resumed.count(id)) << id;
    EXPECT_EQ(a.data, resumed.at(id).data) << id;  // exact: same operations in the same order
  }
  fs::remove_all(dir);
}
