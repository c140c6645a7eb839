#pragma once
// Helpers the studies tests share: a fresh working directory per test process, and a campaign expanded
// from scene text.
#include <filesystem>
#include <string>

#include <unistd.h>

#include "softhom/io/scene.hpp"
#include "softhom/studies/campaign.hpp"

namespace softhom::studies::testing {

/// An empty directory under the system's temporary directory, named after the test and this process
/// (ctest runs tests in parallel processes).
inline std::filesystem::path fresh_dir(const std::string& name) {
  const auto d = std::filesystem::temp_directory_path() /
                 ("softhom_test_studies_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(d);
  std::filesystem::create_directories(d);
  return d;
}

/// The campaign a scene text defines (relative paths against the temporary directory).
inline Campaign expand(const std::string& text) {
  return expand_campaign(io::parse_scene(text, "<test>"), std::filesystem::temp_directory_path());
}

}  // namespace softhom::studies::testing
