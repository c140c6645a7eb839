#pragma once
// Result files are never half-written: everything goes to a temporary name in the same directory and
// is renamed into place once complete.
//
// Columns of response.csv. Every response.csv of every subcommand uses one vocabulary: `t` (time), tensor
// components `F11 … F33`, `P11 …` (first Piola–Kirchhoff stress), `sigma11 …` (Cauchy stress), all
// row-major (11, 12, 13, 21, …) in the load frame, and plain names for scalars (`pressure`, `volume`,
// …). The header carries the bare names, so that pandas reads `pd.read_csv(path).P11`; units and a
// description of every column are in summary.json under "columns" ({"P11": {"unit": "MPa",
// "description": "..."}}, see column_info()). Units are those of the scenes: MPa, mm, s (the spec's
// unit system); "1" marks a dimensionless column, "count" an iteration count.
//
// Write failures (full disk, permissions, read-only file systems) throw io::WriteError, whose message
// names the file and the OS reason; no temporary is left behind and the previous complete file stays.
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace softhom::io {

/// An output file could not be written. what(): "cannot write 'PATH': WHAT (OS reason)".
class WriteError : public std::runtime_error {
 public:
  WriteError(const std::filesystem::path& path, const std::string& what, int os_error);
  const std::filesystem::path& path() const { return path_; }
  int os_error() const { return os_error_; }  ///< errno value, 0 if none

 private:
  std::filesystem::path path_;
  int os_error_ = 0;
};

/// Writes `content` to `path` atomically (temp file + fsync + rename). Creates parent directories.
/// Throws WriteError.
void write_file_atomic(const std::filesystem::path& path, std::string_view content);

/// Temporary name used for `path` while it is being written (same directory, so rename is atomic):
/// DIR/.NAME.tmp-PID.
std::filesystem::path temporary_path(const std::filesystem::path& path);

/// The pid in a temporary's name (".NAME.tmp-PID"), or 0 when `file` is not named like a temporary.
long temporary_owner(const std::filesystem::path& file);

/// Removes the temporaries directly in `dir` whose owning process no longer runs (left by kill -9,
/// a power cut, a second Ctrl-C). Temporaries of running processes, including this one, are kept.
/// Returns the removed paths; a missing directory is not an error.
std::vector<std::filesystem::path> remove_stale_temporaries(const std::filesystem::path& dir);

/// Removes the temporaries of this process directly in `dir` (last line of defence on exit paths
/// that skipped a destructor). Returns the removed paths.
std::vector<std::filesystem::path> remove_own_temporaries(const std::filesystem::path& dir);

/// Test hook: when the environment variable SOFTHOM_INJECT_WRITE_FAILURE holds a file name (e.g.
/// "response.csv" or "fields.h5"), writes of a file of that name fail as on a full disk (ENOSPC),
/// after part of the data went to the temporary, so that the clean-up paths run. Returns whether
/// `target` is such a file.
bool write_failure_injected(const std::filesystem::path& target);

/// Input files a scene names (the scene itself, a base scene, curve CSVs, a checkpoint record, an image,
/// a mesh) are read through one checked opener: only a regular file is opened (a FIFO would block until a
/// writer appears, a device such as /dev/zero never ends, a directory is not a file), at most
/// `max_bytes` of it, and, when it is text, without NUL bytes.
struct InputFileKind {
  const char* what;            ///< what the file should be, for messages: "a scene is a TOML file"
  std::uintmax_t max_bytes;    ///< larger files are refused before they are read
  bool text;                   ///< NUL bytes refused
};
inline constexpr InputFileKind kSceneFile{"a scene is a regular TOML file", 4u << 20, true};
inline constexpr InputFileKind kCsvFile{"a curve is a regular CSV text file", 64u << 20, true};
inline constexpr InputFileKind kJsonFile{"a checkpoint or summary record is a regular JSON file", 64u << 20, true};
/// Binary inputs read by HDF5 (images, checkpoint states): their size is the data's own.
inline constexpr InputFileKind kDataFile{"a data file is a regular file", ~std::uintmax_t(0), false};
inline constexpr InputFileKind kMeshFile{"a mesh is a regular Gmsh file", 1u << 30, false};

/// Why `path` cannot be read as an input of `kind` ("'PATH' is a FIFO (named pipe); a scene is ..."),
/// or "" when it can. Looks at the file without opening anything but a regular file.
std::string input_file_problem(const std::filesystem::path& path, const InputFileKind& kind);

/// input_file_problem() as an InputError(field, path, problem).
void check_input_file(const std::filesystem::path& path, const std::string& field, const InputFileKind& kind);

/// The whole text of a checked input file. The file is opened without blocking and checked again on
/// the open descriptor (it may have been replaced since the look), and no more than kind.max_bytes are
/// ever read, within a few seconds. Throws InputError(field, path, reason).
std::string read_input_file(const std::filesystem::path& path, const std::string& field, const InputFileKind& kind);

/// A CSV table: header once, rows of doubles. Non-finite values are refused (throws), so no NaN ever
/// reaches an output file.
class CsvTable {
 public:
  explicit CsvTable(std::vector<std::string> columns) : columns_(std::move(columns)) {}
  void add_row(const std::vector<double>& row);
  std::size_t rows() const { return columns_.empty() ? 0 : data_.size() / columns_.size(); }
  /// Every value, row after row.
  std::span<const double> values() const { return data_; }
  const std::vector<std::string>& columns() const { return columns_; }
  std::string to_string() const;
  void write(const std::filesystem::path& path) const { write_file_atomic(path, to_string()); }

 private:
  std::vector<std::string> columns_;
  std::vector<double> data_;
};

/// A CSV file whose converged rows are on disk while the run goes on: every add_row() rewrites the
/// file atomically (so a reader, or a kill -9, only ever sees a complete table of whole rows), except
/// when rows come faster than writes are cheap: a rewrite waits until the time since the last one is
/// at least `cost_ratio` times what the last one took, which bounds the writing overhead to about
/// 1/cost_ratio of the run and keeps at most that short interval of rows unwritten. flush() writes now.
/// (Appending instead would be cheaper per row but leaves a torn last line on kill -9 mid-write.)
class ProgressiveCsv {
 public:
  ProgressiveCsv(std::filesystem::path path, std::vector<std::string> columns, double cost_ratio = 20.0);
  void add_row(const std::vector<double>& row);
  void flush();
  std::size_t rows() const { return table_.rows(); }
  std::size_t rows_on_disk() const { return rows_on_disk_; }
  const CsvTable& table() const { return table_; }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
  CsvTable table_;
  double cost_ratio_;
  std::size_t rows_on_disk_ = 0;
  bool written_ = false;
  std::chrono::steady_clock::time_point last_end_{};
  double last_cost_s_ = 0.0;
};

/// Unit and description of a response column of the shared vocabulary (see the top of this file):
/// {"unit", "description"}; unknown names get unit "" and an empty description.
struct ColumnInfo {
  std::string unit;
  std::string description;
};
ColumnInfo column_info(const std::string& column);

/// Peak resident memory of this process in bytes (from /proc/self/status VmHWM), 0 if unknown.
std::size_t peak_memory_bytes();

}  // namespace softhom::io
