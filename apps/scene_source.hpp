#pragma once
// Where a command's scene comes from: a file given on the command line, or an embedded default.
#include <filesystem>
#include <string>

#include <toml++/toml.h>

#include "commands.hpp"

namespace softhom::app {

struct LoadedScene {
  toml::table table;
  std::filesystem::path file;  ///< empty for an embedded scene
  std::string name;            ///< file stem or embedded name
};

/// options.scene if given, else the embedded scene `default_name` (a studies/scenes stem).
LoadedScene load_scene_or_default(const CommandOptions& options, const std::string& default_name);

/// `softhom rve` / `softhom macro` on a scene already loaded (options.scene is not read): what the
/// commands run after loading, and what the Python module calls with a scene built in memory.
int run_rve_scene(const CommandOptions& options, LoadedScene scene);
int run_macro_scene(const CommandOptions& options, const LoadedScene& scene);

}  // namespace softhom::app
