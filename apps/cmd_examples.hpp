#pragma once
// `softhom examples list` and `softhom examples copy NAME|all [DIR]`: the shipped scenes, devices,
// campaigns, calibrations, Python and plot scripts, copied where the user runs them.
#include <string>

namespace softhom::app {

/// Prints every example with its description (action "list") or copies NAME into DIR ("copy").
/// Returns the exit code: 2 (message on stderr) for an unknown name or when no examples are found.
int run_examples(const std::string& action, const std::string& name, const std::string& dir);

}  // namespace softhom::app
