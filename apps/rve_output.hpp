#pragma once
// Output pieces shared by the two RVE engines' commands (cmd_rve.cpp: FFT, cmd_rve_fe.cpp: FE), so that
// both write the same [output] semantics and the same summary.json step log.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <toml++/toml.h>

#include "softhom/io/files.hpp"
#include "softhom/io/scene.hpp"
#include "softhom/io/summary.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/rve/fft_solver.hpp"
#include "softhom/studies/rve_scene.hpp"

namespace softhom::app {

/// The [output] table of an RVE scene, declared with the scene's other keys (studies/rve_scene.hpp).
using studies::RveOutputSettings;
using studies::parse_rve_output;

/// One entry of summary.json "steps".
inline nlohmann::json rve_step_log_entry(const rve::RveStep& s) {
  return {{"t", s.t},
          {"newton_iterations", s.newton_iterations},
          {"krylov_iterations", s.krylov_iterations},
          {"substeps", s.substeps},
          {"cutbacks", s.cutbacks},
          {"shifted_solves", s.shifted_solves},
          {"minres_solves", s.minres_solves},
          {"continuation_iterations", s.continuation_iterations},
          {"residuals", s.residuals},
          {"wall_time_s", s.wall_seconds}};
}

/// The run-result keys of summary.json common to both engines; writes summary.json (atomically) and,
/// when the run stopped early, says so on stderr. Returns whether the run completed.
inline bool finish_rve_summary(nlohmann::json& summary, const rve::RveRunResult& result, const nlohmann::json& step_log,
                               std::size_t solver_memory_bytes, const std::filesystem::path& out,
                               std::chrono::steady_clock::time_point wall_start) {
  summary["completed"] = result.completed;
  summary["error"] = result.error;
  summary["steps"] = step_log;
  summary["newton_iterations"] = result.total_newton_iterations;
  summary["krylov_iterations"] = result.total_krylov_iterations;
  summary["cutbacks"] = result.cutbacks;
  summary["warnings"] = result.log;
  summary["solver_memory_bytes"] = solver_memory_bytes;
  summary["peak_memory_bytes"] = io::peak_memory_bytes();
  summary["solve_time_s"] = result.wall_seconds;
  summary["wall_time_s"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  io::write_summary(out, summary);
  if (!result.completed)
    std::cerr << "softhom rve: stopped early: " << result.error << "\nsofthom rve: " << result.steps.size()
              << " converged rows kept in " << (out / "response.csv").string() << "\n";
  return result.completed;
}

}  // namespace softhom::app
