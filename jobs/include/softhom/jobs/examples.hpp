#pragma once
// The shipped examples (scenes, devices, campaigns, calibrations with their data, meshes, Python
// scripts and plot scripts) as installed under share/softhom/examples, found from the program or the
// Python module wherever it runs, and copied into a directory of the user's (`softhom examples`).
#include <filesystem>
#include <string>
#include <vector>

namespace softhom::jobs {

struct Example {
  std::string name;             ///< "scenes/rve_ecoflex_circ45": category/stem
  std::filesystem::path file;   ///< relative to the examples directory
  std::string description;      ///< its description key or first comment line
};

/// The examples directory: $SOFTHOM_EXAMPLES when set, else `extra` (the Python module's own guess),
/// else share/softhom/examples next to the running program, else the one staged in the build directory
/// (a build that is not installed). Empty when none exists.
std::filesystem::path examples_directory(const std::filesystem::path& extra = {});

/// Every example under `root`, by category then name.
std::vector<Example> list_examples(const std::filesystem::path& root);

/// Copies the example `name` ("rve_ecoflex_circ45", "scenes/rve_ecoflex_circ45", a file name, or "all")
/// with the files it names (meshes, curve data), keeping the layout below `root`, into `dir` (created).
/// An existing file with other contents is not overwritten (InputError naming it); returns the copied
/// paths relative to `dir`. An unknown name is an InputError listing close names.
std::vector<std::filesystem::path> copy_example(const std::filesystem::path& root, const std::string& name,
                                                const std::filesystem::path& dir);

}  // namespace softhom::jobs
