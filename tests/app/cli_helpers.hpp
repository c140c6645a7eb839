#pragma once
// Runs the built `softhom` binary and reads what it wrote.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include <unistd.h>

namespace softhom::test {

struct CommandResult {
  int exit_code = -1;
  std::string output;  // stdout + stderr
};

/// Runs the binary with `args` (and `env`, "NAME=value …", in its environment); output is stdout + stderr.
inline CommandResult run_softhom(const std::string& args, const std::string& env = "") {
  // ctest runs every test in its own process, in parallel: the pid keeps logs apart
  // (std::rand() is unseeded and would give every process the same name).
  static int calls = 0;
  const auto log = std::filesystem::temp_directory_path() /
                   ("softhom-cli-" + std::to_string(::getpid()) + "-" + std::to_string(calls++) + ".log");
  const std::string cmd = (env.empty() ? "" : "env " + env + " ") + std::string(SOFTHOM_BINARY) + " " + args + " > " +
                          log.string() + " 2>&1";
  const int status = std::system(cmd.c_str());
  CommandResult r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream in(log);
  std::stringstream ss;
  ss << in.rdbuf();
  r.output = ss.str();
  std::filesystem::remove(log);
  return r;
}

inline std::filesystem::path fresh_dir(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / ("softhom-test-" + std::to_string(::getpid()) + "-" + name);
  std::filesystem::remove_all(dir);
  return dir;
}

inline std::string scene(const std::string& stem) {
  return std::string(SOFTHOM_SOURCE_DIR) + "/studies/scenes/" + stem + ".toml";
}

struct Csv {
  std::vector<std::string> columns;
  std::vector<std::vector<double>> rows;
  double at(std::size_t row, const std::string& column) const {
    for (std::size_t c = 0; c < columns.size(); ++c)
      if (columns[c] == column) return rows.at(row).at(c);
    throw std::runtime_error("no column " + column);
  }
};

inline nlohmann::json read_json(const std::filesystem::path& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

inline Csv read_csv(const std::filesystem::path& path) {
  Csv csv;
  std::ifstream in(path);
  std::string line;
  if (!std::getline(in, line)) return csv;
  std::stringstream header(line);
  for (std::string c; std::getline(header, c, ',');) csv.columns.push_back(c);
  while (std::getline(in, line)) {
    std::stringstream ls(line);
    std::vector<double> row;
    for (std::string c; std::getline(ls, c, ',');) row.push_back(std::stod(c));
    csv.rows.push_back(row);
  }
  return csv;
}

inline std::string write_temp_scene(const std::string& name, const std::string& text) {
  const auto p = std::filesystem::temp_directory_path() / ("softhom-scene-" + name + ".toml");
  std::ofstream(p) << text;
  return p.string();
}

}  // namespace softhom::test
