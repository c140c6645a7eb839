#pragma once
// `softhom rve` on the FE engine ([solver] engine = "fe"), dispatched from cmd_rve.cpp.
#include "commands.hpp"
#include "scene_source.hpp"

namespace softhom::app {

int run_rve_fe(const CommandOptions& options, const LoadedScene& scene);

/// [solver] engine = "auto" with target_error: picks the cheaper engine and resolution for the requested
/// relative error of the homogenized stress (rules from the engine benchmark in BENCHMARKS.md), writes
/// the choice into the scene table (solver.engine / mesh sizes, or microstructure.grid) and returns
/// "fe" or "fft" with a one-line explanation in `why`.
std::string choose_engine(toml::table& scene, std::string& why);

}  // namespace softhom::app
