#pragma once
// Result files are never half-written: everything goes to a temporary name in the same directory and
// is renamed into place once complete.
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace softhom::io {

/// Writes `content` to `path` atomically (temp file + fsync + rename). Creates parent directories.
void write_file_atomic(const std::filesystem::path& path, std::string_view content);

/// Temporary name used for `path` while it is being written (same directory, so rename is atomic).
std::filesystem::path temporary_path(const std::filesystem::path& path);

/// A CSV table: header once, rows of doubles. Non-finite values are refused (throws), so no NaN ever
/// reaches an output file.
class CsvTable {
 public:
  explicit CsvTable(std::vector<std::string> columns) : columns_(std::move(columns)) {}
  void add_row(const std::vector<double>& row);
  std::size_t rows() const { return columns_.empty() ? 0 : data_.size() / columns_.size(); }
  const std::vector<std::string>& columns() const { return columns_; }
  std::string to_string() const;
  void write(const std::filesystem::path& path) const { write_file_atomic(path, to_string()); }

 private:
  std::vector<std::string> columns_;
  std::vector<double> data_;
};

/// Peak resident memory of this process in bytes (from /proc/self/status VmHWM), 0 if unknown.
std::size_t peak_memory_bytes();

}  // namespace softhom::io
