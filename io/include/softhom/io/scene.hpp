#pragma once
// Scene files (TOML) → descriptions the libraries understand. Field names in errors are the TOML
// paths ("material.G", "load.stretch[2]", ...).
#include <filesystem>
#include <string>

#include <toml++/toml.h>

#include "softhom/io/keys.hpp"

#include "softhom/materials/library.hpp"
#include "softhom/materials/loading.hpp"

namespace softhom::io {

/// Parses a file; a syntax error becomes an InputError with line and column.
toml::table load_scene(const std::filesystem::path& path);
/// Parses TOML text (for embedded default scenes).
toml::table parse_scene(std::string_view text, const std::string& source_name);

/// A material table:
///   preset = "ecoflex-anisotropic"            # optional, spec §6 names
///   law = "gent" | "neo-hookean" | "yeoh" | "ogden"
///   G, Jm, K | mu, K | E, nu | C1, C2, C3, K | mu = [...], alpha = [...], K
///   fiber_invariant = "full" | "isochoric"   # required when fibers are present
///   tension_only = true
///   [[<path>.fibers]] direction = [x, y, z] | angle_deg = α (in the 1–2 plane, spec §7: from e2 toward e1)
///                     k1, k2 (default: the preset's)
///   [<path>.viscoelastic] g_inf = 0.5, terms = [{g = 0.5, tau = 1.0}]
/// Unknown keys are errors (a typo must not silently fall back to a default).
MaterialSpec parse_material(const toml::table& table, const std::string& path);

/// A load table:
///   type = "uniaxial" | "equibiaxial" | "pure_shear" | "simple_shear" | "mixed"
///   direction = [1, 0, 0], in_plane = [0, 1, 0]          # load frame (uniaxial), default e1, e2
///   stretch = [[t0, λ0], [t1, λ1], ...]  or  stretch = λ with duration = T (linear ramp from 1)
///   gamma = ... (simple shear)
///   steps = N  (uniform output steps over the path)   or   dt = Δt
///   mixed: F = [[...9 entries or "free"...]] and P = [[...]] per component
MixedControl parse_load(const toml::table& table, const std::string& path);


/// Helpers for the other parsers (number with field name in the error, optional default).
double get_number(const toml::table& table, const std::string& key, const std::string& path);
double get_number_or(const toml::table& table, const std::string& key, const std::string& path, double fallback);
std::string get_string_or(const toml::table& table, const std::string& key, const std::string& path,
                          const std::string& fallback);
/// Refuses keys not in `allowed` with an InputError naming path.key.
bool get_bool_or(const toml::table& table, const std::string& key, const std::string& path, bool fallback);
void check_keys(const toml::table& table, const std::string& path, std::initializer_list<std::string_view> allowed);

}  // namespace softhom::io
