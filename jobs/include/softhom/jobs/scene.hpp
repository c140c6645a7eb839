#pragma once
// Where a job's scene comes from: a file, TOML text or a table built in memory, or an embedded
// default (studies/scenes/*.toml compiled into the library).
#include <filesystem>
#include <map>
#include <string>

#include <toml++/toml.h>

namespace softhom::jobs {

struct LoadedScene {
  toml::table table;
  std::filesystem::path file;  ///< empty for an embedded or in-memory scene
  std::string name;            ///< file stem or embedded name
};

/// The scene file `file` (io::load_scene: InputError naming the file on a TOML error).
LoadedScene load_scene_file(const std::filesystem::path& file);
/// `file` if given, else the embedded scene `default_name` (a studies/scenes stem).
LoadedScene load_scene_or_default(const std::filesystem::path& file, const std::string& default_name);

/// studies/scenes/*.toml by file stem.
const std::map<std::string, std::string>& embedded_scenes();
/// The embedded scene a subcommand runs without a scene file ("" when it needs one).
std::string default_scene_name(const std::string& command);

}  // namespace softhom::jobs
