#pragma once
// The material-point run of a scene, shared by `softhom point` and `softhom demo`.
#include <filesystem>

#include "scene_source.hpp"
#include "softhom/materials/driver.hpp"

namespace softhom::app {

struct PointRun {
  PointRunResult result;
};

/// Runs [material] + [load] (+ optional [solver]) of the scene and writes OUT/response.csv and
/// OUT/summary.json (also when the run stops early: the converged rows are kept).
PointRun run_point_scene(const LoadedScene& scene, const std::filesystem::path& out, bool quiet);

}  // namespace softhom::app
