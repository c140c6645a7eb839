#include "softhom/fe/petsc_options.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <utility>

#include "softhom/core/input_error.hpp"

namespace softhom::fe {
namespace {

constexpr const char* kField = "solver.petsc_options";

bool contains(const std::string& s, const char* part) { return s.find(part) != std::string::npos; }
bool ends_with(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

[[noreturn]] void refuse(const std::string& name, const std::string& value, const std::string& why) {
  throw InputError(kField, value.empty() ? name : name + " " + value, why);
}

bool plain_name(const std::string& name) {
  if (name.size() < 2 || name[0] != '-') return false;
  for (std::size_t i = 1; i < name.size(); ++i) {
    const char c = name[i];
    if (!((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_')) return false;
  }
  return name[1] != '_' && name.back() != '_';
}

bool plain_value(const std::string& value) {
  for (const char c : value)
    if (c == '"' || c == '\'' || c == '$' || c == '`' || static_cast<unsigned char>(c) < 0x20) return false;
  return true;
}

// Viewers print to standard output without a value, with "ascii" or with a format alone.
bool stdout_viewer(const std::string& value) {
  if (value.empty() || value == "ascii") return true;
  const std::size_t first = value.find(':');
  if (first == std::string::npos) return false;
  const std::string type = value.substr(0, first);
  if (!(type.empty() || type == "ascii")) return false;
  const std::size_t second = value.find(':', first + 1);
  // type:filename[:format[:mode]]: the file name must be empty.
  return second == first + 1 && value.find(':', second + 1) == std::string::npos;
}

void check_number(const std::string& name, const std::string& value, bool integer) {
  errno = 0;
  char* end = nullptr;
  const double x = std::strtod(value.c_str(), &end);
  if (value.empty() || end != value.c_str() + value.size() || errno == ERANGE || !std::isfinite(x))
    refuse(name, value, "needs a finite number");
  if (integer) {
    if (x != std::floor(x) || x < 1.0 || x > 1e7) refuse(name, value, "needs an integer from 1 to 10000000");
    return;
  }
  if (!(x > 0.0)) refuse(name, value, "needs a tolerance > 0");
  if (ends_with(name, "_rtol") && !(x < 1.0)) refuse(name, value, "a relative tolerance must be < 1");
}

void check_option(const std::string& name, const std::string& value) {
  if (!plain_name(name))
    refuse(name, value, "is not a PETSc option (options are -name [value], names of lower-case letters, digits and '_')");
  if (!plain_value(value)) refuse(name, value, "values are plain words or numbers (no quotes, '$' or control characters)");
  const std::string bare = name.substr(1) + "_";
  for (const char* word : {"file", "log", "history", "debugger", "draw", "dump", "saws", "python", "viewer_"})
    if (contains(bare, word)) refuse(name, value, "reads or writes files or changes PETSc itself; scenes may not set it");
  if (!(contains("_" + bare, "_ksp_") || contains("_" + bare, "_pc_") || bare.rfind("mat_mumps_", 0) == 0))
    refuse(name, value, "is not a solver option: petsc_options accepts options of KSP (…ksp_…), PC (…pc_…) and MUMPS (mat_mumps_…)");
  if (contains(bare, "view") || contains(bare, "monitor") || contains(bare, "converged_reason")) {
    if (!stdout_viewer(value))
      refuse(name, value, "viewers and monitors print to standard output only (no value, \"ascii\" or \"::<format>\")");
    return;
  }
  for (const char* tol : {"_rtol", "_atol", "_divtol", "_dtol"})
    if (ends_with(name, tol)) return check_number(name, value, false);
  for (const char* count : {"_max_it", "_restart", "_levels"})
    if (ends_with(name, count)) return check_number(name, value, true);
}

}  // namespace

std::vector<std::pair<std::string, std::string>> split_petsc_options(const std::string& options) {
  std::vector<std::string> tokens;
  std::string token;
  for (const char c : options) {
    if (c == ' ' || c == '\t' || c == '\n' || c == '\r') {
      if (!token.empty()) tokens.push_back(std::move(token));
      token.clear();
    } else {
      token += c;
    }
  }
  if (!token.empty()) tokens.push_back(std::move(token));
  std::vector<std::pair<std::string, std::string>> out;
  for (std::size_t k = 0; k < tokens.size(); ++k) {
    const std::string& t = tokens[k];
    // A value is a token after a name that is not itself a name; "-1" and "-1e-3" are values.
    const bool is_name = t.size() > 1 && t[0] == '-' && !(t[1] >= '0' && t[1] <= '9') && t[1] != '.';
    if (is_name) {
      out.emplace_back(t, "");
    } else if (!out.empty() && out.back().second.empty()) {
      out.back().second = t;
    } else {
      refuse(t, "", "is not an option (options start with '-', each followed by at most one value)");
    }
  }
  return out;
}

void check_petsc_options(const std::string& options) {
  for (const auto& [name, value] : split_petsc_options(options)) check_option(name, value);
}

}  // namespace softhom::fe
