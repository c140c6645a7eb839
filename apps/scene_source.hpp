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

}  // namespace softhom::app
