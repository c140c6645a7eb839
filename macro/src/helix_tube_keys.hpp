#pragma once
// The [helix_tube] table of macro scenes (declared once in helix_tube_keys.cpp).
#include <toml++/toml.h>

#include "softhom/core/keys.hpp"
#include "softhom/macro/helix_tube.hpp"

namespace softhom::macro {

const keys::KeyTable<HelixTubeSpec>& helix_tube_table();
/// Reads and checks [helix_tube] (check_helix_tube).
HelixTubeSpec read_helix_tube(const toml::node& node);

}  // namespace softhom::macro
