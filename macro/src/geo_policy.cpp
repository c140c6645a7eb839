#include "geo_policy.hpp"

#include <cctype>
#include <vector>

#include "softhom/core/input_error.hpp"

namespace softhom::macro {
namespace {

/// A word of the .geo text outside comments and strings, with its line, or a string literal.
struct Token {
  std::string text;
  int line = 1;
  bool string = false;
};

std::vector<Token> tokenize(const std::string& s) {
  std::vector<Token> out;
  int line = 1;
  for (std::size_t i = 0; i < s.size();) {
    const char c = s[i];
    if (c == '\n') {
      ++line;
      ++i;
    } else if (s.compare(i, 2, "//") == 0) {
      while (i < s.size() && s[i] != '\n') ++i;
    } else if (s.compare(i, 2, "/*") == 0) {
      const std::size_t end = s.find("*/", i + 2);
      for (std::size_t k = i; k < std::min(end, s.size()); ++k) line += s[k] == '\n';
      i = end == std::string::npos ? s.size() : end + 2;
    } else if (c == '"') {
      Token t{"", line, true};
      for (++i; i < s.size() && s[i] != '"'; ++i) {
        if (s[i] == '\\' && i + 1 < s.size()) ++i;
        if (s[i] == '\n') ++line;
        t.text += s[i];
      }
      ++i;
      out.push_back(std::move(t));
    } else if (std::isalpha(static_cast<unsigned char>(c)) || c == '_') {
      Token t{"", line, false};
      while (i < s.size() && (std::isalnum(static_cast<unsigned char>(s[i])) || s[i] == '_')) t.text += s[i++];
      out.push_back(std::move(t));
    } else if (std::isspace(static_cast<unsigned char>(c))) {
      ++i;
    } else {
      out.push_back(Token{std::string(1, c), line, false});
      ++i;
    }
  }
  return out;
}

bool one_of(const std::string& w, std::initializer_list<const char*> words) {
  for (const char* x : words)
    if (w == x) return true;
  return false;
}

// A file name a .geo may read: relative, inside its folder.
bool inside_folder(const std::string& name) {
  if (name.empty() || name[0] == '/' || name[0] == '~') return false;
  const std::filesystem::path p(name);
  for (const auto& part : p)
    if (part == "..") return false;
  return true;
}

}  // namespace

void check_geo_text(const std::string& text, const std::filesystem::path& geo, const std::string& field) {
  const std::vector<Token> tokens = tokenize(text);
  auto refuse = [&](const Token& t, const std::string& why) {
    throw InputError(field, geo.string() + ":" + std::to_string(t.line), "'" + t.text + "' " + why);
  };
  for (std::size_t k = 0; k < tokens.size(); ++k) {
    const Token& t = tokens[k];
    if (t.string) continue;
    if (one_of(t.text, {"System", "SystemCall", "NonBlockingSystemCall", "OnelabRun"}))
      refuse(t, "runs a program; a scene's .geo may only describe geometry and meshing");
    if (one_of(t.text, {"Save", "Print", "CreateDir", "RenameFile", "DeleteFile", "Plugin"}))
      refuse(t, "writes or changes files; a scene's .geo may only describe geometry and meshing (softhom writes the mesh)");
    if (t.text == "Delete" && k + 1 < tokens.size() && tokens[k + 1].text == "File")
      refuse(t, "deletes files; a scene's .geo may only describe geometry and meshing");
    if (one_of(t.text, {"Printf", "Sprintf"})) {
      // Printf(...) > "file" and >> "file" append to a file: find the ';' that ends the statement.
      int depth = 0;
      for (std::size_t j = k + 1; j < tokens.size() && tokens[j].text != ";"; ++j) {
        if (tokens[j].string) continue;
        depth += tokens[j].text == "(" ? 1 : tokens[j].text == ")" ? -1 : 0;
        if (depth == 0 && tokens[j].text == ">") refuse(t, "with '>' writes a file; print to the log instead");
      }
    }
    if (one_of(t.text, {"Include", "Merge", "MergeWithBoundingBox", "ShapeFromFile"})) {
      const bool literal = k + 1 < tokens.size() && tokens[k + 1].string;
      const bool ends = k + 2 >= tokens.size() || tokens[k + 2].text == ";" || tokens[k + 2].text == ")";
      if (!literal || !ends)
        refuse(t, "reads a file named by an expression; name it as a plain string relative to the .geo's folder");
      if (!inside_folder(tokens[k + 1].text))
        refuse(t, "reads '" + tokens[k + 1].text + "' outside the .geo's folder; keep the files it reads next to it");
    }
  }
}

}  // namespace softhom::macro
