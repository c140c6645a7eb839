// The checked opener every named input file goes through: only a regular file is read, within its size
// bound and, for text, without NUL bytes; anything else is an InputError naming the field and the path,
// at once (a FIFO would block the open, /dev/zero would fill the memory).
#include <gtest/gtest.h>

#include <chrono>
#include <fstream>

#include <sys/stat.h>

#include "io/io_test_helpers.hpp"
#include "softhom/core/input_error.hpp"
#include "softhom/io/files.hpp"
#include "softhom/io/scene.hpp"

using namespace softhom;
namespace fs = std::filesystem;

namespace {

/// The reason read_input_file gives for `path` (empty when it reads), checking the field and value.
std::string refusal(const fs::path& path, const io::InputFileKind& kind) {
  try {
    io::read_input_file(path, "curves[0].file", kind);
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "curves[0].file");
    EXPECT_EQ(e.value(), path.string());
    return e.what();
  }
  return {};
}

void write(const fs::path& p, const std::string& text) { std::ofstream(p, std::ios::binary) << text; }

}  // namespace

TEST(InputFile, ReadsARegularTextFileWhole) {
  test::TempDir tmp{"input_files"};
  write(tmp.path / "a.csv", "x,y\n1,2\n");
  EXPECT_EQ(io::read_input_file(tmp.path / "a.csv", "curves[0].file", io::kCsvFile), "x,y\n1,2\n");
  EXPECT_EQ(io::input_file_problem(tmp.path / "a.csv", io::kCsvFile), "");
}

TEST(InputFile, RefusesWhatIsNoRegularFileWithoutBlocking) {
  test::TempDir tmp{"input_files"};
  ASSERT_EQ(::mkfifo((tmp.path / "fifo").c_str(), 0600), 0);
  const auto start = std::chrono::steady_clock::now();
  EXPECT_NE(refusal(tmp.path / "fifo", io::kCsvFile).find("is a FIFO"), std::string::npos);
  EXPECT_NE(refusal(tmp.path, io::kCsvFile).find("is a directory"), std::string::npos);
  EXPECT_NE(refusal("/dev/zero", io::kCsvFile).find("is a device"), std::string::npos);
  EXPECT_NE(refusal(tmp.path / "missing.csv", io::kCsvFile).find("file not found"), std::string::npos);
  // Nothing was opened for reading: a FIFO without a writer would block a plain open for ever, and the
  // device is never read. 5 s is orders of magnitude above the few stat calls this takes.
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 5.0);
  EXPECT_NE(io::input_file_problem(tmp.path / "fifo", io::kDataFile).find("is a FIFO"), std::string::npos);
  EXPECT_THROW(io::check_input_file("/dev/zero", "microstructure.image.file", io::kDataFile), InputError);
}

TEST(InputFile, RefusesNulBytesInTextAndFilesAboveTheBound) {
  test::TempDir tmp{"input_files"};
  write(tmp.path / "nul.csv", std::string("x,y\n1,\0002\n", 10));
  EXPECT_NE(refusal(tmp.path / "nul.csv", io::kCsvFile).find("NUL"), std::string::npos);
  const io::InputFileKind tiny{"a test file is small", 8, true};
  write(tmp.path / "big.txt", "123456789");  // 9 bytes, one more than the bound
  EXPECT_NE(refusal(tmp.path / "big.txt", tiny).find("has 9 bytes"), std::string::npos);
  write(tmp.path / "fits.txt", "12345678");
  EXPECT_EQ(refusal(tmp.path / "fits.txt", tiny), "");
}

TEST(InputFile, SceneFilesGoThroughTheSameOpenerNamingTheirKey) {
  test::TempDir tmp{"input_files"};
  ASSERT_EQ(::mkfifo((tmp.path / "base.toml").c_str(), 0600), 0);
  try {
    io::load_scene(tmp.path / "base.toml", "base_scene");
    ADD_FAILURE() << "a FIFO was read as a scene";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "base_scene");
    EXPECT_NE(std::string(e.what()).find("FIFO"), std::string::npos) << e.what();
  }
  EXPECT_THROW(io::load_scene(tmp.path), InputError);  // a directory
  write(tmp.path / "ok.toml", "[load]\nsteps = 3\n");
  EXPECT_EQ(io::load_scene(tmp.path / "ok.toml")["load"]["steps"].value<int>(), 3);
}
