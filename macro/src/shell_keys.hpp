#pragma once
// Scene keys of shell structures (shell_keys.cpp): [geometry] type = "shell" and the [shell] table.
#include <filesystem>
#include <string>
#include <vector>

#include <toml++/toml.h>

#include "softhom/core/keys.hpp"
#include "softhom/macro/structures.hpp"

namespace softhom::macro {

// Scenes are in mm. A structure larger than 1 km is a unit mistake; beyond it the generators'
// coordinates lose all digits (outer_radius = 1e300 produced empty surfaces, not an error).
inline const keys::Range kLength = keys::left_open(0.0, 1e6);
// Cells along one direction; the total mesh size is bounded where the mesh is generated.
inline const keys::Range kCells = keys::closed_range(1, 100000);

/// Reads [geometry] (type = "shell") and the [shell] table into s (kind, surface, section, frame, edges);
/// shape "gmsh" reads its mesh (a .geo meshed into mesh_cache first), relative to scene_file.
void read_shell(const toml::table& scene, const toml::table& geometry, StructureSpec& s, const std::filesystem::path& scene_file,
                const std::filesystem::path& mesh_cache);
/// The declared tables, for `softhom keys macro` and docs/keys.md.
std::vector<keys::TableDoc> shell_scene_tables();
/// The keys of [geometry] for type = "shell" (messages naming which types a key belongs to).
std::vector<std::string> shell_geometry_key_names();

}  // namespace softhom::macro
