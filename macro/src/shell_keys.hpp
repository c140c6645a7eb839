#pragma once
// Scene keys of shell structures (shell_keys.cpp): [geometry] type = "shell" and the [shell] table.
#include <string>
#include <vector>

#include <toml++/toml.h>

#include "softhom/core/keys.hpp"
#include "softhom/macro/structures.hpp"

namespace softhom::macro {

/// Reads [geometry] (type = "shell") and the [shell] table into s (kind, surface, section, frame, edges).
void read_shell(const toml::table& scene, const toml::table& geometry, StructureSpec& s);
/// The declared tables, for `softhom keys macro` and docs/keys.md.
std::vector<keys::TableDoc> shell_scene_tables();
/// The keys of [geometry] for type = "shell" (messages naming which types a key belongs to).
std::vector<std::string> shell_geometry_key_names();

}  // namespace softhom::macro
