// softhom examples (cmd_examples.hpp).
#include "cmd_examples.hpp"

#include <iostream>

#include "softhom/core/input_error.hpp"
#include "softhom/jobs/examples.hpp"

namespace softhom::app {

int run_examples(const std::string& action, const std::string& name, const std::string& dir) {
  const std::filesystem::path root = jobs::examples_directory();
  if (root.empty()) {
    std::cerr << "softhom examples: no examples directory found (share/softhom/examples next to the program); "
                 "set SOFTHOM_EXAMPLES to it\n";
    return 2;
  }
  if (action == "list") {
    std::cout << "Examples in " << root.string() << " (copy one with: softhom examples copy NAME DIR)\n";
    for (const auto& e : jobs::list_examples(root)) {
      std::cout << "  " << e.name;
      // One line per example: the description cut at a word near 80 characters.
      std::string d = e.description;
      if (d.size() > 80) d = d.substr(0, d.find_last_of(" ,;", 77)) + " ...";
      if (!d.empty()) std::cout << std::string(e.name.size() < 40 ? 40 - e.name.size() : 1, ' ') << d;
      std::cout << "\n";
    }
    return 0;
  }
  if (name.empty()) {
    std::cerr << "softhom examples: input error: copy needs NAME (or all) and DIR: softhom examples copy all examples\n";
    return 2;
  }
  try {
    const auto copied = jobs::copy_example(root, name, dir);
    for (const auto& p : copied) std::cout << (std::filesystem::path(dir) / p).string() << "\n";
    if (copied.empty()) std::cout << "softhom examples: " << name << " is already in " << dir << "\n";
  } catch (const InputError& e) {
    std::cerr << "softhom examples: input error: " << e.what() << "\n";
    return 2;
  } catch (const std::filesystem::filesystem_error& e) {
    std::cerr << "softhom examples: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

}  // namespace softhom::app
