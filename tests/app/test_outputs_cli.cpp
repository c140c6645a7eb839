// `softhom` under signals, write faults and bad command lines: converged rows on disk, summary.json
// status, documented exit codes (run_control.hpp), no temporaries, plain progress lines in files.
#include <gtest/gtest.h>

#include <chrono>
#include <csignal>
#include <fstream>
#include <thread>

#include <nlohmann/json.hpp>
#include <fcntl.h>
#include <sys/mount.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "app/cli_helpers.hpp"

using namespace softhom::test;
namespace fs = std::filesystem;

namespace {

// Runs the binary with extra environment assignments ("NAME=value ...").
CommandResult run_env(const std::string& env, const std::string& args) { return run_softhom(args, env); }

// Names in `dir` that look like temporaries (".NAME.tmp-PID").
std::vector<std::string> temporaries(const fs::path& dir) {
  std::vector<std::string> out;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string n = it->path().filename().string();
    if (!n.empty() && n[0] == '.' && n.find(".tmp-") != std::string::npos) out.push_back(n);
  }
  return out;
}

// An FFT RVE scene long enough to be interrupted (homogeneous 8 x 8 cell, many small steps).
std::string long_rve_scene(int steps) {
  return write_temp_scene("outputs_long_rve_" + std::to_string(::getpid()),
                          "[microstructure]\nvolume_fraction = 0.0\ngrid = [8, 8]\n"
                          "[phases.matrix]\npreset = \"ecoflex\"\n"
                          "[load]\ntype = \"uniaxial\"\nstretch = 3.0\nduration = 1.0\nsteps = " +
                              std::to_string(steps) + "\n[solver]\ndiscretization = \"rotated\"\ntolerance = 1e-6\n"
                              "[output]\nfields = \"last\"\n");
}

// Every line of a CSV has as many fields as its header: no torn row.
void expect_whole_rows(const fs::path& csv) {
  std::ifstream in(csv);
  std::string header;
  ASSERT_TRUE(std::getline(in, header)) << csv;
  const auto fields = std::count(header.begin(), header.end(), ',') + 1;
  std::string line;
  for (int n = 1; std::getline(in, line); ++n)
    EXPECT_EQ(std::count(line.begin(), line.end(), ',') + 1, fields) << "line " << n + 1 << " of " << csv;
}

}  // namespace

TEST(OutputsCli, RveInterruptKeepsConvergedRowsAndSaysInterrupted) {
  const auto full = fresh_dir("outputs_rve_full");
  const auto cut = fresh_dir("outputs_rve_cut");
  ASSERT_EQ(run_softhom("rve -q -o " + full.string()).exit_code, 0);
  // A real SIGTERM raised in the child after 5 converged steps (run_control.hpp test hook).
  const CommandResult r = run_env("SOFTHOM_TEST_SIGTERM_AFTER_STEPS=5", "rve -q -o " + cut.string());
  EXPECT_EQ(r.exit_code, 128 + SIGTERM) << r.output;  // documented: 128 + signal
  EXPECT_NE(r.output.find("interrupted by SIGTERM"), std::string::npos) << r.output;
  const Csv a = read_csv(full / "response.csv"), b = read_csv(cut / "response.csv");
  ASSERT_EQ(b.rows.size(), 6u);  // t = 0 and the five converged steps
  for (std::size_t i = 0; i < b.rows.size(); ++i)
    // Same binary, same single thread: the converged rows are the uninterrupted run's, to round-off.
    EXPECT_NEAR(b.at(i, "P11"), a.at(i, "P11"), 1e-12 * (1.0 + std::abs(a.at(i, "P11"))));
  const auto s = read_json(cut / "summary.json");
  EXPECT_EQ(s["status"], "interrupted");
  EXPECT_EQ(s["signal"], "SIGTERM");
  EXPECT_EQ(s["completed"], false);
  EXPECT_EQ(s["steps"].size(), 6u);
  EXPECT_EQ(read_json(full / "summary.json")["status"], "completed");
  EXPECT_TRUE(temporaries(cut).empty());
  fs::remove_all(full);
  fs::remove_all(cut);
}

TEST(OutputsCli, PointInterruptKeepsConvergedRows) {
  const auto out = fresh_dir("outputs_point_cut");
  const CommandResult r = run_env("SOFTHOM_TEST_SIGTERM_AFTER_STEPS=10", "point -q -o " + out.string());
  EXPECT_EQ(r.exit_code, 128 + SIGTERM) << r.output;
  EXPECT_EQ(read_csv(out / "response.csv").rows.size(), 11u);  // t = 0 + ten steps
  const auto s = read_json(out / "summary.json");
  EXPECT_EQ(s["status"], "interrupted");
  EXPECT_EQ(s["signal"], "SIGTERM");
  EXPECT_EQ(s["columns"]["P11"]["unit"], "MPa");
  EXPECT_EQ(s["columns"]["t"]["unit"], "s");
  EXPECT_TRUE(temporaries(out).empty());
  fs::remove_all(out);
}

TEST(OutputsCli, SigtermFromOutsideAndKillNineKeepRows) {
  const std::string scene = long_rve_scene(4000);
  for (const int sig : {SIGTERM, SIGKILL}) {
    const auto out = fresh_dir("outputs_rve_signal_" + std::to_string(sig));
    const pid_t pid = ::fork();
    if (pid == 0) {
      const int devnull = ::open("/dev/null", O_WRONLY);
      ::dup2(devnull, 1);
      ::dup2(devnull, 2);
      ::execl(SOFTHOM_BINARY, SOFTHOM_BINARY, "rve", scene.c_str(), "-q", "-o", out.c_str(), (char*)nullptr);
      ::_exit(127);
    }
    // Wait until a few rows are on disk (the run takes far longer than that), then signal.
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
    std::size_t rows = 0;
    while (std::chrono::steady_clock::now() < deadline) {
      if (fs::exists(out / "response.csv")) rows = read_csv(out / "response.csv").rows.size();
      if (rows >= 4) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    ASSERT_GE(rows, 4u) << "no rows appeared on disk while the run went on";
    ::kill(pid, sig);
    int status = 0;
    ::waitpid(pid, &status, 0);
    if (sig == SIGTERM) {
      ASSERT_TRUE(WIFEXITED(status));
      EXPECT_EQ(WEXITSTATUS(status), 128 + SIGTERM);
      EXPECT_EQ(read_json(out / "summary.json")["status"], "interrupted");
      EXPECT_TRUE(temporaries(out).empty());
    } else {
      EXPECT_TRUE(WIFSIGNALED(status));
    }
    expect_whole_rows(out / "response.csv");
    const Csv csv = read_csv(out / "response.csv");
    EXPECT_GE(csv.rows.size(), rows);  // rows seen before the signal are still there
    for (std::size_t i = 1; i < csv.rows.size(); ++i) EXPECT_GT(csv.at(i, "t"), csv.at(i - 1, "t"));
    if (sig == SIGKILL) {
      // A temporary the killed process may have left (made certain here) is removed by the next start.
      std::ofstream(out / (".fields.h5.tmp-" + std::to_string(pid))) << "partial";
      const CommandResult again = run_softhom("point -q -o " + out.string());
      EXPECT_EQ(again.exit_code, 0) << again.output;
      EXPECT_TRUE(temporaries(out).empty());
    }
    fs::remove_all(out);
  }
  fs::remove(scene);
}

TEST(OutputsCli, InjectedWriteFailureNamesFileExitsOneKeepsPreviousFile) {
  const auto out = fresh_dir("outputs_inject");
  ASSERT_EQ(run_softhom("point -q -o " + out.string()).exit_code, 0);
  const Csv before = read_csv(out / "response.csv");
  const CommandResult r = run_env("SOFTHOM_INJECT_WRITE_FAILURE=response.csv", "point -q -o " + out.string());
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find((out / "response.csv").string()), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("No space left on device"), std::string::npos) << r.output;
  EXPECT_EQ(read_csv(out / "response.csv").rows.size(), before.rows.size());  // previous complete file intact
  EXPECT_TRUE(temporaries(out).empty());
  // The HDF5 path: a failing fields.h5 ends cleanly (exit 1, not a crash in HDF5's exit handler).
  const auto rve_out = fresh_dir("outputs_inject_rve");  // a directory of its own (no point results in it)
  const CommandResult f = run_env("SOFTHOM_INJECT_WRITE_FAILURE=fields.h5", "rve -q -o " + rve_out.string());
  EXPECT_EQ(f.exit_code, 1) << f.output;
  EXPECT_NE(f.output.find((rve_out / "fields.h5").string()), std::string::npos) << f.output;
  EXPECT_TRUE(temporaries(rve_out).empty());
  fs::remove_all(out);
  fs::remove_all(rve_out);
}

TEST(OutputsCli, FullAndReadOnlyFileSystems) {
  if (::geteuid() != 0) GTEST_SKIP() << "needs root to mount a tmpfs";
  const auto mnt = fresh_dir("outputs_tmpfs");
  fs::create_directories(mnt);
  if (::mount("tmpfs", mnt.c_str(), "tmpfs", 0, "size=1m") != 0) GTEST_SKIP() << "cannot mount a tmpfs here";
  // Fields of every step of a 32 x 32 x 8 cell do not fit in 1 MB.
  const std::string scene = write_temp_scene(
      "outputs_full_" + std::to_string(::getpid()),
      "[microstructure]\nvolume_fraction = 0.2\nradius = 0.2\nfiber_angle_deg = 30\ngrid = [32, 32, 8]\n"
      "[phases.matrix]\npreset = \"ecoflex\"\n[phases.fiber]\npreset = \"glass\"\n"
      "[load]\ntype = \"uniaxial\"\nstretch = 1.2\nduration = 1.0\nsteps = 3\n[output]\nfields = \"all\"\n");
  const CommandResult r = run_softhom("rve " + scene + " -q -o " + (mnt / "run").string());
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("fields.h5"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("No space left on device"), std::string::npos) << r.output;
  EXPECT_TRUE(temporaries(mnt / "run").empty());
  ::umount(mnt.c_str());
  fs::remove(scene);

  if (::mount("tmpfs", mnt.c_str(), "tmpfs", MS_RDONLY, "size=1m") != 0) GTEST_SKIP() << "cannot mount read-only";
  const CommandResult ro = run_softhom("point -q -o " + mnt.string());
  EXPECT_EQ(ro.exit_code, 1) << ro.output;
  EXPECT_NE(ro.output.find("response.csv"), std::string::npos) << ro.output;
  EXPECT_NE(ro.output.find("Read-only file system"), std::string::npos) << ro.output;
  ::umount(mnt.c_str());
  fs::remove_all(mnt);
}

TEST(OutputsCli, BadCommandLinesExitTwoNamingTheOption) {
  struct Case {
    std::string args, must_name;
  };
  const auto out = fresh_dir("outputs_cli").string();
  const std::vector<Case> cases{
      {"point --threads -3 -o " + out, "--threads"},
      {"point --threads 1000000000 -o " + out, "--threads"},
      {"point --threads abc -o " + out, "--threads"},
      {"sweep --jobs 100000 -o " + out, "--jobs"},
      {"point --no-such-option", "--no-such-option"},
      {"point " + fs::temp_directory_path().string() + " -o " + out, "directory"},
      {"point /dev/zero -o " + out, "device"},
  };
  for (const auto& c : cases) {
    const CommandResult r = run_softhom(c.args);
    EXPECT_EQ(r.exit_code, 2) << c.args << "\n" << r.output;
    EXPECT_NE(r.output.find(c.must_name), std::string::npos) << c.args << "\n" << r.output;
    EXPECT_EQ(r.output.find("17976931348623157"), std::string::npos) << r.output;  // no 309-digit bound
  }
  // A FIFO would block a reader forever: refused before it is opened (timeout guards the test).
  const fs::path fifo = fs::temp_directory_path() / ("softhom-outputs-fifo-" + std::to_string(::getpid()));
  fs::remove(fifo);
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const CommandResult f = run_softhom("point " + fifo.string() + " -o " + out);
  EXPECT_EQ(f.exit_code, 2) << f.output;
  EXPECT_NE(f.output.find("FIFO"), std::string::npos) << f.output;
  fs::remove(fifo);
  // An enormous file is no scene.
  const fs::path huge = fs::temp_directory_path() / ("softhom-outputs-huge-" + std::to_string(::getpid()) + ".toml");
  { std::ofstream(huge) << ""; }
  fs::resize_file(huge, 64u << 20);
  const CommandResult h = run_softhom("point " + huge.string() + " -o " + out);
  EXPECT_EQ(h.exit_code, 2) << h.output;
  EXPECT_NE(h.output.find("bytes"), std::string::npos) << h.output;
  fs::remove(huge);
  fs::remove_all(out);
}

TEST(OutputsCli, ProgressInAFileIsPlainLines) {
  const auto out = fresh_dir("outputs_progress");
  const CommandResult r = run_softhom("rve -o " + out.string());  // stderr redirected to a file
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(r.output.find('\r'), std::string::npos);
  EXPECT_EQ(r.output.find('\033'), std::string::npos);
  // One line per converged step (t = 0 and 20 steps), each a progress line, no CSV rows.
  std::size_t lines = 0;
  std::istringstream in(r.output);
  for (std::string line; std::getline(in, line);)
    if (line.rfind("[rve rve_homogeneous] t = ", 0) == 0) ++lines;
  EXPECT_EQ(lines, 21u) << r.output;
  EXPECT_EQ(r.output.find("0,0,0"), std::string::npos) << r.output;
  fs::remove_all(out);
}

TEST(OutputsCli, MacroSpeaksTheSharedVocabularyAndStopsOnSignal) {
  const auto out = fresh_dir("outputs_macro");
  const CommandResult r =
      run_env("SOFTHOM_TEST_SIGTERM_AFTER_STEPS=3", "macro " + scene("macro_plate_uniaxial") + " -q -o " + out.string());
  EXPECT_EQ(r.exit_code, 128 + SIGTERM) << r.output;
  const Csv csv = read_csv(out / "response.csv");
  ASSERT_FALSE(csv.columns.empty());
  EXPECT_EQ(csv.columns.front(), "t");  // not "time": one vocabulary across subcommands
  EXPECT_EQ(csv.rows.size(), 4u);       // undeformed state + three converged output times
  const auto s = read_json(out / "summary.json");
  EXPECT_EQ(s["status"], "interrupted");
  for (const auto& c : csv.columns) EXPECT_FALSE(s["columns"][c]["unit"].get<std::string>().empty()) << c;
  EXPECT_TRUE(temporaries(out).empty());
  fs::remove_all(out);
}

TEST(OutputsCli, EveryRveAndPointColumnHasAUnit) {
  for (const std::string command : {"point", "rve"}) {
    const auto out = fresh_dir("outputs_units_" + command);
    ASSERT_EQ(run_softhom(command + " -q -o " + out.string()).exit_code, 0);
    const Csv csv = read_csv(out / "response.csv");
    const auto s = read_json(out / "summary.json");
    EXPECT_EQ(s["status"], "completed");
    EXPECT_EQ(s["columns"].size(), csv.columns.size());
    for (const auto& c : csv.columns) EXPECT_FALSE(s["columns"][c]["unit"].get<std::string>().empty()) << command << " " << c;
    fs::remove_all(out);
  }
}

TEST(OutputsCli, AnOutDirectoryOfAnotherSubcommandIsRefusedAndKept) {
  // A point run into a macro run's --out overwrote response.csv and summary.json and left fields.h5
  // beside them; now it is refused naming --out (exit 2), and the macro run's files stay as they were.
  const auto out = fresh_dir("outputs_other_subcommand");
  fs::create_directories(out);
  {
    std::ofstream summary(out / "summary.json");
    summary << R"({"command": "macro", "status": "completed"})" << "\n";
  }
  const auto r = run_softhom("point " + scene("point_uniaxial_ecoflex") + " --out " + out.string() + " -q");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--out"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("softhom macro"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(out / "response.csv"));
  EXPECT_EQ(read_json(out / "summary.json")["command"], "macro");
  // The same subcommand again replaces its own results.
  const auto again = fresh_dir("outputs_same_subcommand");
  ASSERT_EQ(run_softhom("point " + scene("point_uniaxial_ecoflex") + " --out " + again.string() + " -q").exit_code, 0);
  EXPECT_EQ(run_softhom("point " + scene("point_uniaxial_ecoflex") + " --out " + again.string() + " -q").exit_code, 0);
}
