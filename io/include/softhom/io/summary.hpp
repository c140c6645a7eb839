#pragma once
// summary.json: run metadata common to every subcommand (version, command, scene echo, wall time,
// warnings), to which each command adds its own fields.
#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>
#include <toml++/toml.h>

namespace softhom::io {

std::string softhom_version();

/// {"softhom_version", "command", "scene_file", "scene": <scene as JSON>, "threads", "started_utc"}.
nlohmann::json summary_base(const std::string& command, const std::filesystem::path& scene_file,
                            const toml::table& scene);
/// Writes DIR/summary.json atomically (pretty-printed).
void write_summary(const std::filesystem::path& dir, const nlohmann::json& summary);

}  // namespace softhom::io
