#include "commands.hpp"
#include <iostream>
namespace softhom::app {
int run_sweep(const CommandOptions&) { std::cerr << "softhom: 'sweep' is not available yet in this version\n"; return 3; }
}  // namespace softhom::app
