#include "softhom/macro/mesh_generation.hpp"

#include "geo_policy.hpp"

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <vector>

#include "softhom/macro/structures.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/materials/system_memory.hpp"

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

/// Sum of the bounding-box volumes of the model's volumes (mm³), capped by the box of all of them, from
/// gmsh's `-0` output of the checked .geo (the geometry only, as an MSH 4.1 $Entities section whose
/// volume lines are "tag minX minY minZ maxX maxY maxZ ..."); 0 when gmsh cannot tell (its own run then
/// reports the error).
double geometry_box_measure(const std::string& program, const std::filesystem::path& geo, const std::string& h,
                            const std::filesystem::path& stem, int dimension) {
  const std::filesystem::path entities = stem.string() + ".entities.msh", log = stem.string() + ".entities.log";
  const int rc = run_program({program, geo.string(), "-0", "-setnumber", "mesh_size", h, "-format", "msh41", "-o",
                              entities.string()},
                             log);
  std::ifstream in(entities);
  std::error_code ec;
  std::filesystem::remove(entities, ec);  // open, its text stays readable
  std::filesystem::remove(log, ec);
  std::string line;
  while (rc == 0 && std::getline(in, line) && line.rfind("$Entities", 0) != 0) {}
  std::size_t counts[4] = {0, 0, 0, 0};
  if (!(rc == 0 && in >> counts[0] >> counts[1] >> counts[2] >> counts[3]) || counts[dimension] == 0) return 0.0;
  std::getline(in, line);
  for (int d = 0; d < dimension; ++d)
    for (std::size_t k = 0; k < counts[d] && std::getline(in, line); ++k) {}
  double sum = 0.0, lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
  // A surface's box bounds its area by the sum of the box's three face areas (a sphere's: 12 r² against
  // 4π r²), a volume's box its volume.
  auto measure = [dimension](const double* e) {
    return dimension == 3 ? e[0] * e[1] * e[2] : e[0] * e[1] + e[1] * e[2] + e[2] * e[0];
  };
  for (std::size_t k = 0; k < counts[dimension] && std::getline(in, line); ++k) {
    std::istringstream v(line);
    double tag, a[3], b[3];
    if (!(v >> tag >> a[0] >> a[1] >> a[2] >> b[0] >> b[1] >> b[2])) break;
    const double e[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    sum += measure(e);
    for (int i = 0; i < 3; ++i) lo[i] = std::min(lo[i], a[i]), hi[i] = std::max(hi[i], b[i]);
  }
  const double all[3] = {hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]};
  return dimension == 3 ? std::min(sum, measure(all)) : sum;
}

/// Refuses, before gmsh meshes it, a .geo whose mesh at mesh_size cannot be solved in the memory
/// available even on the leanest route (Krylov, estimate_size_of_nodes). Nodes of a quadratic
/// tetrahedral mesh at a uniform size h, measured with gmsh 4.8 on a 10 mm box: 8 070 at h = 1,
/// 54 661 at 0.5, 251 745 at 0.3, i.e. 6.8 V / h³ as h falls. V is the volumes' bounding boxes, an
/// overestimate for curved or hollow parts (a quarter tube's box holds 2.3x its wall); a size field
/// that refines below mesh_size makes more nodes than this.
/// A triangulated surface (dimension 2) has about 1.2 A / h² nodes at size h (equilateral triangles of
/// area 0.43 h², two per node); the estimate then counts them as solid nodes, an overestimate.
/// Boxes overestimate thin curved parts by about ten times (the micro-gripper at 0.1 mm: 59 GiB
/// estimated, 5.6 GiB measured), so only an estimate beyond kBoxOverestimate times the available memory
/// is refused: a mesh size that is merely too fine for the machine is then left to the solver's own
/// estimate from the mesh's node count, and an absurd one (the box at 0.01 mm: 1e4 times) still never
/// reaches gmsh.
constexpr double kBoxOverestimate = 16.0;

void refuse_unmeshable_geo(const std::string& program, const std::filesystem::path& geo, double mesh_size,
                           const std::string& h, const std::filesystem::path& stem, int dimension) {
  const double available = double(softhom::available_memory_bytes());
  if (!(available > 0.0)) return;
  const double volume = geometry_box_measure(program, geo, h, stem, dimension);
  const double nodes = dimension == 3 ? 6.8 * volume / (mesh_size * mesh_size * mesh_size) : 1.2 * volume / (mesh_size * mesh_size);
  const SizeEstimate e = estimate_size_of_nodes(nodes, false);
  if (!(e.bytes() > kBoxOverestimate * available)) return;
  char why[384];
  std::snprintf(why, sizeof why,
                "the geometry's bounding boxes (%.3g mm^%d) meshed at this size make about %.3g nodes, which need "
                "about %.3g GiB, more than %.0f times the %.3g GiB available; use a larger mesh_size",
                volume, dimension, nodes, e.bytes() / 1073741824.0, kBoxOverestimate, available / 1073741824.0);
  throw InputError("geometry.mesh_size", h, why);
}

}  // namespace

std::filesystem::path mesh_cache_dir(const std::filesystem::path& out) {
  if (const char* env = std::getenv("SOFTHOM_MESH_CACHE"); env && *env) return env;
  if (!out.empty()) return out / "mesh";
  return std::filesystem::temp_directory_path() / "softhom-mesh-cache";
}

std::filesystem::path mesh_from_geo(const std::filesystem::path& geo, double mesh_size,
                                    const std::filesystem::path& cache_dir, const std::string& field,
                                    const std::vector<std::pair<std::string, double>>& parameters, int dimension) {
  namespace fs = std::filesystem;
  if (!fs::is_regular_file(geo)) throw InputError(field, geo.string(), "no such .geo file");
  const std::string text = read_text(geo);
  check_geo_text(text, geo, field);
  const std::string h = size_text(mesh_size);
  std::string keyed = text + "\n#mesh_size=" + h + (dimension == 2 ? "\n#surface" : "");
  for (const auto& [name, value] : parameters) keyed += "\n#" + name + "=" + size_text(value);
  char hash[17];
  std::snprintf(hash, sizeof hash, "%016llx", static_cast<unsigned long long>(fnv1a(keyed)));
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
  // A .geo that never reads mesh_size sets its own sizes: the estimate at mesh_size would not apply.
  if (text.find("mesh_size") != std::string::npos)
    refuse_unmeshable_geo(program, fs::absolute(geo), mesh_size, h, cache_dir / (name + ".tmp-" + std::to_string(::getpid())),
                          dimension);
  // An argument vector, not a command line: paths with spaces or shell characters are passed as they are.
  std::vector<std::string> args{program, fs::absolute(geo).string(), dimension == 2 ? "-2" : "-3", "-order",
                                dimension == 2 ? "1" : "2", "-setnumber", "mesh_size", h};
  for (const auto& [name, value] : parameters) args.insert(args.end(), {"-setnumber", name, size_text(value)});
  args.insert(args.end(), {"-format", "msh41", "-o", tmp.string()});
  const int rc = run_program(args, log);
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

std::filesystem::path scene_mesh_file(const std::string& file, const std::string& geo, double mesh_size,
                                      const std::filesystem::path& scene_file, const std::filesystem::path& mesh_cache,
                                      int dimension, const std::vector<std::pair<std::string, double>>& parameters) {
  if (file.empty() == geo.empty())
    throw InputError(file.empty() ? "geometry.file" : "geometry.geo", "",
                     file.empty() ? "missing: give file (a .msh) or geo (a .geo with mesh_size)" : "give file or geo, not both");
  if (!geo.empty() && !(mesh_size > 0.0)) throw InputError("geometry.mesh_size", "", "missing: required with geometry.geo");
  if (geo.empty() && mesh_size > 0.0) throw InputError("geometry.mesh_size", format_number(mesh_size), "only with geometry.geo");
  auto resolve = [&](const std::string& f) {
    std::filesystem::path p(f);
    if (p.is_relative() && !scene_file.empty()) p = scene_file.parent_path() / p;
    return p;
  };
  std::filesystem::path path = resolve(file);
  if (!geo.empty())
    path = mesh_from_geo(resolve(geo), mesh_size, mesh_cache.empty() ? mesh_cache_dir() : mesh_cache, "geometry.geo",
                         parameters, dimension);
  if (!std::filesystem::exists(path)) throw InputError("geometry.file", path.string(), "no such file");
  return path;
}

}  // namespace softhom::macro
