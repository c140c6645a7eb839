#pragma once
// Declared scene keys: one row per key (type, default, range, unit, doc) from which the allowed-key
// check, typed reads with ranges and the reference tables are all derived. Wrong types are refused
// (plane_strain = "yes" is not false), integers are read as integers with a range before any cast,
// renamed keys say their new name, unknown keys suggest the nearest declared one.
#include <cstdint>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include <toml++/toml.h>

namespace softhom::io {

/// One declared key of a table.
struct KeyRow {
  std::string name;
  std::string type;          ///< "number", "integer", "flag", "string", "choice", "table", "array", ...
  std::string default_text;  ///< as a user would write it; empty: required or no default
  std::string range;         ///< "(0, 1)", ">= 0", "hex8 | tet10", ...
  std::string unit;          ///< "mm", "MPa", "s", "" (dimensionless)
  std::string doc;
};

/// A key that was renamed: its old spelling is refused with "renamed to <new>".
struct RenamedKey {
  std::string old_name, new_name;
};

/// A table's declaration: its TOML path (with "<name>" or "[i]" for repeated tables), the rows, and
/// keys it refuses with their new name.
struct KeyTableDoc {
  std::string path;
  std::string doc;
  std::vector<KeyRow> rows;
  std::vector<RenamedKey> renamed;
};

/// Refuses keys of `table` that `decl` does not declare: renamed keys name their new spelling,
/// others list the declared keys and suggest the nearest one.
void check_declared(const toml::table& table, const std::string& path, const KeyTableDoc& decl);

/// The declared key nearest to `key` (edit distance at most 2 or a case-insensitive match), or "".
std::string nearest_key(std::string_view key, const KeyTableDoc& decl);

/// An integer key (a TOML integer, or a float with an integral value) within [min, max].
std::int64_t get_integer_in(const toml::table& table, const std::string& key, const std::string& path,
                            std::int64_t fallback, std::int64_t min, std::int64_t max);
int get_int_in(const toml::table& table, const std::string& key, const std::string& path, int fallback, int min,
               int max);

/// A finite number within an interval; `open_min`/`open_max` make the bound strict. The message names
/// the interval ("must lie in (0, 1)").
double get_number_in(const toml::table& table, const std::string& key, const std::string& path, double fallback,
                     double min, double max, bool open_min = false, bool open_max = false);
/// Same for a required key.
double require_number_in(const toml::table& table, const std::string& key, const std::string& path, double min,
                         double max, bool open_min = false, bool open_max = false);

/// A string that must be one of `choices`; a wrong type or an unknown choice is an InputError.
std::string get_choice(const toml::table& table, const std::string& key, const std::string& path,
                       const std::string& fallback, const std::vector<std::string>& choices);

/// Interval text for messages: "(0, 1)", "[0, inf)", ...
std::string interval_text(double min, double max, bool open_min, bool open_max);

/// Character text of a key or name for messages: control characters as \xNN.
std::string printable(std::string_view text);

}  // namespace softhom::io
