#pragma once
// The jobs of softhom: every subcommand is parse(scene) → Job → run(job, sink, options). A Job holds
// the scene parsed once into the structures the engines take; run() drives the engine and hands what it
// produces to a Sink (sink.hpp: the program's files, or arrays in memory). The front ends (apps/: the
// command line; python/: the module) only load scenes, choose a sink and map outcomes to exit codes or
// exceptions. Errors in input are InputError; a stop request (a signal, Ctrl-C) ends a run after its
// last converged step, which the sink has received; the run then returns false.
#include <cstddef>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <variant>

#include <nlohmann/json.hpp>

#include "softhom/jobs/engine_choice.hpp"
#include "softhom/jobs/scene.hpp"
#include "softhom/jobs/sink.hpp"
#include "softhom/macro/scene.hpp"
#include "softhom/materials/driver.hpp"
#include "softhom/materials/scene_keys.hpp"
#include "softhom/studies/calibration.hpp"
#include "softhom/studies/campaign.hpp"
#include "softhom/studies/rve_fe_scene.hpp"
#include "softhom/studies/rve_scene.hpp"

namespace softhom::jobs {

/// How a job runs (not what it computes: that is the scene).
struct RunOptions {
  bool quiet = false;          ///< no progress on stderr
  int threads = 0;             ///< OpenMP threads the front end set (0: all); sweep and demo split them between cases
  int jobs = 0;                ///< sweep / demo: cases in parallel (0: one single-threaded job per thread)
  bool retry_failed = false;   ///< sweep: rerun cases stored as failed
  bool no_warm_start = false;  ///< sweep / demo: every case from F = I
  bool dry_run = false;        ///< sweep: list the cases and their state, run nothing
};

// ---- softhom point ---------------------------------------------------------------------------------

struct PointJob {
  LoadedScene scene;
  PointScene parsed;
  MaterialPtr material;
  std::vector<std::string> warnings;  ///< plausibility of the material (softhom/materials/plausibility.hpp)
};
PointJob parse_point(LoadedScene scene);
/// Rows "response" (as the steps converge) and the summary. The result holds the converged steps.
PointRunResult run_point(const PointJob& job, Sink& sink, const RunOptions& options);

// ---- softhom rve -----------------------------------------------------------------------------------

/// The FFT engine's cell, materials, load, [output] and [solver] (studies::parse_rve_scene).
struct FftRveJob {
  studies::RveSceneSetup setup;
};

/// The FE engine's generated section, materials, load, [output] and [solver].
/// The FE engine's setup (shared with the FE cases of `softhom sweep`) and what the run writes.
struct FeRveJob : studies::FeRveSetup {
  studies::RveOutputSettings output;
};

struct RveJob {
  /// The scene as the engine reads it: with engine = "auto", the resolution's grid or mesh sizes in
  /// place of target_error (what summary.json records as "scene"); otherwise the scene as given.
  LoadedScene scene;
  std::optional<EngineResolution> resolution;  ///< engine = "auto" only
  bool microstructure_only = false;            ///< [output] microstructure_only: no load path
  bool resume = false;                         ///< continue the checkpoint in the sink's directory
  std::variant<FftRveJob, FeRveJob> engine;
  std::vector<std::string> warnings;           ///< plausibility of the phases (softhom/materials/plausibility.hpp)
};

struct RveParseOptions {
  std::filesystem::path out;  ///< the run's output directory (solver.fftw_wisdom resolves against it)
  bool resume = false;
};
/// Parses the scene once: the engine (and with "auto" its resolution), then that engine's tables.
/// Under an MPI launcher a 3D FFT cell is parsed as this rank's slab (collective).
RveJob parse_rve(LoadedScene scene, const RveParseOptions& options = {});
/// Rows "response", fields (as [output] asks; FFT cells over MPI ranks: one file from all ranks),
/// checkpoints (FFT engine, sinks with a directory) and the summary. Returns whether the load path
/// completed. The FFT job's per-voxel scene arrays are released once the solver holds its own.
bool run_rve(RveJob& job, Sink& sink, const RunOptions& options);
/// How many scenes parse_rve has parsed in this process (a test counts the parses of a run).
std::size_t rve_scene_parses();

/// [solver] engine = "auto": the inputs of the choice from the scene (target_error, the phases'
/// moduli, the section). InputError when target_error is missing, out of range or given together with
/// a resolution (grid / mesh_size).
EngineRequest engine_request(const toml::table& scene);
/// The scene as the chosen engine reads it: engine and target_error replaced by the resolution
/// (microstructure.grid for the FFT engine; engine = "fe", mesh_size, interface_size for the FE one).
/// The given table is not changed.
toml::table resolved_scene(const toml::table& scene, const EngineResolution& resolution);

// ---- softhom macro ---------------------------------------------------------------------------------

struct MacroJob {
  LoadedScene scene;
  macro::MacroScene parsed;
};
/// `out`: the run's output directory (empty: the user cache) where a geometry.geo is meshed.
MacroJob parse_macro(LoadedScene scene, const std::filesystem::path& out = {});
/// Rows "response" (and "device" for a [device]), fields, the summary (macro_summary). Under an MPI
/// launcher every rank runs; rank 0 alone hands results to the sink. Returns whether it completed.
bool run_macro(MacroJob& job, Sink& sink, const RunOptions& options);

// ---- softhom sweep ---------------------------------------------------------------------------------

struct SweepJob {
  std::filesystem::path file;  ///< the campaign file
  toml::table table;
  studies::Campaign campaign;
};
SweepJob parse_sweep(const std::filesystem::path& file);
/// The store (campaign.h5, cases.csv) in the sink's directory and the summary. Returns whether every
/// case is stored as ok (a dry run: true).
bool run_sweep(const SweepJob& job, Sink& sink, const RunOptions& options);

// ---- softhom calibrate -----------------------------------------------------------------------------

struct CalibrationJob {
  LoadedScene scene;
  studies::CalibrationInput input;
};
/// `base`: the directory relative curve files are resolved against (default: the scene file's directory,
/// or the working directory for a scene without a file).
CalibrationJob parse_calibration(LoadedScene scene, const std::filesystem::path& base = {});
struct CalibrationOutcome {
  studies::CalibrationResult result;
  nlohmann::json summary;
  std::string material_toml;
  std::string comparison_csv;
};
/// The fit; its summary to the sink, and with a sink directory material.toml, response.csv and
/// curves/*.csv; with `cli_files` also what only `softhom calibrate` writes: material.feb,
/// material.inp and, when the calibration asks for it and python3 with matplotlib is there, fit.png.
CalibrationOutcome run_calibration(const CalibrationJob& job, Sink& sink, const RunOptions& options, bool cli_files);

// ---- softhom demo ----------------------------------------------------------------------------------

struct DemoJob {
  std::filesystem::path file;  ///< the campaign file; empty: the embedded demo campaign
  std::string embedded_text;   ///< the embedded campaign (written to OUT/campaign.toml by the run)
  studies::Campaign campaign;
};
DemoJob parse_demo(const std::filesystem::path& campaign_file);
/// The whole chain (point checks, the RVE campaign, calibration, a tube, plots, report.md) into the
/// sink's directory. Returns whether every step went as expected.
bool run_demo(const DemoJob& job, Sink& sink, const RunOptions& options);

}  // namespace softhom::jobs
