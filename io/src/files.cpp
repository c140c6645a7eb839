// Atomic file writes, CSV tables and process memory: the plumbing every output file goes through.
#include "softhom/io/files.hpp"

#include <cerrno>
#include <charconv>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <stdexcept>
#include <system_error>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include "softhom/core/input_error.hpp"

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

WriteError::WriteError(const std::filesystem::path& path, const std::string& what, int os_error)
    : std::runtime_error("cannot write '" + path.string() + "': " + what +
                         (os_error ? std::string(" (") + std::strerror(os_error) + ")" : std::string())),
      path_(path),
      os_error_(os_error) {}

namespace {

// A regular input file is read in well under a second; a file system that stalls longer than this
// (a hung network mount) is reported instead of waited for.
constexpr double kInputReadSeconds = 30.0;

/// Why a file of this type and size is not an input of `kind` ("" when it is).
std::string file_type_problem(const struct stat& st, const InputFileKind& kind) {
  const std::string tail = std::string("; ") + kind.what;
  if (S_ISDIR(st.st_mode)) return "is a directory" + tail;
  if (S_ISFIFO(st.st_mode)) return "is a FIFO (named pipe)" + tail;
  if (S_ISCHR(st.st_mode) || S_ISBLK(st.st_mode)) return "is a device" + tail;
  if (S_ISSOCK(st.st_mode)) return "is a socket" + tail;
  if (!S_ISREG(st.st_mode)) return "is not a regular file" + tail;
  if (static_cast<std::uintmax_t>(st.st_size) > kind.max_bytes)
    return "has " + std::to_string(st.st_size) + " bytes, more than the " + std::to_string(kind.max_bytes) +
           " an input of this kind may have" + tail;
  return {};
}

std::string open_problem(int err) {
  return err == ENOENT ? std::string("file not found") : std::string("cannot be read (") + std::strerror(err) + ")";
}

/// Reads the open regular file `fd` (at most kind.max_bytes) into `text`; returns the problem or "".
std::string read_bounded(int fd, const InputFileKind& kind, std::string& text) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(kInputReadSeconds);
  char buffer[1 << 16];
  for (;;) {
    const ssize_t n = ::read(fd, buffer, sizeof buffer);
    if (n == 0) break;
    if (n < 0) {
      if (errno == EINTR) continue;
      return open_problem(errno);
    }
    if (text.size() + std::size_t(n) > kind.max_bytes)
      return "has more than the " + std::to_string(kind.max_bytes) + " bytes an input of this kind may have; " + kind.what;
    text.append(buffer, std::size_t(n));
    if (std::chrono::steady_clock::now() > deadline) return "could not be read within " + format_number(kInputReadSeconds) + " s";
  }
  if (kind.text && text.find('\0') != std::string::npos)
    return std::string("is a binary file (NUL bytes); ") + kind.what;
  return {};
}

/// The checked read: "" and the text, or the problem (a reason without the path).
std::string read_checked(const fs::path& path, const InputFileKind& kind, std::string& text) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return open_problem(errno);
  if (std::string p = file_type_problem(st, kind); !p.empty()) return p;
  // Not blocking: the path may have been swapped for a FIFO since the look; the descriptor is checked again.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) return open_problem(errno);
  std::string problem = ::fstat(fd, &st) != 0 ? open_problem(errno) : file_type_problem(st, kind);
  if (problem.empty()) problem = read_bounded(fd, kind, text);
  ::close(fd);
  return problem;
}

}  // namespace

std::string input_file_problem(const fs::path& path, const InputFileKind& kind) {
  std::string problem;
  if (kind.text) {
    std::string text;
    problem = read_checked(path, kind, text);
  } else if (struct stat st {}; ::stat(path.c_str(), &st) != 0) {
    problem = open_problem(errno);
  } else {
    problem = file_type_problem(st, kind);
  }
  if (problem.empty()) return problem;
  const bool sentence = problem.rfind("is ", 0) == 0 || problem.rfind("has ", 0) == 0;  // "'p' is a FIFO"
  std::string message = "'";  // (built by appending: GCC 12 warns falsely on "'" + std::string)
  message += path.string();
  message += sentence ? "' " : "': ";
  return message + problem;
}

void check_input_file(const fs::path& path, const std::string& field, const InputFileKind& kind) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) throw InputError(field, path.string(), open_problem(errno));
  if (std::string p = file_type_problem(st, kind); !p.empty()) throw InputError(field, path.string(), p);
}

std::string read_input_file(const fs::path& path, const std::string& field, const InputFileKind& kind) {
  std::string text;
  if (std::string p = read_checked(path, kind, text); !p.empty()) throw InputError(field, path.string(), p);
  return text;
}

long temporary_owner(const std::filesystem::path& file) {
  const std::string name = file.filename().string();
  const std::size_t tag = name.rfind(".tmp-");
  if (name.size() < 2 || name[0] != '.' || tag == std::string::npos || tag == 0) return 0;
  long pid = 0;
  const char* first = name.data() + tag + 5;
  const char* last = name.data() + name.size();
  const auto r = std::from_chars(first, last, pid);
  return (r.ec == std::errc{} && r.ptr == last && first != last && pid > 0) ? pid : 0;
}

namespace {

// kill(pid, 0) probes a process without signalling it; EPERM means it exists under another user.
bool process_alive(long pid) { return ::kill(static_cast<pid_t>(pid), 0) == 0 || errno == EPERM; }

template <class Pred>
std::vector<fs::path> remove_temporaries_if(const fs::path& dir, Pred remove_it) {
  std::vector<fs::path> removed;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const long pid = temporary_owner(it->path());
    if (pid == 0 || !remove_it(pid)) continue;
    std::error_code rm;
    // A stale HDF5 temporary is a file; remove_all also copes with a directory of that name.
    if (fs::remove_all(it->path(), rm) > 0 && !rm) removed.push_back(it->path());
  }
  return removed;
}

}  // namespace

std::vector<std::filesystem::path> remove_stale_temporaries(const std::filesystem::path& dir) {
  return remove_temporaries_if(dir, [](long pid) { return pid != ::getpid() && !process_alive(pid); });
}

std::vector<std::filesystem::path> remove_own_temporaries(const std::filesystem::path& dir) {
  return remove_temporaries_if(dir, [](long pid) { return pid == ::getpid(); });
}

bool write_failure_injected(const std::filesystem::path& target) {
  const char* name = std::getenv("SOFTHOM_INJECT_WRITE_FAILURE");
  return name && *name && target.filename() == name;
}

namespace {

[[noreturn]] void fail(const fs::path& path, const std::string& what, int err) { throw WriteError(path, what, err); }

// Writes all of `content` to `tmp` and fsyncs it, so that after the rename the data is on disk and
// a crash can leave either the old file or the new one, never a truncated one.
void write_and_sync(const fs::path& target, const fs::path& tmp, std::string_view content) {
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) fail(target, "cannot create temporary '" + tmp.string() + "'", errno);
  const char* p = content.data();
  std::size_t left = content.size();
  const bool inject = write_failure_injected(target);
  if (inject) left /= 2;  // half the data reaches the temporary, then the "disk is full"
  while (left > 0 || inject) {
    const ssize_t n = inject && left == 0 ? (errno = ENOSPC, -1) : ::write(fd, p, left);
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
  if (path.filename().empty()) throw WriteError(path, "not a file name", 0);
  std::error_code ec;
  if (!path.parent_path().empty()) {
    fs::create_directories(path.parent_path(), ec);
    if (ec) throw WriteError(path, "cannot create directory '" + path.parent_path().string() + "'", ec.value());
  }
  const fs::path tmp = temporary_path(path);
  try {
    write_and_sync(path, tmp, content);
    fs::rename(tmp, path, ec);
    if (ec) fail(path, "cannot rename temporary into place", ec.value());
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

ProgressiveCsv::ProgressiveCsv(std::filesystem::path path, std::vector<std::string> columns, double cost_ratio)
    : path_(std::move(path)), table_(std::move(columns)), cost_ratio_(cost_ratio) {}

void ProgressiveCsv::add_row(const std::vector<double>& row) {
  table_.add_row(row);
  const auto now = std::chrono::steady_clock::now();
  if (!written_ || std::chrono::duration<double>(now - last_end_).count() >= cost_ratio_ * last_cost_s_) flush();
}

void ProgressiveCsv::flush() {
  if (path_.empty()) return;  // a table kept in memory only (e.g. on the ranks that do not write)
  const auto start = std::chrono::steady_clock::now();
  table_.write(path_);
  last_end_ = std::chrono::steady_clock::now();
  last_cost_s_ = std::chrono::duration<double>(last_end_ - start).count();
  rows_on_disk_ = table_.rows();
  written_ = true;
}

namespace {

// "P_matrix_12" → {"P_matrix_", 1, 2}; false unless the name is PREFIX + two digits in 1..3.
bool split_tensor_component(const std::string& c, std::string& prefix, int& i, int& j) {
  if (c.size() < 3) return false;
  const char a = c[c.size() - 2], b = c[c.size() - 1];
  if (a < '1' || a > '3' || b < '1' || b > '3') return false;
  prefix = c.substr(0, c.size() - 2);
  i = a - '0';
  j = b - '0';
  return true;
}

}  // namespace

ColumnInfo column_info(const std::string& column) {
  std::string prefix;
  int i = 0, j = 0;
  if (split_tensor_component(column, prefix, i, j)) {
    const std::string ij = std::to_string(i) + std::to_string(j);
    static const std::map<std::string, ColumnInfo> tensors{
        {"F", {"1", "deformation gradient (macro average for an RVE)"}},
        {"P", {"MPa", "first Piola-Kirchhoff stress (macro average for an RVE)"}},
        {"sigma", {"MPa", "Cauchy stress (macro average for an RVE)"}},
        {"P_matrix_", {"MPa", "first Piola-Kirchhoff stress averaged over the matrix phase"}},
        {"P_fiber_", {"MPa", "first Piola-Kirchhoff stress averaged over the fiber phase"}},
        {"sigma_matrix_", {"MPa", "Cauchy stress averaged over the matrix phase"}},
        {"sigma_fiber_", {"MPa", "Cauchy stress averaged over the fiber phase"}},
    };
    if (const auto it = tensors.find(prefix); it != tensors.end())
      return {it->second.unit, it->second.description + ", component " + ij + " (row-major, load frame)"};
  }
  static const std::map<std::string, ColumnInfo> scalars{
      {"t", {"s", "time of the load history"}},
      {"fiber_angle_deg", {"deg", "current fiber angle to the load direction (e1)"}},
      {"delta_fiber_angle_deg", {"deg", "fiber rotation since the undeformed state"}},
      {"newton_iterations", {"count", "Newton iterations of the step"}},
      {"krylov_iterations", {"count", "Krylov iterations of the step"}},
      {"substeps", {"count", "sub-steps the step took (1: no cut-back)"}},
      {"stretch", {"1", "applied or measured stretch"}},
      {"axial_stretch", {"1", "axial stretch of the free end"}},
      {"force", {"N", "reaction force on the loaded face (MPa x mm^2)"}},
      {"nominal_stress", {"MPa", "force per undeformed loaded area"}},
      {"pressure", {"MPa", "cavity (internal) pressure"}},
      {"volume", {"mm^3", "cavity volume"}},
      {"inner_radius", {"mm", "mean inner radius"}},
      {"mean_radius", {"mm", "mean radius of the cavity surface"}},
      {"twist_deg", {"deg", "twist of the free end"}},
      {"tip_angle_deg", {"deg", "bending angle of the tip"}},
      {"tip_deflection", {"mm", "deflection of the tip"}},
      {"probe_ux", {"mm", "displacement x of the probe node"}},
      {"probe_uy", {"mm", "displacement y of the probe node"}},
      {"probe_uz", {"mm", "displacement z of the probe node"}},
  };
  if (const auto it = scalars.find(column); it != scalars.end()) return it->second;
  // fiber<k>_angle_deg of the material-point driver (one per fiber family)
  if (column.rfind("fiber", 0) == 0 && column.size() > 15 && column.compare(column.size() - 10, 10, "_angle_deg") == 0)
    return {"deg", "current angle of fiber family " + column.substr(5, column.size() - 15) + " to the load direction (e1)"};
  return {};
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
