#pragma once
#include <map>
#include <string>

namespace softhom::app {
/// studies/scenes/*.toml by file stem, compiled into the program.
const std::map<std::string, std::string>& embedded_scenes();
}  // namespace softhom::app
