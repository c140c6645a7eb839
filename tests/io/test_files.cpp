// Atomic writes leave no temporaries and replace content; CSV round-trips doubles exactly and refuses NaN.
#include <gtest/gtest.h>

#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>

#include <unistd.h>

#include "io/io_test_helpers.hpp"
#include "softhom/io/files.hpp"

using namespace softhom;
using softhom::test::listing;
using softhom::test::slurp;
namespace fs = std::filesystem;

namespace {

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::string item;
  std::istringstream in(s);
  while (std::getline(in, item, sep)) out.push_back(item);
  return out;
}

}  // namespace

TEST(AtomicFile, TemporaryIsHiddenInSameDirectory) {
  const fs::path t = io::temporary_path("out/dir/response.csv");
  EXPECT_EQ(t.parent_path(), fs::path("out/dir"));  // same file system, so rename is atomic
  EXPECT_EQ(t.filename().string().rfind(".response.csv.tmp-", 0), 0u) << t;
}

TEST(AtomicFile, CreatesDirectoriesReplacesContentLeavesNoTemporary) {
  test::TempDir tmp{"files"};
  const fs::path p = tmp.path / "a" / "b" / "x.txt";
  io::write_file_atomic(p, "first version, longer than the second\n");
  EXPECT_EQ(slurp(p), "first version, longer than the second\n");
  io::write_file_atomic(p, "second\n");
  EXPECT_EQ(slurp(p), "second\n");  // replaced, not overwritten in place (no stale tail)
  EXPECT_EQ(listing(tmp.path), std::vector<std::string>{"a/b/x.txt"});
  io::write_file_atomic(p, "");
  EXPECT_EQ(fs::file_size(p), 0u);
}

TEST(AtomicFile, FailureThrowsNamingPathAndLeavesNoTemporary) {
  test::TempDir tmp{"files"};
  // The target is an existing non-empty directory: the write succeeds, the rename must fail.
  const fs::path target = tmp.path / "occupied";
  fs::create_directories(target / "inside");
  try {
    io::write_file_atomic(target, "data");
    FAIL() << "expected std::runtime_error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(target.string()), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(io::temporary_path(target)));
  EXPECT_TRUE(fs::is_directory(target / "inside"));

  // The parent "directory" is a regular file: cannot create it.
  io::write_file_atomic(tmp.path / "file", "x");
  EXPECT_THROW(io::write_file_atomic(tmp.path / "file" / "child.txt", "y"), std::runtime_error);
}

TEST(CsvTable, RoundTripsDoublesExactly) {
  const std::vector<double> values = {0.1,
                                      1.0 / 3.0,
                                      -2.0 / 3.0,
                                      M_PI,
                                      1.0,
                                      -0.0,
                                      1e-300,
                                      std::numeric_limits<double>::denorm_min(),
                                      std::numeric_limits<double>::max(),
                                      -std::numeric_limits<double>::min(),
                                      123456789.123456789,
                                      std::nextafter(1.0, 2.0)};
  io::CsvTable t({"a", "b", "c"});
  ASSERT_EQ(values.size() % 3, 0u);
  for (std::size_t i = 0; i < values.size(); i += 3) t.add_row({values[i], values[i + 1], values[i + 2]});
  EXPECT_EQ(t.rows(), values.size() / 3);

  const auto lines = split(t.to_string(), '\n');
  ASSERT_EQ(lines.size(), 1 + values.size() / 3);
  EXPECT_EQ(lines[0], "a,b,c");
  std::vector<double> parsed;
  for (std::size_t r = 1; r < lines.size(); ++r) {
    const auto cells = split(lines[r], ',');
    ASSERT_EQ(cells.size(), 3u) << lines[r];
    for (const auto& c : cells) {
      double x = 0;
      const auto res = std::from_chars(c.data(), c.data() + c.size(), x);
      ASSERT_TRUE(res.ec == std::errc{} && res.ptr == c.data() + c.size()) << c;
      parsed.push_back(x);
    }
  }
  ASSERT_EQ(parsed.size(), values.size());
  for (std::size_t i = 0; i < values.size(); ++i) {
    // Exact (bitwise, incl. the sign of zero): the CSV promises full round-trip precision.
    EXPECT_EQ(std::memcmp(&parsed[i], &values[i], sizeof(double)), 0) << i << ": " << values[i];
  }
}

TEST(CsvTable, RefusesNonFiniteNamingTheColumn) {
  io::CsvTable t({"time", "stretch", "P11"});
  t.add_row({0.0, 1.0, 0.0});
  for (double bad : {std::nan(""), HUGE_VAL, -HUGE_VAL}) {
    try {
      t.add_row({1.0, 1.1, bad});
      FAIL() << "expected std::invalid_argument for " << bad;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("P11"), std::string::npos) << e.what();
    }
  }
  EXPECT_EQ(t.rows(), 1u);  // the refused rows were not added
  EXPECT_EQ(t.to_string(), "time,stretch,P11\n0,1,0\n");
}

TEST(CsvTable, RefusesWrongRowLength) {
  io::CsvTable t({"x", "y"});
  EXPECT_THROW(t.add_row({1.0}), std::invalid_argument);
  EXPECT_THROW(t.add_row({1.0, 2.0, 3.0}), std::invalid_argument);
  EXPECT_EQ(t.rows(), 0u);
  io::CsvTable none({});
  EXPECT_EQ(none.rows(), 0u);
  EXPECT_THROW(none.add_row({}), std::invalid_argument);
}

TEST(CsvTable, WritesAtomically) {
  test::TempDir tmp{"files"};
  io::CsvTable t({"t", "v"});
  t.add_row({0.5, -2.25});
  t.write(tmp.path / "response.csv");
  EXPECT_EQ(slurp(tmp.path / "response.csv"), "t,v\n0.5,-2.25\n");
  EXPECT_EQ(listing(tmp.path), std::vector<std::string>{"response.csv"});
}

TEST(PeakMemory, CoversMemoryInUse) {
  const std::size_t before = io::peak_memory_bytes();
  EXPECT_GT(before, 0u);  // Linux always has /proc/self/status
  constexpr std::size_t bytes = 64u << 20;
  std::vector<char> block(bytes);
  for (std::size_t i = 0; i < bytes; i += 4096) block[i] = static_cast<char>(i);  // touch every page
  volatile char sink = block[bytes / 2];
  (void)sink;
  const std::size_t after = io::peak_memory_bytes();
  EXPECT_GE(after, before);
  EXPECT_GE(after, bytes);  // the peak is at least what is resident right now
}
