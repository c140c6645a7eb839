#pragma once
// The [device] table of macro scenes (declared once in device_keys.cpp).
#include <toml++/toml.h>

#include "softhom/core/keys.hpp"
#include "softhom/macro/devices.hpp"

namespace softhom::macro {

const keys::KeyTable<DeviceSpec>& device_table();
/// Reads [device] (absent: kind none).
DeviceSpec read_device(const toml::node* node);

}  // namespace softhom::macro
