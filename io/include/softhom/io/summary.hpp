#pragma once
// summary.json: run metadata common to every subcommand (version, command, scene echo, wall time,
// warnings), to which each command adds its own fields.
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <toml++/toml.h>

namespace softhom::io {

std::string softhom_version();

/// Records now as the start of the run ("started_utc" of its summary). Until it is called, the start is
/// the time the program (or the Python module) was loaded.
void mark_run_started();
/// The start of the run, as "YYYY-MM-DDTHH:MM:SSZ".
std::string run_started_utc();

/// {"softhom_version", "command", "scene_file", "scene": <scene as JSON>, "threads", "started_utc"}.
nlohmann::json summary_base(const std::string& command, const std::filesystem::path& scene_file,
                            const toml::table& scene);
/// How a run ended, as summary.json says it: "completed"; "interrupted" (SIGINT/SIGTERM or
/// request_stop(), materials/interrupt.hpp; the converged rows are kept); "stopped" (the solver could
/// not go on: locking, cut-backs exhausted, wall-time budget; the converged rows are kept).
std::string run_status(bool completed);
/// Sets "status" (run_status), "completed", "error" and, when interrupted by a signal, "signal"
/// ("SIGTERM", "SIGINT").
void set_run_status(nlohmann::json& summary, bool completed, const std::string& error);
/// {"COLUMN": {"unit", "description"}, …} for the columns of a response.csv (io::column_info).
nlohmann::json columns_json(const std::vector<std::string>& columns);
/// "SIGTERM", "SIGINT", … ("signal N" for others).
std::string signal_name(int signal);
/// Writes DIR/summary.json atomically (pretty-printed).
void write_summary(const std::filesystem::path& dir, const nlohmann::json& summary);

}  // namespace softhom::io
