#include "softhom/macro/mesh_generation.hpp"

#include "geo_policy.hpp"

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <vector>

#include "softhom/materials/errors.hpp"

namespace softhom::macro {
namespace {

std::string read_text(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// FNV-1a 64: a stable content hash for the cache name (not a security boundary).
std::uint64_t fnv1a(const std::string& s) {
  std::uint64_t h = 1469598103934665603ull;
  for (unsigned char c : s) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return h;
}

/// The size as gmsh receives it and as the cache name spells it: shortest round-trip decimal.
std::string size_text(double h) {
  char buf[64];
  for (int digits = 1; digits <= 17; ++digits) {
    std::snprintf(buf, sizeof buf, "%.*g", digits, h);
    if (std::strtod(buf, nullptr) == h) break;
  }
  return buf;
}

/// The last lines of gmsh's log that report errors (or its last lines when none says "Error").
std::string gmsh_message(const std::filesystem::path& log) {
  std::ifstream in(log);
  std::vector<std::string> errors, tail;
  for (std::string line; std::getline(in, line);) {
    if (line.find("Error") != std::string::npos) errors.push_back(line);
    tail.push_back(line);
    if (tail.size() > 3) tail.erase(tail.begin());
  }
  const std::vector<std::string>& pick = errors.empty() ? tail : errors;
  std::string out;
  for (std::size_t i = pick.size() > 4 ? pick.size() - 4 : 0; i < pick.size(); ++i)
    out += (out.empty() ? "" : " | ") + pick[i];
  return out.empty() ? "(no output)" : out;
}

/// Runs argv[0] with its output in `log`; the exit status, 127 when the program could not be started.
int run_program(const std::vector<std::string>& args, const std::filesystem::path& log) {
  std::vector<char*> argv;
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  const pid_t pid = ::fork();
  if (pid < 0) return 127;
  if (pid == 0) {
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) {
      ::dup2(fd, STDOUT_FILENO);
      ::dup2(fd, STDERR_FILENO);
      ::close(fd);
    }
    const int null_in = ::open("/dev/null", O_RDONLY);
    if (null_in >= 0) ::dup2(null_in, STDIN_FILENO);
    ::execvp(argv[0], argv.data());
    ::_exit(127);
  }
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0)
    if (errno != EINTR) return 127;
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  return 128 + (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
}

}  // namespace

std::filesystem::path mesh_cache_dir(const std::filesystem::path& out) {
  if (const char* env = std::getenv("SOFTHOM_MESH_CACHE"); env && *env) return env;
  if (!out.empty()) return out / "mesh";
  return std::filesystem::temp_directory_path() / "softhom-mesh-cache";
}

std::filesystem::path mesh_from_geo(const std::filesystem::path& geo, double mesh_size,
                                    const std::filesystem::path& cache_dir, const std::string& field) {
  namespace fs = std::filesystem;
  if (!fs::is_regular_file(geo)) throw InputError(field, geo.string(), "no such .geo file");
  const std::string text = read_text(geo);
  check_geo_text(text, geo, field);
  const std::string h = size_text(mesh_size);
  char hash[17];
  std::snprintf(hash, sizeof hash, "%016llx", static_cast<unsigned long long>(fnv1a(text + "\n#mesh_size=" + h)));
  std::error_code ec;
  fs::create_directories(cache_dir, ec);
  if (ec) throw InputError(field, cache_dir.string(), "cannot create the mesh cache directory: " + ec.message());
  const std::string name = geo.stem().string() + "-" + hash + "-h" + h;
  const fs::path mesh = cache_dir / (name + ".msh");
  if (fs::is_regular_file(mesh)) return mesh;

  const fs::path tmp = cache_dir / (name + ".tmp-" + std::to_string(::getpid()) + ".msh");
  const fs::path log = cache_dir / (name + ".log");
  const char* env = std::getenv("SOFTHOM_GMSH");
  const std::string program = env && *env ? env : "gmsh";
  // An argument vector, not a command line: paths with spaces or shell characters are passed as they are.
  const int rc = run_program({program, fs::absolute(geo).string(), "-3", "-order", "2", "-setnumber", "mesh_size", h,
                              "-format", "msh41", "-o", tmp.string()},
                             log);
  if (rc == 127)
    throw InputError(field, geo.string(),
                     "cannot run the mesher '" + program + "' (install Debian's gmsh, or set SOFTHOM_GMSH): " +
                         gmsh_message(log));
  const std::string message = gmsh_message(log);
  // gmsh reports some failures (a bad .geo line) on its log and still exits 0: its Error lines count.
  if (rc != 0 || !fs::is_regular_file(tmp) || read_text(log).find("Error   :") != std::string::npos) {
    fs::remove(tmp, ec);
    throw InputError(field, geo.string(),
                     "gmsh failed (exit " + std::to_string(rc) + ", mesh_size = " + h + "): " + message +
                         " (full log: " + log.string() + ")");
  }
  fs::rename(tmp, mesh, ec);
  if (ec) throw InputError(field, mesh.string(), "cannot store the generated mesh: " + ec.message());
  return mesh;
}

}  // namespace softhom::macro
