// Atomic file writes, CSV tables and process memory: the plumbing every output file goes through.
#include "softhom/io/files.hpp"

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <system_error>

#include <fcntl.h>
#include <unistd.h>

namespace softhom::io {

namespace fs = std::filesystem;

std::filesystem::path temporary_path(const std::filesystem::path& path) {
  // Same directory as the target (rename is only atomic within one file system); a leading dot keeps
  // it out of casual listings; the pid keeps two concurrent processes from sharing a temporary.
  std::string name = ".";  // (built by appending: GCC 12 warns falsely on "." + std::string)
  name += path.filename().string();
  name += ".tmp-" + std::to_string(::getpid());
  return path.parent_path() / name;
}

namespace {

[[noreturn]] void fail(const fs::path& path, const std::string& what, int err) {
  throw std::runtime_error("cannot write '" + path.string() + "': " + what +
                           (err ? std::string(" (") + std::strerror(err) + ")" : std::string()));
}

// Writes all of `content` to `tmp` and fsyncs it, so that after the rename the data is on disk and
// a crash can leave either the old file or the new one, never a truncated one.
void write_and_sync(const fs::path& target, const fs::path& tmp, std::string_view content) {
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) fail(target, "cannot create temporary '" + tmp.string() + "'", errno);
  const char* p = content.data();
  std::size_t left = content.size();
  while (left > 0) {
    const ssize_t n = ::write(fd, p, left);
    if (n < 0) {
      if (errno == EINTR) continue;
      const int err = errno;
      ::close(fd);
      fail(target, "write failed", err);
    }
    p += n;
    left -= static_cast<std::size_t>(n);
  }
  if (::fsync(fd) != 0) {
    const int err = errno;
    ::close(fd);
    fail(target, "fsync failed", err);
  }
  if (::close(fd) != 0) fail(target, "close failed", errno);
}

}  // namespace

void write_file_atomic(const std::filesystem::path& path, std::string_view content) {
  if (path.filename().empty()) throw std::runtime_error("cannot write '" + path.string() + "': not a file name");
  std::error_code ec;
  if (!path.parent_path().empty()) {
    fs::create_directories(path.parent_path(), ec);
    if (ec) throw std::runtime_error("cannot write '" + path.string() + "': cannot create directory '" +
                                     path.parent_path().string() + "' (" + ec.message() + ")");
  }
  const fs::path tmp = temporary_path(path);
  try {
    write_and_sync(path, tmp, content);
    fs::rename(tmp, path, ec);
    if (ec) fail(path, "cannot rename temporary into place (" + ec.message() + ")", 0);
  } catch (...) {
    fs::remove(tmp, ec);  // best effort: never leave a half-written temporary behind
    throw;
  }
}

void CsvTable::add_row(const std::vector<double>& row) {
  if (columns_.empty()) throw std::invalid_argument("CsvTable: no columns");
  if (row.size() != columns_.size())
    throw std::invalid_argument("CsvTable: row has " + std::to_string(row.size()) + " values, expected " +
                                std::to_string(columns_.size()) + " (columns '" + columns_.front() +
                                "' to '" + columns_.back() + "')");
  for (std::size_t j = 0; j < row.size(); ++j)
    if (!std::isfinite(row[j]))
      throw std::invalid_argument("CsvTable: non-finite value in column '" + columns_[j] + "' of row " +
                                  std::to_string(rows() + 1));
  data_.insert(data_.end(), row.begin(), row.end());
}

std::string CsvTable::to_string() const {
  // Column names are written verbatim, so they must not need CSV quoting.
  for (const auto& c : columns_)
    if (c.empty() || c.find_first_of(",\"\r\n") != std::string::npos)
      throw std::invalid_argument("CsvTable: column name '" + c + "' is empty or needs quoting");
  std::string out;
  for (std::size_t j = 0; j < columns_.size(); ++j) {
    if (j) out += ',';
    out += columns_[j];
  }
  out += '\n';
  // Shortest representation that parses back to the identical double (std::to_chars guarantee).
  char buf[32];
  for (std::size_t i = 0; i < data_.size(); ++i) {
    const auto r = std::to_chars(buf, buf + sizeof buf, data_[i]);
    out.append(buf, r.ptr);
    out += ((i + 1) % columns_.size() == 0) ? '\n' : ',';
  }
  return out;
}

std::size_t peak_memory_bytes() {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("VmHWM:", 0) != 0) continue;
    std::size_t kib = 0;
    const char* p = line.c_str() + 6;
    while (*p == ' ' || *p == '\t') ++p;
    const auto r = std::from_chars(p, line.c_str() + line.size(), kib);
    return r.ec == std::errc{} ? kib * 1024 : 0;  // the kernel reports kB (KiB)
  }
  return 0;
}

}  // namespace softhom::io
