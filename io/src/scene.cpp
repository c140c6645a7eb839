#include "softhom/io/scene.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <set>
#include <sstream>

#include "softhom/io/files.hpp"
#include "softhom/materials/errors.hpp"

namespace softhom::io {
namespace {

std::string join(const std::string& path, const std::string& key) { return path.empty() ? key : path + "." + key; }

}  // namespace

namespace {

std::string show(const toml::node& node) { return keys::describe_value(node); }

double as_number(const toml::node& node, const std::string& field) {
  if (auto v = node.value<double>()) {
    if (!std::isfinite(*v)) throw InputError(field, show(node), "must be a finite number");
    return *v;
  }
  throw InputError(field, show(node), "must be a number");
}

}  // namespace

toml::table parse_scene(std::string_view text, const std::string& source_name) {
  try {
    return toml::parse(text, source_name);
  } catch (const toml::parse_error& e) {
    std::ostringstream s;
    s << "line " << e.source().begin.line << ", column " << e.source().begin.column;
    throw InputError(source_name, s.str(), std::string("TOML syntax error: ") + std::string(e.description()));
  }
}

toml::table load_scene(const std::filesystem::path& path, const std::string& field) {
  const std::string text = read_input_file(path, field, kSceneFile);
  try {
    return toml::parse(text, path.string());
  } catch (const toml::parse_error& e) {
    std::ostringstream s;
    s << "line " << e.source().begin.line << ", column " << e.source().begin.column;
    throw InputError(path.string(), s.str(), std::string("TOML syntax error: ") + std::string(e.description()));
  }
}

double get_number(const toml::table& table, const std::string& key, const std::string& path) {
  const toml::node* node = table.get(key);
  if (!node) throw InputError(join(path, key), "", "missing");
  return as_number(*node, join(path, key));
}

double get_number_or(const toml::table& table, const std::string& key, const std::string& path, double fallback) {
  return table.contains(key) ? get_number(table, key, path) : fallback;
}

std::string get_string_or(const toml::table& table, const std::string& key, const std::string& path,
                          const std::string& fallback) {
  const toml::node* node = table.get(key);
  if (!node) return fallback;
  if (auto s = node->value<std::string>()) return *s;
  throw InputError(join(path, key), show(*node), "must be a string");
}

bool get_bool_or(const toml::table& table, const std::string& key, const std::string& path, bool fallback) {
  const toml::node* node = table.get(key);
  if (!node) return fallback;
  if (const auto* b = node->as_boolean()) return b->get();  // exactly a boolean: 1 or "yes" is refused
  throw InputError(join(path, key), show(*node), "must be true or false");
}

void check_keys(const toml::table& table, const std::string& path, std::initializer_list<std::string_view> allowed) {
  for (const auto& [key, node] : table) {
    if (std::find(allowed.begin(), allowed.end(), key.str()) == allowed.end()) {
      std::string list;
      for (auto a : allowed) list += (list.empty() ? "" : ", ") + std::string(a);
      throw InputError(join(path, std::string(key.str())), show(node), "unknown key (allowed: " + list + ")");
    }
  }
}

}  // namespace softhom::io
