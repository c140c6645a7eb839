#include "softhom/io/key_checks.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>

#include "softhom/io/scene.hpp"
#include "softhom/materials/errors.hpp"

namespace softhom::io {
namespace {

std::string join(const std::string& path, const std::string& key) { return path.empty() ? key : path + "." + key; }

std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> prev(b.size() + 1), cur(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) prev[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    cur[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j)
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1)});
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = char(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

std::string bound_text(double v) {
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  return format_number(v);
}

}  // namespace

std::string printable(std::string_view text) {
  std::string out;
  for (unsigned char c : text) {
    if (c < 0x20 || c == 0x7f) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02x", unsigned(c));
      out += buf;
    } else {
      out += char(c);
    }
  }
  return out;
}

std::string nearest_key(std::string_view key, const KeyTableDoc& decl) {
  std::string best;
  std::size_t best_d = 3;
  for (const KeyRow& r : decl.rows) {
    const std::size_t d = lower(key) == lower(r.name) ? 0 : edit_distance(key, r.name);
    if (d < best_d) {
      best_d = d;
      best = r.name;
    }
  }
  return best;
}

void check_declared(const toml::table& table, const std::string& path, const KeyTableDoc& decl) {
  for (const auto& [k, node] : table) {
    const std::string key(k.str());
    if (std::any_of(decl.rows.begin(), decl.rows.end(), [&](const KeyRow& r) { return r.name == key; })) continue;
    for (const RenamedKey& r : decl.renamed)
      if (r.old_name == key) throw InputError(join(path, printable(key)), describe_value(node), "renamed to " + r.new_name);
    std::string list;
    for (const KeyRow& r : decl.rows) list += (list.empty() ? "" : ", ") + r.name;
    const std::string near = nearest_key(key, decl);
    throw InputError(join(path, printable(key)), describe_value(node),
                     "unknown key" + (near.empty() ? std::string() : " (did you mean " + near + "?)") + " (allowed: " +
                         list + ")");
  }
}

std::string interval_text(double min, double max, bool open_min, bool open_max) {
  if (std::isinf(max) && max > 0) return std::string(open_min ? "> " : ">= ") + bound_text(min);
  if (std::isinf(min) && min < 0) return std::string(open_max ? "< " : "<= ") + bound_text(max);
  return std::string(open_min ? "(" : "[") + bound_text(min) + ", " + bound_text(max) + (open_max ? ")" : "]");
}

std::int64_t get_integer_in(const toml::table& table, const std::string& key, const std::string& path,
                            std::int64_t fallback, std::int64_t min, std::int64_t max) {
  const toml::node* node = table.get(key);
  if (!node) return fallback;
  const std::string field = join(path, key);
  const std::string range = "[" + std::to_string(min) + ", " + std::to_string(max) + "]";
  std::int64_t v = 0;
  if (const auto i = node->value_exact<std::int64_t>()) {
    v = *i;
  } else if (const auto d = node->value_exact<double>()) {
    // 2.0 is accepted as 2; 2.5, nan and 1e300 are not (a cast of those is undefined or wrong).
    if (!std::isfinite(*d) || *d != std::floor(*d) || std::abs(*d) > 9e15)
      throw InputError(field, describe_value(*node), "must be a whole number in " + range);
    v = std::int64_t(*d);
  } else {
    throw InputError(field, describe_value(*node), "must be a whole number in " + range);
  }
  if (v < min || v > max) throw InputError(field, describe_value(*node), "must be a whole number in " + range);
  return v;
}

int get_int_in(const toml::table& table, const std::string& key, const std::string& path, int fallback, int min,
               int max) {
  return int(get_integer_in(table, key, path, fallback, min, max));
}

double require_number_in(const toml::table& table, const std::string& key, const std::string& path, double min,
                         double max, bool open_min, bool open_max) {
  const double v = get_number(table, key, path);  // refuses wrong types, NaN and infinities
  const bool ok = (open_min ? v > min : v >= min) && (open_max ? v < max : v <= max);
  if (!ok) throw InputError(join(path, key), format_number(v), "must lie in " + interval_text(min, max, open_min, open_max));
  return v;
}

double get_number_in(const toml::table& table, const std::string& key, const std::string& path, double fallback,
                     double min, double max, bool open_min, bool open_max) {
  if (!table.contains(key)) return fallback;
  return require_number_in(table, key, path, min, max, open_min, open_max);
}

std::string get_choice(const toml::table& table, const std::string& key, const std::string& path,
                       const std::string& fallback, const std::vector<std::string>& choices) {
  const std::string v = get_string_or(table, key, path, fallback);
  if (std::find(choices.begin(), choices.end(), v) != choices.end()) return v;
  std::string list;
  for (const auto& c : choices) list += (list.empty() ? "" : ", ") + c;
  std::string hint;
  std::string alt = v;
  std::replace(alt.begin(), alt.end(), '_', '-');
  if (alt != v && std::find(choices.begin(), choices.end(), alt) != choices.end()) hint = " (renamed to " + alt + ")";
  throw InputError(join(path, key), v.empty() ? "\"\"" : printable(v), "expected " + list + hint);
}

}  // namespace softhom::io
