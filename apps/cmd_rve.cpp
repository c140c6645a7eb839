#include "commands.hpp"
#include <iostream>
namespace softhom::app {
int run_rve(const CommandOptions&) { std::cerr << "softhom: 'rve' is not available yet in this version\n"; return 3; }
}  // namespace softhom::app
