#pragma once
// The [[fibers]] tables of macro scenes (declared once in fiber_keys.cpp).
#include <toml++/toml.h>

#include "softhom/core/keys.hpp"
#include "softhom/macro/fiber_geometry.hpp"

namespace softhom::macro {

keys::TableDoc fibers_table_doc();
/// Reads [[fibers]] (absent: none). Whether the fibers fit the mesh is checked when they are tied.
std::vector<FiberSpec> read_fibers(const toml::node* node);

}  // namespace softhom::macro
