// The campaign store as the one writer of a directory: concurrent writers refused, campaigns merged,
// stale temporaries removed, bad case ids refused, write failures that leave the previous files, the
// index table and its dtypes, the first layout still read, interrupt and resume. Tiny cells (8²,
// 1-2 load steps) keep the file at a few seconds.
#include <gtest/gtest.h>
#include <hdf5.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>

#include "softhom/io/scene.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/materials/interrupt.hpp"
#include "softhom/studies/campaign.hpp"
#include "studies/studies_test_helpers.hpp"

namespace fs = std::filesystem;
using namespace softhom;
using namespace softhom::studies;
using softhom::studies::testing::fresh_dir;
using softhom::studies::testing::expand;

namespace {

// Campaign A: the matrix alone and two composite angles under a two-step tension; B: another load.
const char* kA = R"(
description = "A"
[base.solver]
tolerance = 1e-6
[loads.pull]
type = "uniaxial"
stretch = 1.2
steps = 2
[sweep]
matrix = ["pdms"]
angle = [30, 60]
volume_fraction = [0.0, 0.23]
resolution = 8
load = ["pull"]
)";
const char* kB = R"(
description = "B"
[base.solver]
tolerance = 1e-6
[loads.push]
type = "uniaxial"
stretch = 0.9
steps = 1
[sweep]
matrix = ["pdms"]
angle = [45]
volume_fraction = [0.23]
resolution = 8
load = ["push"]
)";

SweepOptions quiet() {
  SweepOptions o;
  o.jobs = 1;
  o.threads = 1;  // one OpenMP thread: bitwise reproducible sums
  o.quiet = true;
  return o;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

std::vector<std::string> temporaries(const fs::path& dir) {
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().filename().string().find(".tmp-") != std::string::npos) out.push_back(e.path().filename().string());
  return out;
}

/// Equality up to timings: same chain, same thread count → the same floating-point operations.
void expect_same_records(const std::map<std::string, CaseRecord>& a, const std::map<std::string, CaseRecord>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (const auto& [id, ra] : a) {
    ASSERT_TRUE(b.count(id)) << id;
    const CaseRecord& rb = b.at(id);
    EXPECT_EQ(ra.status, rb.status) << id;
    EXPECT_EQ(ra.scene_hash, rb.scene_hash) << id;
    EXPECT_EQ(ra.columns, rb.columns) << id;
    EXPECT_EQ(ra.data, rb.data) << id;  // exact
    for (const auto& [k, v] : ra.stats)
      if (!is_timing_stat(k)) {
        EXPECT_EQ(v, rb.stats.at(k)) << id << " " << k;
      }
  }
}

pid_t dead_pid() {
  const pid_t pid = fork();
  if (pid == 0) _exit(0);
  int status = 0;
  waitpid(pid, &status, 0);
  return pid;  // reaped: no process has this pid until the kernel wraps around
}

}  // namespace

TEST(CampaignStore, CaseIdsThatCannotBeGroupNames) {
  EXPECT_EQ(case_id_problem("pdms-circle-a30"), "");
  EXPECT_EQ(case_id_problem("grüne Faser 1"), "");  // UTF-8 and spaces are fine
  EXPECT_NE(case_id_problem(std::string("a\0b", 3)), "");
  EXPECT_NE(case_id_problem("a\tb"), "");
  EXPECT_NE(case_id_problem("a\x7f"), "");
  EXPECT_NE(case_id_problem("a/b"), "");
  EXPECT_NE(case_id_problem(""), "");
  EXPECT_NE(case_id_problem(".."), "");
  EXPECT_EQ(escape_control_characters(std::string("a\0b\n", 4)), "a\\x00b\\x0a");
}

TEST(CampaignStore, ControlCharacterNameIsRefusedBeforeAnythingIsWrittenAndRerunsWork) {
  const fs::path dir = fresh_dir("nul");
  Campaign c = expand(kB);
  c.cases[0].id = std::string("bad\0name", 8);  // what a TOML "\u0000" escape gives
  try {
    run_campaign(c, dir / "out", quiet());
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "case id");
    EXPECT_NE(std::string(e.what()).find("bad\\x00name"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("control character"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir / "out"));  // refused before the directory is touched
  c.cases[0].id = "a/b";
  EXPECT_THROW(run_campaign(c, dir / "out", quiet()), InputError);
  // The same campaign with its own id runs, twice.
  const Campaign good = expand(kB);
  EXPECT_EQ(run_campaign(good, dir / "out", quiet()).finished, 1);
  EXPECT_EQ(run_campaign(good, dir / "out", quiet()).skipped, 1);
  fs::remove_all(dir);
}

TEST(CampaignStore, SecondWriterIsRefusedWhileTheFirstHoldsTheLock) {
  const fs::path dir = fresh_dir("lock");
  const Campaign a = expand(kA);
  run_campaign(a, dir, quiet());
  const std::string store_before = slurp(dir / "campaign.h5"), csv_before = slurp(dir / "cases.csv");
  {
    // flock belongs to the open file: a second open (this process or another) is refused.
    const StoreLock holder(dir);
    const std::string lock_text = slurp(dir / "campaign.lock");
    EXPECT_NE(lock_text.find("pid=" + std::to_string(::getpid()) + "\n"), std::string::npos) << lock_text;
    EXPECT_NE(lock_text.find("host="), std::string::npos) << lock_text;
    try {
      run_campaign(expand(kB), dir, quiet());
      ADD_FAILURE() << "second writer not refused";
    } catch (const StoreBusy& e) {
      const std::string m = e.what();
      EXPECT_NE(m.find(dir.string()), std::string::npos) << m;
      EXPECT_NE(m.find("pid " + std::to_string(::getpid())), std::string::npos) << m;
      EXPECT_NE(m.find(" on host "), std::string::npos) << m;
    }
    // Nothing changed.
    EXPECT_EQ(slurp(dir / "campaign.h5"), store_before);
    EXPECT_EQ(slurp(dir / "cases.csv"), csv_before);

    // The binary: exit code 1 at once, the message names the directory and the holder.
    const std::string exe = SOFTHOM_BINARY;
    if (fs::exists(exe)) {
      const fs::path campaign = dir / "b.toml", err = dir / "stderr.txt";
      std::ofstream(campaign) << kB;
      const std::string cmd = exe + " sweep " + campaign.string() + " --out " + dir.string() + " 2> " + err.string();
      const int status = std::system(cmd.c_str());
      EXPECT_EQ(WEXITSTATUS(status), 1);
      const std::string message = slurp(err);
      EXPECT_NE(message.find("in use by another softhom sweep"), std::string::npos) << message;
      EXPECT_NE(message.find("pid " + std::to_string(::getpid())), std::string::npos) << message;
      EXPECT_EQ(slurp(dir / "campaign.h5"), store_before);
    }
  }
  // Released: the next writer runs and keeps A's cases.
  EXPECT_EQ(run_campaign(expand(kB), dir, quiet()).finished, 1);
  EXPECT_EQ(read_store(dir / "campaign.h5").size(), 4u);
  fs::remove_all(dir);
}

TEST(CampaignStore, TwoCampaignsInSequenceMerge) {
  const fs::path dir = fresh_dir("merge"), alone = fresh_dir("merge_alone");
  const Campaign a = expand(kA), b = expand(kB);
  run_campaign(a, alone, quiet());
  const auto a_alone = read_store(alone / "campaign.h5");
  ASSERT_EQ(a_alone.size(), 3u);

  run_campaign(a, dir, quiet());
  const SweepReport rb = run_campaign(b, dir, quiet());
  EXPECT_EQ(rb.total, 1);
  EXPECT_EQ(rb.finished, 1);
  auto merged = read_store(dir / "campaign.h5");
  ASSERT_EQ(merged.size(), 4u);
  const std::string b_id = b.cases[0].id;
  ASSERT_TRUE(merged.count(b_id));
  merged.erase(b_id);
  expect_same_records(a_alone, merged);  // A's cases untouched by B's run
  // cases.csv: B's case first (the campaign just run), then A's by id; every case present.
  std::ifstream in(dir / "cases.csv");
  std::string line;
  std::getline(in, line);
  std::vector<std::string> order;
  while (std::getline(in, line)) {
    const std::string id = line.substr(0, line.find(','));
    if (order.empty() || order.back() != id) order.push_back(id);
  }
  ASSERT_EQ(order.size(), 4u);
  EXPECT_EQ(order[0], b_id);
  EXPECT_TRUE(std::is_sorted(order.begin() + 1, order.end()));
  fs::remove_all(dir);
  fs::remove_all(alone);
}

TEST(CampaignStore, StoreChangedBehindTheWriterIsMergedNotReplaced) {
  const fs::path dir = fresh_dir("behind");
  const Campaign a = expand(kA);
  // A writer that ignored the lock adds a case while A runs (after A's first stored case).
  CaseRecord foreign;
  foreign.id = "foreign";
  foreign.parameters = {{"matrix", std::string("x")}};
  foreign.status = "ok";
  foreign.columns = {"t", "P11"};
  foreign.data = {0.0, 0.0, 1.0, 2.5};
  SweepOptions o = quiet();
  bool added = false;
  o.on_case_stored = [&](const CaseRecord&) {
    if (added) return;
    auto records = read_store(dir / "campaign.h5");
    records["foreign"] = foreign;
    write_store(dir / "campaign.h5", records, "another");
    added = true;
  };
  run_campaign(a, dir, o);
  const auto store = read_store(dir / "campaign.h5");
  ASSERT_EQ(store.size(), 4u);
  ASSERT_TRUE(store.count("foreign"));
  EXPECT_EQ(store.at("foreign").data, foreign.data);
  for (const auto& c : a.cases) EXPECT_EQ(store.at(c.id).status, "ok") << c.id;
  fs::remove_all(dir);
}

TEST(CampaignStore, StaleTemporariesOfDeadWritersAreRemoved) {
  const fs::path dir = fresh_dir("stale");
  const pid_t dead = dead_pid();
  const std::string d = std::to_string(dead);
  for (const char* name : {".campaign.h5.tmp-", ".cases.csv.tmp-", ".summary.json.tmp-"}) std::ofstream(dir / (name + d)) << "x";
  std::ofstream(dir / ".cases.csv.tmp-1") << "x";  // pid 1 is alive: another writer's, kept
  std::ofstream(dir / ("notes.tmp-" + d)) << "x";  // not one of our temporaries' names
  const SweepReport r = run_campaign(expand(kB), dir, quiet());
  EXPECT_EQ(r.removed_temporaries.size(), 3u);
  std::vector<std::string> left = temporaries(dir);
  std::sort(left.begin(), left.end());
  EXPECT_EQ(left, (std::vector<std::string>{".cases.csv.tmp-1", "notes.tmp-" + d}));

  // The last holder was another host: its pids cannot be checked here, nothing is removed.
  std::ofstream(dir / "campaign.lock") << "pid=" << d << "\nhost=some-other-host.invalid\n";
  std::ofstream(dir / (".campaign.h5.tmp-" + d)) << "x";
  EXPECT_TRUE(run_campaign(expand(kB), dir, quiet()).removed_temporaries.empty());
  EXPECT_TRUE(fs::exists(dir / (".campaign.h5.tmp-" + d)));
  fs::remove_all(dir);
}

TEST(CampaignStore, WriteFailureKeepsThePreviousFilesAndNoTemporary) {
  const fs::path dir = fresh_dir("fault");
  run_campaign(expand(kB), dir, quiet());
  const std::string store_before = slurp(dir / "campaign.h5"), csv_before = slurp(dir / "cases.csv");
  fs::path seen;
  set_store_write_fault_for_testing([&](const fs::path& tmp) {
    seen = tmp;
    EXPECT_TRUE(fs::exists(tmp));  // the fault comes while the temporary is half written
    throw std::runtime_error("No space left on device (simulated)");
  });
  try {
    run_campaign(expand(kA), dir, quiet());
    ADD_FAILURE() << "no error";
  } catch (const InputError&) {
    ADD_FAILURE() << "a write failure is not an input error (exit code 1, not 2)";
  } catch (const std::runtime_error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find((dir / "campaign.h5").string()), std::string::npos) << m;
    EXPECT_NE(m.find("No space left on device (simulated)"), std::string::npos) << m;
    EXPECT_NE(m.find("previous store is unchanged"), std::string::npos) << m;
  }
  set_store_write_fault_for_testing({});
  EXPECT_EQ(seen.filename().string(), ".campaign.h5.tmp-" + std::to_string(::getpid()));
  EXPECT_TRUE(temporaries(dir).empty());
  EXPECT_EQ(slurp(dir / "campaign.h5"), store_before);
  EXPECT_EQ(slurp(dir / "cases.csv"), csv_before);
  EXPECT_FALSE(stop_requested());  // the stop used to end the engines early is withdrawn
  // The lock was released and a rerun completes the campaign.
  const SweepReport r = run_campaign(expand(kA), dir, quiet());
  EXPECT_EQ(r.finished, 3);
  EXPECT_EQ(read_store(dir / "campaign.h5").size(), 4u);
  fs::remove_all(dir);
}

namespace {

struct Member {
  std::string name;
  H5T_class_t cls;
};

std::vector<Member> compound_members(hid_t type) {
  std::vector<Member> out;
  for (int i = 0; i < H5Tget_nmembers(type); ++i) {
    char* n = H5Tget_member_name(type, unsigned(i));
    out.push_back({n, H5Tget_member_class(type, unsigned(i))});
    H5free_memory(n);
  }
  return out;
}

}  // namespace

TEST(CampaignStore, IndexTableColumnsAndIntegerCounts) {
  const fs::path dir = fresh_dir("index");
  const Campaign a = expand(kA);
  run_campaign(a, dir, quiet());
  const auto records = read_store(dir / "campaign.h5");
  ASSERT_EQ(records.size(), 3u);

  const hid_t f = H5Fopen((dir / "campaign.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(f, 0);
  const hid_t d = H5Dopen2(f, "index", H5P_DEFAULT);
  ASSERT_GE(d, 0);
  const hid_t type = H5Dget_type(d), space = H5Dget_space(d);
  EXPECT_EQ(H5Sget_simple_extent_npoints(space), 3);
  const std::vector<Member> members = compound_members(type);
  std::vector<std::string> names;
  for (const auto& m : members) names.push_back(m.name);
  EXPECT_EQ(names, (std::vector<std::string>{"case", "status", "matrix", "section", "angle", "volume_fraction", "arrangement",
                                             "resolution", "load", "rows", "steps", "newton_iterations", "error", "scene_hash"}));
  auto cls = [&](const std::string& n) {
    for (const auto& m : members)
      if (m.name == n) return m.cls;
    return H5T_NO_CLASS;
  };
  EXPECT_EQ(cls("case"), H5T_STRING);
  EXPECT_EQ(cls("angle"), H5T_FLOAT);
  for (const char* n : {"resolution", "rows", "steps", "newton_iterations"}) EXPECT_EQ(cls(n), H5T_INTEGER) << n;

  // Read case, angle, rows, steps back through a memory type of our own.
  struct Row {
    char* id;
    double angle;
    std::int64_t rows, steps, resolution;
  };
  const hid_t str = H5Tcopy(H5T_C_S1);
  H5Tset_size(str, H5T_VARIABLE);
  const hid_t mem = H5Tcreate(H5T_COMPOUND, sizeof(Row));
  H5Tinsert(mem, "case", HOFFSET(Row, id), str);
  H5Tinsert(mem, "angle", HOFFSET(Row, angle), H5T_NATIVE_DOUBLE);
  H5Tinsert(mem, "rows", HOFFSET(Row, rows), H5T_NATIVE_INT64);
  H5Tinsert(mem, "steps", HOFFSET(Row, steps), H5T_NATIVE_INT64);
  H5Tinsert(mem, "resolution", HOFFSET(Row, resolution), H5T_NATIVE_INT64);
  std::vector<Row> rows(3);
  ASSERT_GE(H5Dread(d, mem, H5S_ALL, H5S_ALL, H5P_DEFAULT, rows.data()), 0);
  std::set<std::string> ids;
  for (const Row& r : rows) {
    const std::string id = r.id;
    ids.insert(id);
    ASSERT_TRUE(records.count(id)) << id;
    const CaseRecord& rec = records.at(id);
    EXPECT_EQ(r.rows, 3);  // t = 0 and two steps
    EXPECT_EQ(r.steps, 2);
    EXPECT_EQ(r.resolution, 8);
    if (id.find("-matrix-") != std::string::npos) {
      EXPECT_TRUE(std::isnan(r.angle)) << id;  // no fiber, no angle
    } else {
      EXPECT_EQ(r.angle, std::get<double>(rec.parameters[2].value)) << id;
    }
  }
  H5Dvlen_reclaim(mem, space, H5P_DEFAULT, rows.data());
  EXPECT_EQ(ids.size(), 3u);
  H5Tclose(mem);
  H5Tclose(str);
  H5Sclose(space);
  H5Tclose(type);
  H5Dclose(d);

  // Counts are int64 attributes; the response carries its column names.
  const std::string id = a.cases[1].id;
  const hid_t g = H5Gopen2(f, ("cases/" + id).c_str(), H5P_DEFAULT);
  ASSERT_GE(g, 0);
  for (const char* n : {"steps", "newton_iterations", "voxels", "threads", "resolution"}) {
    const hid_t at = H5Aopen(g, n, H5P_DEFAULT);
    ASSERT_GE(at, 0) << n;
    const hid_t t = H5Aget_type(at);
    EXPECT_EQ(H5Tget_class(t), H5T_INTEGER) << n;
    H5Tclose(t);
    H5Aclose(at);
  }
  const hid_t resp = H5Dopen2(g, "response", H5P_DEFAULT);
  ASSERT_GE(resp, 0);
  EXPECT_GT(H5Aexists(resp, "columns"), 0);
  H5Dclose(resp);
  H5Gclose(g);
  H5Fclose(f);
  EXPECT_EQ(records.at(id).columns.front(), "t");
  EXPECT_EQ(records.at(id).stats.at("voxels"), 64.0);  // 8 x 8, read back from int64

  // cases.csv: the matrix alone has angle NaN.
  std::ifstream in(dir / "cases.csv");
  std::string line;
  bool saw_matrix = false;
  while (std::getline(in, line))
    if (line.find("-matrix-") != std::string::npos) {
      EXPECT_NE(line.find(",pdms,none,NaN,0,none,8,pull,"), std::string::npos) << line;
      saw_matrix = true;
    }
  EXPECT_TRUE(saw_matrix);
  fs::remove_all(dir);
}

namespace {

// A store of the first layout ("softhom-campaign-1"): columns on the group, counts and the matrix
// angle (0) as float64, no index table.
void write_first_layout(const fs::path& path, const CaseRecord& r) {
  const hid_t f = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  const hid_t str = H5Tcopy(H5T_C_S1);
  H5Tset_size(str, H5T_VARIABLE);
  auto attr_s = [&](hid_t loc, const char* name, const std::vector<std::string>& v, bool scalar) {
    const hsize_t n = v.size();
    const hid_t sp = scalar ? H5Screate(H5S_SCALAR) : H5Screate_simple(1, &n, nullptr);
    const hid_t a = H5Acreate2(loc, name, str, sp, H5P_DEFAULT, H5P_DEFAULT);
    std::vector<const char*> p;
    for (const auto& s : v) p.push_back(s.c_str());
    H5Awrite(a, str, p.data());
    H5Aclose(a);
    H5Sclose(sp);
  };
  auto attr_d = [&](hid_t loc, const char* name, double v) {
    const hid_t sp = H5Screate(H5S_SCALAR);
    const hid_t a = H5Acreate2(loc, name, H5T_IEEE_F64LE, sp, H5P_DEFAULT, H5P_DEFAULT);
    H5Awrite(a, H5T_NATIVE_DOUBLE, &v);
    H5Aclose(a);
    H5Sclose(sp);
  };
  attr_s(f, "format", {"softhom-campaign-1"}, true);
  const hid_t cases = H5Gcreate2(f, "cases", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  const hid_t g = H5Gcreate2(cases, r.id.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  std::vector<std::string> names;
  for (const auto& p : r.parameters) names.push_back(p.name);
  attr_s(g, "parameters", names, false);
  for (const auto& p : r.parameters) {
    if (p.is_string()) attr_s(g, p.name.c_str(), {std::get<std::string>(p.value)}, true);
    else attr_d(g, p.name.c_str(), std::isnan(std::get<double>(p.value)) ? 0.0 : std::get<double>(p.value));
  }
  attr_s(g, "status", {r.status}, true);
  attr_s(g, "error", {r.error}, true);
  attr_s(g, "scene", {r.scene_text}, true);
  attr_s(g, "scene_hash", {r.scene_hash}, true);
  for (const auto& [k, v] : r.stats) attr_d(g, k.c_str(), v);
  attr_s(g, "columns", r.columns, false);
  const hsize_t dims[2] = {r.rows(), r.columns.size()};
  const hid_t sp = H5Screate_simple(2, dims, nullptr);
  const hid_t d = H5Dcreate2(g, "response", H5T_IEEE_F64LE, sp, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  H5Dwrite(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, r.data.data());
  H5Dclose(d);
  H5Sclose(sp);
  H5Gclose(g);
  H5Gclose(cases);
  H5Tclose(str);
  H5Fclose(f);
}

}  // namespace

TEST(CampaignStore, FirstLayoutIsReadForResumeAndRewritten) {
  const fs::path dir = fresh_dir("v1"), ref = fresh_dir("v1_ref");
  const Campaign a = expand(kA);
  run_campaign(a, ref, quiet());
  const auto reference = read_store(ref / "campaign.h5");
  // The matrix-alone case, stored in the first layout.
  const std::string matrix_id = a.cases[0].id;
  ASSERT_NE(matrix_id.find("-matrix-"), std::string::npos);
  write_first_layout(dir / "campaign.h5", reference.at(matrix_id));
  const auto old = read_store(dir / "campaign.h5");
  ASSERT_EQ(old.size(), 1u);
  const CaseRecord& r = old.at(matrix_id);
  EXPECT_EQ(r.columns, reference.at(matrix_id).columns);
  EXPECT_EQ(r.data, reference.at(matrix_id).data);
  EXPECT_TRUE(std::isnan(std::get<double>(r.parameters[2].value)));  // 0 of the first layout → NaN

  const SweepReport resumed = run_campaign(a, dir, quiet());
  EXPECT_EQ(resumed.skipped, 1);
  EXPECT_EQ(resumed.finished, 2);
  expect_same_records(reference, read_store(dir / "campaign.h5"));
  EXPECT_EQ(slurp(dir / "cases.csv"), slurp(ref / "cases.csv"));

  // A file of another format is refused with a message naming it.
  const fs::path other = dir / "other.h5";
  const hid_t f = H5Fcreate(other.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  H5Fclose(f);
  try {
    read_store(other);
    ADD_FAILURE() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(other.string()), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("unknown format"), std::string::npos) << e.what();
  }
  fs::remove_all(dir);
  fs::remove_all(ref);
}

TEST(CampaignStore, InterruptBetweenCasesThenResumeEqualsAnUninterruptedRun) {
  const fs::path full = fresh_dir("int_full"), part = fresh_dir("int_part");
  const Campaign a = expand(kA);
  run_campaign(a, full, quiet());
  const auto reference = read_store(full / "campaign.h5");

  SweepOptions o = quiet();
  o.on_case_finished = [](const CaseRecord&) { request_stop(); };  // as SIGTERM as the first case ends
  const SweepReport r = run_campaign(a, part, o);
  const bool stopped = stop_requested();
  clear_stop_request();
  EXPECT_TRUE(stopped);
  EXPECT_TRUE(r.interrupted);
  // One job: the stop arrives as the first case ends, so the worker takes no other case.
  EXPECT_EQ(r.finished, 1);
  EXPECT_EQ(read_store(part / "campaign.h5").size(), std::size_t(r.finished));
  EXPECT_TRUE(temporaries(part).empty());

  const SweepReport resumed = run_campaign(a, part, quiet());
  EXPECT_FALSE(resumed.interrupted);
  EXPECT_EQ(resumed.skipped, r.finished);
  EXPECT_EQ(resumed.finished, 3 - r.finished);
  expect_same_records(reference, read_store(part / "campaign.h5"));
  EXPECT_EQ(slurp(part / "cases.csv"), slurp(full / "cases.csv"));
  fs::remove_all(full);
  fs::remove_all(part);
}
