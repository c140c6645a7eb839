#pragma once
// The [[fibers]] tables of macro scenes (declared once in fiber_keys.cpp).
#include <toml++/toml.h>

#include <filesystem>

#include "softhom/core/keys.hpp"
#include "softhom/macro/fiber_geometry.hpp"

namespace softhom::macro {

keys::TableDoc fibers_table_doc();
/// Reads [[fibers]] (absent: none). Whether the fibers fit the mesh is checked when they are tied.
std::vector<FiberSpec> read_fibers(const toml::node* node);
/// Reads the polylines of the geometry = "gmsh" fibers from their files (relative to the scene; a .geo
/// meshed into `mesh_cache`), or from `host_mesh`, the structure's own .msh (empty: not a Gmsh mesh).
void read_fiber_curve_groups(std::vector<FiberSpec>& fibers, const std::filesystem::path& scene_file,
                             const std::filesystem::path& host_mesh, const std::filesystem::path& mesh_cache);

}  // namespace softhom::macro
