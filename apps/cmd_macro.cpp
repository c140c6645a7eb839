#include "commands.hpp"
#include <iostream>
namespace softhom::app {
int run_macro(const CommandOptions&) { std::cerr << "softhom: 'macro' is not available yet in this version\n"; return 3; }
}  // namespace softhom::app
