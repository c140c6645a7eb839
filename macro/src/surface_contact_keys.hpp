#pragma once
// The [[contact.pairs]] and [[contact.self]] tables of macro scenes (declared once in
// surface_contact_keys.cpp).
#include <vector>

#include <toml++/toml.h>

#include "softhom/core/keys.hpp"
#include "softhom/macro/surface_contact.hpp"

namespace softhom::macro {

/// Reads contact.pairs and contact.self of the [contact] table (each absent: none).
std::vector<SurfacePairSpec> read_surface_contacts(const toml::table& contact);
/// Their tables for `softhom keys macro` and docs/keys.md.
std::vector<keys::TableDoc> surface_contact_tables();

}  // namespace softhom::macro
