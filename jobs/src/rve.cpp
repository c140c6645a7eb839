// softhom rve: the scene parsed once into the job of its engine (FFT or FE), the engine choice of
// engine = "auto" applied to the parsed values, and the run dispatched to the engine's job.
#include <atomic>
#include <iostream>

#include <omp.h>

#include "rve_jobs.hpp"
#include "softhom/jobs/thread_defaults.hpp"
#include "softhom/io/scene.hpp"
#include "softhom/core/mpi.hpp"
#include "softhom/jobs/run_control.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/materials/plausibility.hpp"

namespace softhom::jobs {
namespace {

std::atomic<std::size_t> parses{0};

FeRveJob parse_fe_job(const toml::table& scene, bool microstructure_only) {
  FeRveJob job;
  static_cast<studies::FeRveSetup&>(job) = studies::parse_fe_rve_setup(scene, !microstructure_only);
  job.output = studies::parse_rve_output(scene, microstructure_only ? nullptr : &job.control);
  return job;
}

/// Plausibility of the matrix and fiber moduli (materials/plausibility.hpp).
std::vector<std::string> phase_warnings(const RveJob& job) {
  MaterialPtr matrix, fiber;
  if (const auto* fe = std::get_if<FeRveJob>(&job.engine)) {
    matrix = fe->phases.matrix;
    if (fe->phases.has_fiber) fiber = fe->phases.fiber;
  } else {
    matrix = std::get<FftRveJob>(job.engine).setup.matrix;
    fiber = std::get<FftRveJob>(job.engine).setup.fiber;
  }
  std::vector<std::string> w = matrix ? plausibility_warnings(*matrix, MaterialRole::matrix, "phases.matrix")
                                      : std::vector<std::string>{};
  if (fiber)
    for (auto& f : plausibility_warnings(*fiber, MaterialRole::fiber, "phases.fiber")) w.push_back(std::move(f));
  return w;
}

}  // namespace

EngineRequest engine_request(const toml::table& scene) {
  const toml::table* solver = scene["solver"].as_table();
  const toml::table* micro = scene["microstructure"].as_table();
  if (!solver || !micro) throw InputError("solver.engine", "auto", "needs [microstructure] and [solver] tables");
  if (!solver->contains("target_error"))
    throw InputError("solver.target_error", "", "engine = \"auto\" needs target_error (relative error of the homogenized stress)");
  EngineRequest r;
  r.target_error = keys::read_number(*solver->get("target_error"), "solver.target_error", keys::open_range(0.0, 0.5));
  if (micro->contains("grid") || solver->contains("mesh_size"))
    throw InputError("solver.target_error", format_number(r.target_error),
                     "give either target_error (engine = \"auto\") or a resolution (grid / mesh_size), not both");
  const studies::RvePhases phases = studies::parse_rve_phases(scene);
  if (!phases.has_fiber) throw InputError("phases.fiber", "", "missing");
  r.matrix_bulk_to_shear = phases.matrix->initial_bulk_modulus() / phases.matrix->initial_shear_modulus();
  r.shear_contrast = phases.fiber->initial_shear_modulus() / phases.matrix->initial_shear_modulus();
  double target_vf = 0.0;
  std::string note;
  const rve::Section section = studies::parse_fe_section(*micro, target_vf, note);
  r.L1 = section.L1;
  r.L2 = section.L2;
  return r;
}

toml::table resolved_scene(const toml::table& scene, const EngineResolution& resolution) {
  toml::table resolved = scene;
  toml::table& solver = *resolved["solver"].as_table();
  solver.erase("target_error");
  if (resolution.engine == RveEngine::fft) {
    solver.erase("engine");
    resolved["microstructure"].as_table()->insert_or_assign("grid", toml::array{resolution.grid[0], resolution.grid[1]});
  } else {
    solver.insert_or_assign("engine", "fe");
    solver.insert_or_assign("mesh_size", resolution.mesh_size);
    solver.insert_or_assign("interface_size", resolution.interface_size);
  }
  return resolved;
}

RveJob parse_rve(LoadedScene scene, const RveParseOptions& options) {
  ++parses;
  RveJob job;
  job.resume = options.resume;
  RveEngine engine = RveEngine::fft;
  if (const std::string e = studies::rve_scene_engine(scene.table); e == "auto") {
    job.resolution = choose_engine(engine_request(scene.table));
    scene.table = resolved_scene(scene.table, *job.resolution);
    engine = job.resolution->engine;
  } else if (e == "fe") {
    engine = RveEngine::fe;
  }
  if (engine == RveEngine::fe && options.resume)
    throw InputError("--resume", "", "continues runs of the FFT engine only (solver.engine = \"fe\" writes no checkpoint)");
  // [load] is parsed only when the run needs it (unknown tables are refused by the scene parser).
  job.microstructure_only = studies::parse_rve_output(scene.table, nullptr).microstructure_only;
  if (engine == RveEngine::fe) {
    job.engine = parse_fe_job(scene.table, job.microstructure_only);
  } else {
    if (job.microstructure_only && options.resume)
      throw InputError("--resume", "", "output.microstructure_only runs no load path, there is nothing to continue");
    // A 3D cell under an MPI launcher: each rank builds and holds only its slab of the phase image.
    const bool with_load = !job.microstructure_only;
    job.engine = FftRveJob{studies::parse_rve_scene(scene.table, with_load, options.out, with_load)};
  }
  job.warnings = phase_warnings(job);
  job.scene = std::move(scene);
  return job;
}

std::size_t rve_scene_parses() { return parses.load(); }

bool run_rve(RveJob& job, Sink& sink, const RunOptions& options) {
  if (job.resolution && !options.quiet) std::cerr << "softhom rve: " << job.resolution->why << "\n";
  print_warnings("softhom rve", job.warnings, options.quiet || mpi::world_rank() != 0);
  if (auto* fe = std::get_if<FeRveJob>(&job.engine)) return run_fe_rve(job, *fe, sink, options);
  FftRveJob& fft = std::get<FftRveJob>(job.engine);
  // Without a thread count from the user, a small cell runs on fewer threads (thread_defaults.hpp); the
  // voxels are this rank's (a slab under MPI).
  const std::size_t voxels = fft.setup.image.owned_voxels();
  const ThreadCountScope threads(thread_count_given(options.threads)
                                     ? 0
                                     : default_thread_count(voxels, kVoxelsPerDefaultThread, omp_get_max_threads()));
  return run_fft_rve(job, fft, sink, options);
}

}  // namespace softhom::jobs
