#pragma once
// Scene files (TOML) → descriptions the libraries understand. Field names in errors are the TOML
// paths ("material.G", "load.stretch[2]", ...).
#include <filesystem>
#include <string>

#include <toml++/toml.h>

#include "softhom/core/keys.hpp"

#include "softhom/materials/library.hpp"
#include "softhom/materials/loading.hpp"
#include "softhom/materials/scene_keys.hpp"

namespace softhom::io {

/// Parses a file read through the checked opener (read_input_file, kSceneFile: a regular text file of at
/// most 4 MiB); a file that is none names `field` ("scene", "base_scene"), a syntax error becomes an
/// InputError with line and column.
toml::table load_scene(const std::filesystem::path& path, const std::string& field = "scene");
/// Parses TOML text (for embedded default scenes).
toml::table parse_scene(std::string_view text, const std::string& source_name);

/// Material and load tables are declared and parsed in the materials library (scene_keys.hpp); these
/// names keep the parsers' old spelling for the front ends.
using softhom::parse_material;
using softhom::parse_load;

/// Helpers of the parsers not yet declared key by key (prefer keys::KeyTable, keys.hpp).
double get_number(const toml::table& table, const std::string& key, const std::string& path);
double get_number_or(const toml::table& table, const std::string& key, const std::string& path, double fallback);
std::string get_string_or(const toml::table& table, const std::string& key, const std::string& path,
                          const std::string& fallback);
/// Refuses keys not in `allowed` with an InputError naming path.key.
bool get_bool_or(const toml::table& table, const std::string& key, const std::string& path, bool fallback);
void check_keys(const toml::table& table, const std::string& path, std::initializer_list<std::string_view> allowed);

}  // namespace softhom::io
