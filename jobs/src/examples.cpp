// The shipped examples and their copies (examples.hpp).
#include "softhom/jobs/examples.hpp"

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <regex>
#include <set>
#include <sstream>

#include "softhom/core/input_error.hpp"

namespace softhom::jobs {

namespace fs = std::filesystem;

namespace {

// The folders of the examples directory that hold examples (the studies/ layout, with the Python
// examples in python/), and the top-level plot scripts.
const std::vector<std::string> kCategories{"scenes", "devices", "campaigns", "calibrations", "python"};

bool is_example_file(const fs::path& p) { return p.extension() == ".toml" || p.extension() == ".py"; }

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// The `description = "..."` of a scene, else its first comment line; a script's first docstring line.
std::string describe(const fs::path& file) {
  std::istringstream in(read_text(file));
  std::string line, comment;
  static const std::regex description(R"(^description\s*=\s*"(.*)\"\s*$)");
  std::smatch m;
  while (std::getline(in, line)) {
    if (std::regex_match(line, m, description)) return m[1];
    if (comment.empty() && line.rfind("\"\"\"", 0) == 0) comment = line.substr(3);
    if (comment.empty() && line.rfind("# ", 0) == 0 && line.find("softhom ") == std::string::npos) comment = line.substr(2);
  }
  if (const auto end = comment.find("\"\"\""); end != std::string::npos) comment.resize(end);
  return comment;
}

std::string category_of(const fs::path& relative) {
  const fs::path parent = relative.parent_path();
  return parent.empty() ? "plots" : parent.begin()->string();
}

/// The files a scene names with a relative path that exists below `root` (meshes, curves, base scenes).
std::vector<fs::path> named_files(const fs::path& root, const fs::path& relative) {
  std::vector<fs::path> out;
  static const std::regex quoted(R"re("([^"\n]+\.(toml|csv|geo|msh|h5))")re");
  const std::string text = read_text(root / relative);
  for (std::sregex_iterator it(text.begin(), text.end(), quoted), end; it != end; ++it) {
    const fs::path named((*it)[1].str());
    if (named.is_absolute()) continue;
    std::error_code ec;
    const fs::path target = fs::weakly_canonical(root / relative.parent_path() / named, ec);
    const fs::path base = fs::weakly_canonical(root, ec);
    const fs::path inside = target.lexically_relative(base);
    if (ec || inside.empty() || *inside.begin() == ".." || !fs::is_regular_file(target, ec)) continue;
    out.push_back(inside);
  }
  return out;
}

void copy_one(const fs::path& root, const fs::path& relative, const fs::path& dir, std::vector<fs::path>& copied) {
  const fs::path target = dir / relative;
  std::error_code ec;
  if (fs::exists(target, ec)) {
    if (read_text(target) == read_text(root / relative)) return;
    throw InputError("DIR", target.string(), "exists with other contents: remove it or copy into another directory");
  }
  fs::create_directories(target.parent_path());
  fs::copy_file(root / relative, target);
  copied.push_back(relative);
}

std::string close_names(const std::vector<Example>& all, const std::string& name) {
  std::string s;
  int shown = 0;
  for (const auto& e : all) {
    const std::string stem = e.file.stem().string();
    if (shown < 8 && (stem.find(name) != std::string::npos || name.find(stem.substr(0, 4)) != std::string::npos)) {
      s += (shown++ ? ", " : "") + e.name;
    }
  }
  return s.empty() ? "see 'softhom examples list'" : "did you mean: " + s;
}

}  // namespace

fs::path examples_directory(const fs::path& extra) {
  std::vector<fs::path> candidates;
  if (const char* env = std::getenv("SOFTHOM_EXAMPLES")) candidates.emplace_back(env);
  if (!extra.empty()) candidates.push_back(extra);
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) candidates.push_back(exe.parent_path() / ".." / "share" / "softhom" / "examples");
#ifdef SOFTHOM_BUILD_EXAMPLES
  candidates.emplace_back(SOFTHOM_BUILD_EXAMPLES);
#endif
  for (const auto& c : candidates)
    if (fs::is_directory(c / "scenes", ec)) return fs::weakly_canonical(c, ec);
  return {};
}

std::vector<Example> list_examples(const fs::path& root) {
  std::vector<Example> out;
  std::error_code ec;
  auto add = [&](const fs::path& relative) {
    const std::string category = category_of(relative);
    out.push_back({category + "/" + relative.stem().string(), relative, describe(root / relative)});
  };
  for (const std::string& category : kCategories) {
    const fs::path folder = category;
    std::vector<fs::path> files;
    for (const auto& entry : fs::directory_iterator(root / folder, ec))
      if (entry.is_regular_file() && is_example_file(entry.path())) files.push_back(folder / entry.path().filename());
    std::sort(files.begin(), files.end());
    for (const auto& f : files) add(f);
  }
  std::vector<fs::path> plots;
  for (const auto& entry : fs::directory_iterator(root, ec))
    if (entry.is_regular_file() && entry.path().extension() == ".py") plots.push_back(entry.path().filename());
  std::sort(plots.begin(), plots.end());
  for (const auto& f : plots) add(f);
  return out;
}

std::vector<fs::path> copy_example(const fs::path& root, const std::string& name, const fs::path& dir) {
  const std::vector<Example> all = list_examples(root);
  std::vector<fs::path> chosen;
  for (const auto& e : all)
    if (name == "all" || name == e.name || name == e.file.stem().string() || name == e.file.filename().string() ||
        name == e.file.string())
      chosen.push_back(e.file);
  if (chosen.empty()) throw InputError("NAME", name, "is no example (" + close_names(all, name) + ")");
  if (name != "all" && chosen.size() > 1) chosen.resize(1);
  std::vector<fs::path> copied;
  std::set<fs::path> done;
  while (!chosen.empty()) {
    const fs::path f = chosen.back();
    chosen.pop_back();
    if (!done.insert(f).second) continue;
    copy_one(root, f, dir, copied);
    if (f.extension() == ".toml")
      for (const auto& named : named_files(root, f)) chosen.push_back(named);
  }
  // Copying all takes every mesh and curve file too (a .geo for the user's own scenes).
  std::error_code ec;
  if (name == "all")
    for (const fs::path& data : {fs::path("meshes"), fs::path("calibrations") / "data"})
      for (const auto& entry : fs::directory_iterator(root / data, ec))
        if (const fs::path rel = data / entry.path().filename(); entry.is_regular_file() && done.insert(rel).second)
          copy_one(root, rel, dir, copied);
  std::sort(copied.begin(), copied.end());
  return copied;
}

}  // namespace softhom::jobs
