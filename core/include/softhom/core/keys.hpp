#pragma once
// Scene-key declarations: one declaration per TOML key (name, type, default, allowed range or choices,
// unit, one-line doc), next to the options struct it fills. The declaration drives reading (typed,
// range-checked, unknown keys refused with "did you mean"), the defaults (taken from the
// default-constructed struct) and the documentation (`softhom keys`, docs/keys.md).
//
//   keys::KeyTable<FftSolverOptions> t("solver", "FFT solver settings");
//   t.number("tolerance", &O::tolerance, keys::open_range(0, 1), "-", "Newton tolerance")
//    .integer("max_cutbacks", &O::max_cutbacks, keys::at_least(0), "-", "step halvings")
//    .choice("scheme", &O::scheme, {{"newton-cg", S::newton_cg}, {"moulinec-suquet", S::fixed}}, "...");
//   O options;
//   t.read(toml_table, "solver", options);   // throws InputError naming "solver.<key>"
//   t.describe();                            // rows for the docs
//
// Only toml++ below this header, so every library can declare its keys.
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include <toml++/toml.h>

#include "softhom/core/input_error.hpp"
#include "softhom/core/key_range.hpp"

namespace softhom::keys {

// ---------------------------------------------------------------------------------------------------
// Messages

/// A TOML value as the user wrote it ("a" for strings, {table}, numbers in shortest round-trip form).
std::string describe_value(const toml::node& node);
/// "path.key" ("key" at the top level).
std::string join_key(const std::string& path, const std::string& key);
/// "field[i]".
std::string index_field(const std::string& field, std::size_t i);
/// Levenshtein distance (for "did you mean").
std::size_t edit_distance(std::string_view a, std::string_view b);
/// " (did you mean 'x'?)" for the closest of `names` within a small edit distance, else "".
std::string did_you_mean(std::string_view key, const std::vector<std::string>& names);

// ---------------------------------------------------------------------------------------------------
// Typed readers of one value; every refusal is an InputError naming `field` and the value as written.

/// A finite number inside `range` (TOML integer or float).
double read_number(const toml::node& node, const std::string& field, const Range& range = {});
/// An integer inside `range` and inside [type_lo, type_hi] (the C++ type's range). A TOML float is
/// accepted only when integral ("1e3"), never truncated.
long long read_integer(const toml::node& node, const std::string& field, const Range& range, long long type_lo,
                       long long type_hi);
template <class Int>
Int read_int(const toml::node& node, const std::string& field, const Range& range = {}) {
  static_assert(std::is_integral_v<Int>);
  using Limits = std::numeric_limits<Int>;
  const long long hi = Limits::max() > static_cast<unsigned long long>(std::numeric_limits<long long>::max())
                           ? std::numeric_limits<long long>::max()
                           : static_cast<long long>(Limits::max());
  return static_cast<Int>(read_integer(node, field, range, static_cast<long long>(Limits::min()), hi));
}
bool read_flag(const toml::node& node, const std::string& field);
/// A string without NUL or control characters.
std::string read_text(const toml::node& node, const std::string& field);
const toml::table& read_table(const toml::node& node, const std::string& field);
const toml::array& read_array(const toml::node& node, const std::string& field);
/// A list of numbers (entries checked as field[i]), `min_size..max_size` long; `scalar_ok`: a bare
/// number is a list of one.
std::vector<double> read_numbers(const toml::node& node, const std::string& field, const Range& range = {},
                                 std::size_t min_size = 0, std::size_t max_size = std::size_t(-1),
                                 bool scalar_ok = false);
template <class Int>
std::vector<Int> read_ints(const toml::node& node, const std::string& field, const Range& range = {},
                           std::size_t min_size = 0, std::size_t max_size = std::size_t(-1), bool scalar_ok = false);

/// A named choice (with old spellings refused as "renamed to ...").
template <class E>
struct Choices {
  std::vector<std::pair<std::string, E>> values;
  std::vector<std::pair<std::string, std::string>> renamed;  ///< {old, new}
  /// "a, b or c".
  std::string names() const;
  std::string name_of(E value) const;
};
template <class E>
E read_choice(const toml::node& node, const std::string& field, const Choices<E>& choices);

// ---------------------------------------------------------------------------------------------------
// Documentation rows

struct KeyDoc {
  std::string name;           ///< "tolerance", "fibers" (a sub-table), ...
  std::string type;           ///< "number", "integer", "true/false", "string", "choice", "list of numbers", ...
  std::string default_value;  ///< as it would be written in TOML, or a sentence ("required", "from the preset")
  std::string range;          ///< "(0, 1)", "\"a\", \"b\"", ...
  std::string unit;           ///< "MPa", "-", "s", ""
  std::string doc;            ///< one line
  std::vector<std::string> renamed_from;  ///< old spellings, refused with "renamed to"
};
struct TableDoc {
  std::string path;  ///< "solver", "phases.<name>", "material.fibers[]", ...
  std::string doc;
  std::vector<KeyDoc> keys;
};

/// A scene kind's tables, for `softhom keys`: {"point", point_scene_tables()}, ...
struct SceneKeys {
  std::string command;  ///< the subcommand whose scene these tables make up ("point", "rve", ...)
  std::string doc;
  std::vector<TableDoc> tables;
};
/// Plain-text listing (one block per table, one line per key).
std::string format_keys_text(const SceneKeys& scene);
/// Markdown (a section per scene, a table per TOML table) for docs/keys.md.
std::string format_keys_markdown(const std::vector<SceneKeys>& scenes);

// ---------------------------------------------------------------------------------------------------
// A declared table bound to an options struct

template <class Options>
class KeyTable {
 public:
  /// Reads the key's value into the options (field: full TOML path of the key).
  using Apply = std::function<void(const toml::node& node, const std::string& field, Options& options)>;
  /// The default, as TOML text, from a default-constructed Options.
  using Show = std::function<std::string(const Options& defaults)>;

  KeyTable(std::string path, std::string doc) : path_(std::move(path)), doc_(std::move(doc)) {}

  const std::string& path() const { return path_; }

  KeyTable& number(std::string name, double Options::*member, Range range, std::string unit, std::string doc) {
    return add({std::move(name), "number", {}, range.describe(), std::move(unit), std::move(doc), {}},
               [member, range](const toml::node& n, const std::string& f, Options& o) { o.*member = read_number(n, f, range); },
               [member](const Options& o) { return format_number(o.*member); });
  }
  /// An unset-by-default number (std::optional<double>).
  KeyTable& number(std::string name, std::optional<double> Options::*member, Range range, std::string unit,
                   std::string doc) {
    return add({std::move(name), "number", {}, range.describe(), std::move(unit), std::move(doc), {}},
               [member, range](const toml::node& n, const std::string& f, Options& o) { o.*member = read_number(n, f, range); },
               [member](const Options& o) { return (o.*member) ? format_number(*(o.*member)) : std::string("unset"); });
  }
  template <class Int>
  KeyTable& integer(std::string name, Int Options::*member, Range range, std::string unit, std::string doc) {
    static_assert(std::is_integral_v<Int> && !std::is_same_v<Int, bool>);
    return add({std::move(name), "integer", {}, range.describe(), std::move(unit), std::move(doc), {}},
               [member, range](const toml::node& n, const std::string& f, Options& o) { o.*member = read_int<Int>(n, f, range); },
               [member](const Options& o) { return std::to_string(o.*member); });
  }
  KeyTable& flag(std::string name, bool Options::*member, std::string doc) {
    return add({std::move(name), "true/false", {}, "", "", std::move(doc), {}},
               [member](const toml::node& n, const std::string& f, Options& o) { o.*member = read_flag(n, f); },
               [member](const Options& o) { return std::string(o.*member ? "true" : "false"); });
  }
  KeyTable& text(std::string name, std::string Options::*member, std::string doc) {
    return add({std::move(name), "string", {}, "", "", std::move(doc), {}},
               [member](const toml::node& n, const std::string& f, Options& o) { o.*member = read_text(n, f); },
               [member](const Options& o) { return quoted(o.*member); });
  }
  template <class E>
  KeyTable& choice(std::string name, E Options::*member, Choices<E> choices, std::string doc) {
    std::vector<std::string> old;
    for (const auto& r : choices.renamed) old.push_back("\"" + r.first + "\" → \"" + r.second + "\"");
    std::string range;
    for (const auto& [label, value] : choices.values) range += (range.empty() ? "" : ", ") + quoted(label);
    auto shared = std::make_shared<Choices<E>>(std::move(choices));
    KeyDoc d{std::move(name), "choice", {}, range, "", std::move(doc), {}};
    add(std::move(d),
        [member, shared](const toml::node& n, const std::string& f, Options& o) { o.*member = read_choice(n, f, *shared); },
        [member, shared](const Options& o) { return quoted(shared->name_of(o.*member)); });
    entries_.back().renamed_values = std::move(old);
    return *this;
  }
  /// A choice without old spellings: choice("scheme", &O::scheme, {{"newton-cg", S::newton_cg}, ...}, "doc").
  template <class E>
  KeyTable& choice(std::string name, E Options::*member, std::vector<std::pair<std::string, E>> values, std::string doc) {
    return choice(std::move(name), member, Choices<E>{std::move(values), {}}, std::move(doc));
  }
  KeyTable& numbers(std::string name, std::vector<double> Options::*member, Range range, std::size_t min_size,
                    std::size_t max_size, std::string unit, std::string doc) {
    return add({std::move(name), "list of numbers", {}, list_range(range, min_size, max_size), std::move(unit), std::move(doc), {}},
               [=](const toml::node& n, const std::string& f, Options& o) {
                 o.*member = read_numbers(n, f, range, min_size, max_size);
               },
               [member](const Options& o) { return list_text(o.*member); });
  }
  template <class Int>
  KeyTable& integers(std::string name, std::vector<Int> Options::*member, Range range, std::size_t min_size,
                     std::size_t max_size, std::string unit, std::string doc) {
    return add({std::move(name), "list of integers", {}, list_range(range, min_size, max_size), std::move(unit), std::move(doc), {}},
               [=](const toml::node& n, const std::string& f, Options& o) {
                 o.*member = read_ints<Int>(n, f, range, min_size, max_size);
               },
               [member](const Options& o) { return list_text(o.*member); });
  }
  /// Anything else (sub-tables, unions like "number or [x, y, z]", values with cross-checks): the
  /// handler reads the node; `default_text` documents the default.
  KeyTable& custom(std::string name, std::string type, std::string doc, Apply handler, std::string default_text = "",
                   std::string range = "", std::string unit = "") {
    const std::string def = default_text;
    return add({std::move(name), std::move(type), {}, std::move(range), std::move(unit), std::move(doc), {}},
               std::move(handler), [def](const Options&) { return def; });
  }
  /// The last declared key must be present.
  KeyTable& required() {
    entries_.back().required = true;
    entries_.back().show = [](const Options&) { return std::string("required"); };
    return *this;
  }
  /// Overrides the documented default of the last declared key ("from the preset", "= width", ...).
  KeyTable& default_text(std::string text) {
    entries_.back().show = [text](const Options&) { return text; };
    return *this;
  }
  /// An old spelling of the last declared key: refused with "renamed to <name>".
  KeyTable& renamed(std::string old_name) {
    entries_.back().doc.renamed_from.push_back(std::move(old_name));
    return *this;
  }
  /// Every key of `sub` (bound to a member struct) as a key of this table.
  template <class Sub>
  KeyTable& include(const KeyTable<Sub>& sub, Sub Options::*member) {
    static const Sub defaults{};  // built once per table type
    for (const auto& e : sub.entries()) {
      Entry copy;
      copy.doc = e.doc;
      copy.required = e.required;
      copy.renamed_values = e.renamed_values;
      auto apply = e.apply;
      copy.apply = [apply, member](const toml::node& n, const std::string& f, Options& o) { apply(n, f, o.*member); };
      const std::string def = e.show(defaults);
      copy.show = [def](const Options&) { return def; };
      entries_.push_back(std::move(copy));
    }
    return *this;
  }

  /// Reads every key of `table` (path: its TOML path, "" at the top level) into `options`; keys not
  /// given keep the options' values. Returns the keys present. Unknown keys, old spellings, wrong
  /// types and out-of-range values throw InputError naming path.key.
  std::set<std::string> read(const toml::table& table, const std::string& path, Options& options) const {
    std::set<std::string> present;
    for (const auto& [key, node] : table) {
      const std::string name(key.str());
      const Entry* e = find(name);
      if (!e) refuse_unknown(name, node, path);
      e->apply(node, join_key(path, name), options);
      present.insert(name);
    }
    for (const auto& e : entries_)
      if (e.required && !present.count(e.doc.name)) throw InputError(join_key(path, e.doc.name), "", "missing: " + e.doc.doc);
    return present;
  }
  /// Reads only the declared keys of `table` and skips the others (a table whose keys several
  /// declarations share; the caller refuses what none of them declares). No required-key check.
  std::set<std::string> read_declared(const toml::table& table, const std::string& path, Options& options) const {
    std::set<std::string> present;
    for (const auto& [key, node] : table) {
      const std::string name(key.str());
      if (const Entry* e = find(name)) {
        e->apply(node, join_key(path, name), options);
        present.insert(name);
      }
    }
    return present;
  }
  /// Same, for an optional table: absent (null) keeps the options; a non-table is refused.
  std::set<std::string> read_optional(const toml::node* node, const std::string& path, Options& options) const {
    if (!node) {
      for (const auto& e : entries_)
        if (e.required) throw InputError(join_key(path, e.doc.name), "", "missing: " + e.doc.doc);
      return {};
    }
    return read(read_table(*node, path), path, options);
  }

  /// Documentation rows; defaults printed from a default-constructed Options.
  TableDoc describe() const {
    static const Options defaults{};  // built once per table type
    TableDoc t{path_, doc_, {}};
    for (const auto& e : entries_) {
      KeyDoc d = e.doc;
      d.default_value = e.show(defaults);
      for (const auto& r : e.renamed_values) d.renamed_from.push_back(r);
      t.keys.push_back(std::move(d));
    }
    return t;
  }
  std::vector<std::string> names() const {
    std::vector<std::string> out;
    for (const auto& e : entries_) out.push_back(e.doc.name);
    return out;
  }
  bool declares(const std::string& name) const { return find(name) != nullptr; }

  struct Entry {
    KeyDoc doc;
    Apply apply;
    Show show;
    bool required = false;
    std::vector<std::string> renamed_values;
  };
  const std::vector<Entry>& entries() const { return entries_; }

 private:
  static std::string quoted(const std::string& s) { return "\"" + s + "\""; }
  static std::string list_range(const Range& r, std::size_t lo, std::size_t hi) {
    std::string s;
    if (lo == hi) s = std::to_string(lo) + " entries";
    else if (hi == std::size_t(-1)) s = lo ? "at least " + std::to_string(lo) + " entries" : "";
    else s = std::to_string(lo) + "-" + std::to_string(hi) + " entries";
    const std::string each = r.describe();
    if (!each.empty()) s += (s.empty() ? "each " : ", each ") + each;
    return s;
  }
  template <class T>
  static std::string list_text(const std::vector<T>& v) {
    std::string s = "[";
    for (std::size_t i = 0; i < v.size(); ++i) {
      if (i) s += ", ";
      if constexpr (std::is_floating_point_v<T>) s += format_number(v[i]);
      else s += std::to_string(v[i]);
    }
    return s + "]";
  }
  KeyTable& add(KeyDoc doc, Apply apply, Show show) {
    if (find(doc.name)) throw std::logic_error("key declared twice: " + join_key(path_, doc.name));
    entries_.push_back({std::move(doc), std::move(apply), std::move(show), false, {}});
    return *this;
  }
  const Entry* find(const std::string& name) const {
    for (const auto& e : entries_)
      if (e.doc.name == name) return &e;
    return nullptr;
  }
  [[noreturn]] void refuse_unknown(const std::string& name, const toml::node& node, const std::string& path) const {
    for (const auto& e : entries_)
      for (const auto& old : e.doc.renamed_from)
        if (old == name) throw InputError(join_key(path, name), describe_value(node), "renamed to " + join_key(path, e.doc.name));
    throw InputError(join_key(path, name), describe_value(node), "unknown key" + did_you_mean(name, names()));
  }

  std::string path_, doc_;
  std::vector<Entry> entries_;
};

// ---------------------------------------------------------------------------------------------------
// Template implementations

template <class Int>
std::vector<Int> read_ints(const toml::node& node, const std::string& field, const Range& range, std::size_t min_size,
                           std::size_t max_size, bool scalar_ok) {
  std::vector<Int> out;
  if (scalar_ok && !node.is_array()) {
    out.push_back(read_int<Int>(node, field, range));
  } else {
    const toml::array& a = read_array(node, field);
    for (std::size_t i = 0; i < a.size(); ++i) out.push_back(read_int<Int>(*a.get(i), index_field(field, i), range));
  }
  if (out.size() < min_size || out.size() > max_size) {
    const std::string want = min_size == max_size ? std::to_string(min_size)
                             : max_size == std::size_t(-1)
                                 ? "at least " + std::to_string(min_size)
                                 : std::to_string(min_size) + " to " + std::to_string(max_size);
    throw InputError(field, describe_value(node), "must be a list of " + want + " integers");
  }
  return out;
}

template <class E>
std::string Choices<E>::names() const {
  std::string s;
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (i) s += i + 1 == values.size() ? " or " : ", ";
    s += "\"" + values[i].first + "\"";
  }
  return s;
}

template <class E>
std::string Choices<E>::name_of(E value) const {
  for (const auto& [label, v] : values)
    if (v == value) return label;
  return "?";
}

template <class E>
E read_choice(const toml::node& node, const std::string& field, const Choices<E>& choices) {
  const std::string s = read_text(node, field);
  for (const auto& [label, value] : choices.values)
    if (label == s) return value;
  for (const auto& [old, now] : choices.renamed)
    if (old == s) throw InputError(field, describe_value(node), "renamed to \"" + now + "\"");
  std::vector<std::string> labels;
  for (const auto& v : choices.values) labels.push_back(v.first);
  throw InputError(field, describe_value(node), "must be " + choices.names() + did_you_mean(s, labels));
}

}  // namespace softhom::keys
