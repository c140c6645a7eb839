// Output plumbing under faults: stale temporaries, injected write failures, rows on disk as they come,
// column units, and the attributes and XDMF of field files.
#include <gtest/gtest.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <span>

#include <hdf5.h>
#include <sys/wait.h>
#include <unistd.h>

#include "io/io_test_helpers.hpp"
#include "softhom/io/fields.hpp"
#include "softhom/io/files.hpp"

using namespace softhom;
using softhom::test::listing;
using softhom::test::slurp;
namespace fs = std::filesystem;

namespace {

// The pid of a child that has exited and been reaped: no process has it (until the kernel reuses it,
// which takes a full cycle of the pid space).
long dead_pid() {
  const pid_t pid = ::fork();
  if (pid == 0) ::_exit(0);
  int status = 0;
  ::waitpid(pid, &status, 0);
  return pid;
}

struct ScopedEnv {
  std::string name;
  ScopedEnv(const std::string& n, const std::string& value) : name(n) { ::setenv(n.c_str(), value.c_str(), 1); }
  ~ScopedEnv() { ::unsetenv(name.c_str()); }
};

std::string string_attribute(hid_t loc, const char* name) {
  const hid_t a = H5Aopen(loc, name, H5P_DEFAULT);
  if (a < 0) return "<missing>";
  const hid_t type = H5Aget_type(a);
  char* text = nullptr;
  std::string out = "<unreadable>";
  // Read with the stored type (variable-length UTF-8 string), as h5py does.
  if (H5Tis_variable_str(type) > 0 && H5Aread(a, type, &text) >= 0 && text) {
    out = text;
    H5free_memory(text);
  }
  H5Tclose(type);
  H5Aclose(a);
  return out;
}

double double_attribute(hid_t loc, const char* name) {
  const hid_t a = H5Aopen(loc, name, H5P_DEFAULT);
  if (a < 0) return -1.0;
  double v = -1.0;
  H5Aread(a, H5T_NATIVE_DOUBLE, &v);
  H5Aclose(a);
  return v;
}

io::VoxelGrid small_grid() {
  io::VoxelGrid g;
  g.cells = {3, 2, 2};
  g.spacing = {0.5, 0.5, 0.25};
  return g;
}

}  // namespace

TEST(Temporaries, OwnerIsParsedFromTheName) {
  EXPECT_EQ(io::temporary_owner(io::temporary_path("dir/response.csv")), long(::getpid()));
  EXPECT_EQ(io::temporary_owner(".fields.h5.tmp-42"), 42);
  EXPECT_EQ(io::temporary_owner("response.csv"), 0);
  EXPECT_EQ(io::temporary_owner("x.tmp-42"), 0);         // not hidden: not one of ours
  EXPECT_EQ(io::temporary_owner(".x.tmp-42abc"), 0);     // trailing garbage
  EXPECT_EQ(io::temporary_owner(".x.tmp-"), 0);
}

TEST(Temporaries, StaleOnesAreRemovedLiveOnesKept) {
  test::TempDir tmp{"outputs"};
  const long dead = dead_pid();
  const fs::path stale = tmp.path / (".response.csv.tmp-" + std::to_string(dead));
  const fs::path mine = io::temporary_path(tmp.path / "summary.json");
  const fs::path init = tmp.path / ".fields.h5.tmp-1";  // pid 1 always runs
  for (const auto& p : {stale, mine, init}) std::ofstream(p) << "partial";
  std::ofstream(tmp.path / "response.csv") << "t\n0\n";
  const auto removed = io::remove_stale_temporaries(tmp.path);
  ASSERT_EQ(removed.size(), 1u);
  EXPECT_EQ(removed[0], stale);
  EXPECT_FALSE(fs::exists(stale));
  EXPECT_TRUE(fs::exists(mine));
  EXPECT_TRUE(fs::exists(init));
  EXPECT_TRUE(fs::exists(tmp.path / "response.csv"));
  EXPECT_EQ(io::remove_own_temporaries(tmp.path), std::vector<fs::path>{mine});
  EXPECT_TRUE(io::remove_stale_temporaries(tmp.path / "absent").empty());  // no directory: nothing to do
}

TEST(WriteFailure, InjectedFullDiskNamesFileKeepsPreviousAndLeavesNoTemporary) {
  test::TempDir tmp{"outputs"};
  const fs::path p = tmp.path / "response.csv";
  io::write_file_atomic(p, "t\n0\n");
  ScopedEnv inject("SOFTHOM_INJECT_WRITE_FAILURE", "response.csv");
  try {
    io::write_file_atomic(p, "t\n0\n1\n");
    FAIL() << "expected io::WriteError";
  } catch (const io::WriteError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(p.string()), std::string::npos) << what;
    EXPECT_NE(what.find(std::strerror(ENOSPC)), std::string::npos) << what;
    EXPECT_EQ(e.os_error(), ENOSPC);
  }
  EXPECT_EQ(slurp(p), "t\n0\n");  // the previous complete file stays
  EXPECT_EQ(listing(tmp.path), std::vector<std::string>{"response.csv"});
  io::write_file_atomic(tmp.path / "other.csv", "x\n");  // only the named file fails
  EXPECT_EQ(slurp(tmp.path / "other.csv"), "x\n");
}

TEST(WriteFailure, FieldWriterInjectedFailureLeavesPreviousFieldsAndNoTemporary) {
  test::TempDir tmp{"outputs"};
  const std::vector<double> ones(12, 1.0);
  {
    io::FieldWriter w(tmp.path / "fields", small_grid());
    w.begin_step(0.5);
    w.add("von_mises", ones, 1, io::Centering::cell, "MPa");
    w.end_step();
    w.close();
  }
  const std::string before = slurp(tmp.path / "fields.h5");
  ScopedEnv inject("SOFTHOM_INJECT_WRITE_FAILURE", "fields.h5");
  try {
    io::FieldWriter w(tmp.path / "fields", small_grid());
    FAIL() << "expected io::WriteError";
  } catch (const io::WriteError& e) {
    EXPECT_NE(std::string(e.what()).find((tmp.path / "fields.h5").string()), std::string::npos) << e.what();
  }
  EXPECT_EQ(slurp(tmp.path / "fields.h5"), before);
  EXPECT_EQ(listing(tmp.path), (std::vector<std::string>{"fields.h5", "fields.xdmf"}));
}

TEST(ProgressiveCsv, RowsAreOnDiskAsTheyCome) {
  test::TempDir tmp{"outputs"};
  const fs::path p = tmp.path / "response.csv";
  // cost_ratio 0: every row is written (the bound on the overhead is tested by its definition only,
  // since timings on a shared machine are not reproducible).
  io::ProgressiveCsv csv(p, {"t", "P11"}, 0.0);
  csv.add_row({0.0, 0.0});
  EXPECT_EQ(slurp(p), "t,P11\n0,0\n");
  csv.add_row({0.5, 1.25});
  EXPECT_EQ(slurp(p), "t,P11\n0,0\n0.5,1.25\n");
  EXPECT_EQ(csv.rows_on_disk(), 2u);
  EXPECT_EQ(listing(tmp.path), std::vector<std::string>{"response.csv"});

  // A huge ratio defers every rewrite after the first until flush().
  io::ProgressiveCsv lazy(tmp.path / "lazy.csv", {"t"}, 1e12);
  lazy.add_row({0.0});
  lazy.add_row({1.0});
  EXPECT_EQ(slurp(tmp.path / "lazy.csv"), "t\n0\n");
  lazy.flush();
  EXPECT_EQ(slurp(tmp.path / "lazy.csv"), "t\n0\n1\n");
}

TEST(Columns, EveryResponseColumnHasAUnit) {
  EXPECT_EQ(io::column_info("t").unit, "s");
  EXPECT_EQ(io::column_info("F12").unit, "1");
  EXPECT_EQ(io::column_info("P11").unit, "MPa");
  EXPECT_EQ(io::column_info("sigma33").unit, "MPa");
  EXPECT_EQ(io::column_info("sigma_fiber_23").unit, "MPa");
  EXPECT_NE(io::column_info("sigma_fiber_23").description.find("23"), std::string::npos);
  EXPECT_EQ(io::column_info("fiber2_angle_deg").unit, "deg");
  EXPECT_EQ(io::column_info("pressure").unit, "MPa");
  EXPECT_EQ(io::column_info("volume").unit, "mm^3");
  EXPECT_EQ(io::column_info("newton_iterations").unit, "count");
  EXPECT_EQ(io::column_info("F44").unit, "");  // not a 3x3 component
  EXPECT_EQ(io::column_info("nonsense").unit, "");
}

TEST(FieldAttributes, FileStepAndDatasetsSayWhatTheyHold) {
  test::TempDir tmp{"outputs"};
  std::vector<double> tensor(12 * 9, 0.0);
  {
    io::FieldWriter w(tmp.path / "fields", small_grid());
    w.set_attribute("frame", "load frame");
    w.begin_step(0.25);
    w.add("P", tensor, 9, io::Centering::cell, "MPa");
    w.end_step();
    w.begin_step(0.75);
    w.add("P", tensor, 9, io::Centering::cell, "MPa");
    w.end_step();
    w.close();
  }
  const hid_t f = H5Fopen((tmp.path / "fields.h5").c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(f, 0);
  const std::string version = string_attribute(f, "softhom_version");
  EXPECT_FALSE(version.empty());
  EXPECT_EQ(version.find('<'), std::string::npos) << version;  // neither missing nor unreadable
  EXPECT_NE(string_attribute(f, "units").find("MPa"), std::string::npos);
  EXPECT_NE(string_attribute(f, "tensor_component_order").find("11 12 13 21"), std::string::npos);
  EXPECT_EQ(string_attribute(f, "frame"), "load frame");
  const hid_t g = H5Gopen2(f, "step_000001", H5P_DEFAULT);
  ASSERT_GE(g, 0);
  EXPECT_EQ(double_attribute(g, "time"), 0.75);  // stored as given: exact
  const hid_t d = H5Dopen2(g, "P", H5P_DEFAULT);
  ASSERT_GE(d, 0);
  EXPECT_EQ(string_attribute(d, "unit"), "MPa");
  H5Dclose(d);
  H5Gclose(g);
  H5Fclose(f);
}

TEST(FieldAttributes, XdmfParsesAsXmlWithTheDatasetDimensions) {
  if (std::system("/usr/bin/python3 -c 'import xml.etree.ElementTree' > /dev/null 2>&1") != 0)
    GTEST_SKIP() << "no /usr/bin/python3 to parse the XDMF";
  test::TempDir tmp{"outputs"};
  std::vector<double> tensor(12 * 9, 0.0);
  {
    io::FieldWriter w(tmp.path / "fields", small_grid());
    w.begin_step(1.0);
    w.add("P", tensor, 9, io::Centering::cell, "MPa");
    w.end_step();
    w.close();
  }
  // Grid 3 x 2 x 2 cells: XDMF lists z y x, then the 9 tensor components; the mesh has one more node
  // per direction.
  const std::string script =
      "import sys, xml.etree.ElementTree as ET\n"
      "root = ET.parse(sys.argv[1]).getroot()\n"
      "a = [x for x in root.iter('Attribute') if x.get('Name') == 'P'][0]\n"
      "assert a.get('AttributeType') == 'Tensor', a.attrib\n"
      "assert a.find('DataItem').get('Dimensions') == '2 2 3 9', a.find('DataItem').attrib\n"
      "t = root.find('.//Topology')\n"
      "assert t.get('Dimensions') == '3 3 4', t.attrib\n"
      "assert root.find('.//Time').get('Value') == '1'\n";
  std::ofstream(tmp.path / "check.py") << script;
  const std::string cmd = "/usr/bin/python3 " + (tmp.path / "check.py").string() + " " + (tmp.path / "fields.xdmf").string();
  EXPECT_EQ(std::system(cmd.c_str()), 0) << slurp(tmp.path / "fields.xdmf");
}
