#pragma once
// The [contact] table of macro scenes (declared once in contact_keys.cpp).
#include <vector>

#include <toml++/toml.h>

#include "softhom/core/keys.hpp"
#include "softhom/macro/contact.hpp"

namespace softhom::macro {

/// Reads [contact] (absent: no obstacles).
ContactSpec read_contact(const toml::node* node);
/// Its tables for `softhom keys macro` and docs/keys.md.
std::vector<keys::TableDoc> contact_tables();

}  // namespace softhom::macro
