// summary.json: run metadata shared by every subcommand.
#include "softhom/io/summary.hpp"

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <ctime>
#include <sstream>
#include <stdexcept>

#include <omp.h>

#include "softhom/io/files.hpp"
#include "softhom/materials/interrupt.hpp"

#include <csignal>

namespace softhom::io {

std::string softhom_version() { return SOFTHOM_VERSION; }

namespace {

std::string utc_iso8601(std::time_t time) {
  std::tm tm{};
  gmtime_r(&time, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

// nlohmann writes NaN/Inf as `null`, which would silently turn a failed result into "no value":
// refuse instead, naming where the number sits (JSON pointer syntax).
void check_finite(const nlohmann::json& j, const std::string& where) {
  if (j.is_number_float() && !std::isfinite(j.get<double>()))
    throw std::invalid_argument("summary.json: non-finite number at '" + (where.empty() ? "/" : where) + "'");
  if (j.is_object()) {
    for (const auto& [key, value] : j.items()) check_finite(value, where + "/" + key);
  } else if (j.is_array()) {
    for (std::size_t i = 0; i < j.size(); ++i) check_finite(j[i], where + "/" + std::to_string(i));
  }
}

// The run's start: the program's load until mark_run_started() says otherwise. A summary is written at
// the end of a run, so "now" there would be the end (hours later on a large cell).
std::atomic<std::time_t> run_start{std::time(nullptr)};

}  // namespace

void mark_run_started() { run_start.store(std::time(nullptr)); }

std::string run_started_utc() { return utc_iso8601(run_start.load()); }

nlohmann::json summary_base(const std::string& command, const std::filesystem::path& scene_file,
                            const toml::table& scene) {
  // toml++'s JSON formatter quotes dates, times, inf and nan, so its output is always valid JSON.
  std::ostringstream scene_json;
  scene_json << toml::json_formatter{scene};
  nlohmann::json j;
  j["softhom_version"] = softhom_version();
  j["command"] = command;
  j["scene_file"] = scene_file.string();
  j["scene"] = nlohmann::json::parse(scene_json.str());
  j["threads"] = omp_get_max_threads();  // what the OpenMP solvers will use (honours OMP_NUM_THREADS)
  // How waiting threads wait (the program sets passive unless the user chose): "" = OpenMP's default.
  const char* wait_policy = std::getenv("OMP_WAIT_POLICY");
  j["omp_wait_policy"] = wait_policy ? wait_policy : "";
  j["started_utc"] = run_started_utc();
  return j;
}

std::string run_status(bool completed) {
  if (completed) return "completed";
  return stop_requested() ? "interrupted" : "stopped";
}

std::string signal_name(int signal) {
  switch (signal) {
    case SIGTERM: return "SIGTERM";
    case SIGINT: return "SIGINT";
    case SIGHUP: return "SIGHUP";
    case SIGQUIT: return "SIGQUIT";
    default: return "signal " + std::to_string(signal);
  }
}

void set_run_status(nlohmann::json& summary, bool completed, const std::string& error) {
  summary["status"] = run_status(completed);
  summary["completed"] = completed;
  summary["error"] = error;
  if (!completed && stop_requested() && stop_signal() > 0) summary["signal"] = signal_name(stop_signal());
}

nlohmann::json columns_json(const std::vector<std::string>& columns) {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& c : columns) {
    const ColumnInfo info = column_info(c);
    j[c] = {{"unit", info.unit}, {"description", info.description}};
  }
  return j;
}

void write_summary(const std::filesystem::path& dir, const nlohmann::json& summary) {
  check_finite(summary, "");
  // Invalid UTF-8 (e.g. from a file name) is replaced rather than failing the whole summary.
  write_file_atomic(dir / "summary.json",
                    summary.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
}

}  // namespace softhom::io
