#include "softhom/core/keys.hpp"

#include <algorithm>
#include <sstream>

namespace softhom::keys {

std::string describe_value(const toml::node& node) {
  std::ostringstream s;
  node.visit([&s](const auto& n) {
    using T = std::decay_t<decltype(n)>;
    if constexpr (std::is_same_v<T, toml::value<std::string>>) {
      s << '"';
      for (unsigned char c : n.get()) {
        if (c < 0x20 || c == 0x7f) {
          const char* hex = "0123456789abcdef";
          s << "\\x" << hex[c >> 4] << hex[c & 15];
        } else {
          s << char(c);
        }
      }
      s << '"';
    } else if constexpr (std::is_same_v<T, toml::value<double>>) {
      s << format_number(n.get());
    } else if constexpr (std::is_same_v<T, toml::table>) {
      s << "{table}";
    } else if constexpr (std::is_same_v<T, toml::array>) {
      s << '[';
      for (std::size_t i = 0; i < n.size(); ++i) s << (i ? ", " : "") << describe_value(*n.get(i));
      s << ']';
    } else {
      s << n;
    }
  });
  return s.str();
}

std::string join_key(const std::string& path, const std::string& key) { return path.empty() ? key : path + "." + key; }

std::string index_field(const std::string& field, std::size_t i) { return field + "[" + std::to_string(i) + "]"; }

std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

std::string did_you_mean(std::string_view key, const std::vector<std::string>& names) {
  // A suggestion within a third of the name's length (at least 2 edits): close enough to be a typo.
  std::size_t best = std::size_t(-1);
  std::string best_name;
  for (const auto& n : names) {
    const std::size_t d = edit_distance(key, n);
    if (d < best) best = d, best_name = n;
  }
  const std::size_t limit = std::max<std::size_t>(2, key.size() / 3);
  if (best_name.empty() || best > limit) return "";
  return " (did you mean '" + best_name + "'?)";
}

// --- Ranges ---------------------------------------------------------------------------------------

bool Range::contains(double x) const {
  if (lo && (lo_open ? !(x > *lo) : !(x >= *lo))) return false;
  if (hi && (hi_open ? !(x < *hi) : !(x <= *hi))) return false;
  return true;
}

std::string Range::describe() const {
  if (lo && hi) return std::string(lo_open ? "(" : "[") + format_number(*lo) + ", " + format_number(*hi) + (hi_open ? ")" : "]");
  if (lo) return std::string(lo_open ? "> " : ">= ") + format_number(*lo);
  if (hi) return std::string(hi_open ? "< " : "<= ") + format_number(*hi);
  return "";
}

Range any_value() { return {}; }
Range open_range(double lo, double hi) { return {lo, hi, true, true}; }
Range closed_range(double lo, double hi) { return {lo, hi, false, false}; }
Range left_open(double lo, double hi) { return {lo, hi, true, false}; }
Range right_open(double lo, double hi) { return {lo, hi, false, true}; }
Range at_least(double lo) { return {lo, std::nullopt, false, false}; }
Range above(double lo) { return {lo, std::nullopt, true, false}; }
Range at_most(double hi) { return {std::nullopt, hi, false, false}; }

namespace {

std::string range_reason(const Range& r) {
  const std::string d = r.describe();
  if (r.lo && r.hi) return "must lie in " + d;
  return "must be " + d;
}

}  // namespace

// --- Readers --------------------------------------------------------------------------------------

double read_number(const toml::node& node, const std::string& field, const Range& range) {
  std::optional<double> v;
  if (const auto* i = node.as_integer()) v = double(i->get());
  else if (const auto* f = node.as_floating_point()) v = f->get();
  if (!v) throw InputError(field, describe_value(node), "must be a number");
  if (!std::isfinite(*v)) throw InputError(field, describe_value(node), "must be a finite number");
  if (!range.contains(*v)) throw InputError(field, describe_value(node), range_reason(range));
  return *v;
}

long long read_integer(const toml::node& node, const std::string& field, const Range& range, long long type_lo,
                       long long type_hi) {
  long long v = 0;
  if (const auto* i = node.as_integer()) {
    v = i->get();
  } else if (const auto* f = node.as_floating_point()) {
    const double x = f->get();
    // An integral float inside long long's range ("1e3"); anything else is refused, never truncated.
    if (!std::isfinite(x) || x != std::floor(x)) throw InputError(field, describe_value(node), "must be a whole number");
    if (!(x >= -9.2e18 && x <= 9.2e18))
      throw InputError(field, describe_value(node), "must be a whole number from " + std::to_string(type_lo) + " to " + std::to_string(type_hi));
    v = static_cast<long long>(x);
  } else {
    throw InputError(field, describe_value(node), "must be a whole number");
  }
  // The declared range first (its message is the one the user needs), then the C++ type's.
  if (!range.contains(double(v))) throw InputError(field, describe_value(node), range_reason(range));
  if (v < type_lo || v > type_hi)
    throw InputError(field, describe_value(node), "must be a whole number from " + std::to_string(type_lo) + " to " + std::to_string(type_hi));
  return v;
}

bool read_flag(const toml::node& node, const std::string& field) {
  if (const auto* b = node.as_boolean()) return b->get();
  throw InputError(field, describe_value(node), "must be true or false");
}

std::string read_text(const toml::node& node, const std::string& field) {
  const auto* s = node.as_string();
  if (!s) throw InputError(field, describe_value(node), "must be a string");
  for (unsigned char c : s->get())
    if (c < 0x20 || c == 0x7f) throw InputError(field, describe_value(node), "must not contain NUL or control characters");
  return s->get();
}

const toml::table& read_table(const toml::node& node, const std::string& field) {
  if (const auto* t = node.as_table()) return *t;
  throw InputError(field, describe_value(node), "must be a table");
}

const toml::array& read_array(const toml::node& node, const std::string& field) {
  if (const auto* a = node.as_array()) return *a;
  throw InputError(field, describe_value(node), "must be a list [...]");
}

std::vector<double> read_numbers(const toml::node& node, const std::string& field, const Range& range,
                                 std::size_t min_size, std::size_t max_size, bool scalar_ok) {
  std::vector<double> out;
  if (scalar_ok && !node.is_array()) {
    out.push_back(read_number(node, field, range));
  } else {
    const toml::array& a = read_array(node, field);
    for (std::size_t i = 0; i < a.size(); ++i) out.push_back(read_number(*a.get(i), index_field(field, i), range));
  }
  if (out.size() < min_size || out.size() > max_size) {
    const std::string want = min_size == max_size ? std::to_string(min_size)
                             : max_size == std::size_t(-1)
                                 ? "at least " + std::to_string(min_size)
                                 : std::to_string(min_size) + " to " + std::to_string(max_size);
    throw InputError(field, describe_value(node), "must be a list of " + want + " numbers");
  }
  return out;
}

// --- Documentation -------------------------------------------------------------------------------

namespace {

std::string renamed_note(const KeyDoc& k) {
  if (k.renamed_from.empty()) return "";
  std::string s = " (old spelling";
  s += k.renamed_from.size() > 1 ? "s " : " ";
  for (std::size_t i = 0; i < k.renamed_from.size(); ++i) s += (i ? ", " : "") + k.renamed_from[i];
  return s + " refused)";
}

/// Markdown table cells: '|' would end the cell.
std::string cell(const std::string& s) {
  std::string out;
  for (char c : s) out += c == '|' ? std::string("\\|") : std::string(1, c);
  return out;
}

}  // namespace

std::string format_keys_text(const SceneKeys& scene) {
  std::ostringstream s;
  s << "softhom " << scene.command << ": " << scene.doc << "\n";
  for (const auto& t : scene.tables) {
    s << "\n[" << t.path << "]  " << t.doc << "\n";
    for (const auto& k : t.keys) {
      s << "  " << k.name << " (" << k.type;
      if (!k.unit.empty() && k.unit != "-") s << ", " << k.unit;
      s << ") = " << k.default_value;
      if (!k.range.empty()) s << "  in " << k.range;
      s << "\n      " << k.doc << renamed_note(k) << "\n";
    }
  }
  return s.str();
}

std::string format_keys_markdown(const std::vector<SceneKeys>& scenes) {
  std::ostringstream s;
  s << "# Scene keys\n\n"
       "Generated by `softhom keys --markdown all` from the key declarations in the sources; do not edit\n"
       "by hand (a test regenerates this file and fails when it differs). Every key is typed and range\n"
       "checked: a value of the wrong type, out of range, an unknown key or an old spelling is refused\n"
       "with the TOML path of the field (exit status 2), never replaced by the default.\n";
  for (const auto& scene : scenes) {
    s << "\n## softhom " << scene.command << "\n\n" << scene.doc << "\n";
    if (scene.tables.empty()) s << "\n(No tables declared yet.)\n";
    for (const auto& t : scene.tables) {
      s << "\n### [" << t.path << "]\n\n" << t.doc << "\n\n";
      s << "| key | type | default | allowed | unit | meaning |\n|---|---|---|---|---|---|\n";
      for (const auto& k : t.keys)
        s << "| `" << k.name << "` | " << cell(k.type) << " | " << cell(k.default_value) << " | " << cell(k.range) << " | "
          << cell(k.unit) << " | " << cell(k.doc + renamed_note(k)) << " |\n";
    }
  }
  return s.str();
}

}  // namespace softhom::keys
