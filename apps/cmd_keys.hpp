#pragma once
// `softhom keys [COMMAND] [--markdown]`: every table and key of a subcommand's scene (name, type,
// default, allowed values, unit, meaning), from the key declarations; and `--print-default`.
#include <string>
#include <vector>

#include "softhom/core/keys.hpp"

namespace softhom::app {

/// The registry: one entry per subcommand that reads a scene, in the order of `softhom keys all`.
/// Each library returns the descriptions of its tables (point_scene_tables(),
/// studies::rve_scene_tables(), ...); a subcommand whose tables are not declared yet has none.
std::vector<keys::SceneKeys> scene_key_registry();

/// Prints the tables of `command` ("all": every subcommand) as text or Markdown; an unknown command
/// is an InputError.
int run_keys(const std::string& command, bool markdown);

/// Writes the embedded scene of `command` (jobs::default_scene_name) to stdout (InputError when the subcommand has none).
int print_default_scene(const std::string& command);

}  // namespace softhom::app
