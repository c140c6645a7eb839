// softhom: multiscale mechanics of soft fiber composites. One program, one subcommand per job: the
// command line, signals and exit codes are here; the jobs themselves are in jobs/ (softhom/jobs/jobs.hpp).
//
// Exit codes (also in `softhom --help`):
//   0    the run completed;
//   1    the run stopped early (locking, cut-backs exhausted, wall-time budget) or an output file could
//        not be written (full disk, permissions, read-only file system); converged rows are kept;
//   2    bad input: command line or scene (the option or the TOML path is named);
//   128 + N  interrupted by signal N (130: SIGINT / Ctrl-C, 143: SIGTERM from `timeout`, Slurm,
//        `kill`), as shells report a process killed by N; converged rows and a summary.json with
//        "status": "interrupted" are kept. A second signal ends the process at once (temporaries of
//        that process are then removed at the next start in the same --out).
#include <omp.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <charconv>
#include <cstdlib>
#include <exception>
#include <iostream>

#include "cmd_keys.hpp"
#include "softhom/core/mpi.hpp"
#include "softhom/fe/petsc.hpp"
#include "softhom/io/fields.hpp"
#include "softhom/io/files.hpp"
#include "softhom/io/summary.hpp"
#include "softhom/jobs/jobs.hpp"
#include "softhom/jobs/run_control.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/materials/interrupt.hpp"

namespace softhom::app {

namespace fs = std::filesystem;

/// The command line of a subcommand.
struct CommandOptions {
  fs::path scene;  ///< empty: the command's embedded default scene
  fs::path out = "softhom-out";
  int threads = 0;              ///< 0: OpenMP default
  bool quiet = false;           ///< no progress on stderr
  bool resume = false;          ///< rve: continue the unfinished run whose checkpoint is in `out`
  int jobs = 0;                 ///< sweep / demo: cases in parallel, threads split between them
  bool retry_failed = false;    ///< sweep: rerun cases stored as failed
  bool no_warm_start = false;   ///< sweep / demo: every case from F = I
  bool dry_run = false;         ///< sweep: list the cases and their state, run nothing

  jobs::RunOptions run() const { return {quiet, threads, jobs, retry_failed, no_warm_start, dry_run}; }
};

/// The documented exit code of a run that ended with `completed`.
int run_exit_code(bool completed) {
  if (completed) return 0;
  if (stop_requested() && stop_signal() > 0) return 128 + stop_signal();
  return 1;
}

// Each subcommand: the scene parsed into its job, the job run into the files of --out. Returns the
// exit code.

int run_point(const CommandOptions& o) {
  const jobs::PointJob job = jobs::parse_point(jobs::load_scene_or_default(o.scene, jobs::default_scene_name("point")));
  jobs::FileSink sink(o.out, "point");
  const PointRunResult result = jobs::run_point(job, sink, o.run());
  if (!result.completed) {
    std::cerr << "softhom point: stopped early: " << result.error << "\n"
              << "softhom point: " << result.steps.size() << " converged rows kept in "
              << (o.out / "response.csv").string() << "\n";
    return run_exit_code(false);
  }
  if (!o.quiet)
    std::cerr << "softhom point: " << result.steps.size() - 1 << " steps, " << result.total_newton_iterations
              << " Newton iterations → " << o.out.string() << "\n";
  return 0;
}

int run_rve(const CommandOptions& o) {
  jobs::FileSink sink(o.out, "rve");
  jobs::RveJob job = jobs::parse_rve(jobs::load_scene_or_default(o.scene, jobs::default_scene_name("rve")),
                                     {o.out, o.resume});
  return run_exit_code(jobs::run_rve(job, sink, o.run()));
}

int run_macro(const CommandOptions& o) {
  jobs::FileSink sink(o.out, "macro");  // before the parse, which may mesh a .geo into OUT/mesh
  jobs::MacroJob job =
      jobs::parse_macro(jobs::load_scene_or_default(o.scene, jobs::default_scene_name("macro")), o.out);
  return run_exit_code(jobs::run_macro(job, sink, o.run()));
}

int run_sweep(const CommandOptions& o) {
  jobs::SweepJob job;
  try {
    job = jobs::parse_sweep(o.scene);
  } catch (const InputError&) {
    // Over MPI the message about bad input (the same on every rank) is rank 0's to give.
    if (mpi::world_rank() == 0) throw;
    return 2;
  }
  jobs::FileSink sink(o.out, "sweep");
  return run_exit_code(jobs::run_sweep(job, sink, o.run()));
}

int run_calibrate(const CommandOptions& o) {
  if (o.scene.empty())
    throw InputError("scene", "", "calibrate needs a calibration file: softhom calibrate CALIBRATION.toml --out DIR "
                                  "(example: studies/calibrations/example_point.toml)");
  const jobs::CalibrationJob job = jobs::parse_calibration(jobs::load_scene_file(o.scene));
  jobs::FileSink sink(o.out, "calibrate");
  return run_exit_code(jobs::run_calibration(job, sink, o.run(), true).result.success);
}

int run_demo(const CommandOptions& o) {
  const jobs::DemoJob job = jobs::parse_demo(o.scene);
  jobs::FileSink sink(o.out, "demo");
  return jobs::run_demo(job, sink, o.run()) ? 0 : 1;
}

/// The message and exit code of an exception that ended a subcommand.
int exit_code_of_exception(const char* name) {
  try {
    throw;
  } catch (const InputError& e) {
    std::cerr << "softhom " << name << ": input error: " << e.what() << "\n";
    return 2;
  } catch (const io::WriteError& e) {
    std::cerr << "softhom " << name << ": error: " << e.what() << "\n";
    return stop_requested() ? run_exit_code(false) : 1;
  } catch (const jobs::RunInterrupted&) {
    std::cerr << "softhom " << name << ": " << jobs::interruption_message() << "\n";
    return run_exit_code(false);
  } catch (const std::exception& e) {
    std::cerr << "softhom " << name << ": error: " << e.what() << "\n";
    return 1;
  } catch (...) {
    std::cerr << "softhom " << name << ": error: unknown exception\n";
    return 1;
  }
}

/// Runs one subcommand: clears stale temporaries in --out first, maps every exception to its documented
/// exit code with one clear message, and removes this process's temporaries on every way out.
int run_command(const char* name, int (*run)(const CommandOptions&), const CommandOptions& options) {
  // An exception that escapes where it cannot be caught (an OpenMP region) ends in std::terminate,
  // which unwinds nothing: remove this process's temporaries there too.
  static fs::path out_for_terminate;
  out_for_terminate = options.out;
  std::set_terminate([] {
    io::remove_own_temporaries(out_for_terminate);
    std::abort();
  });
  std::error_code ec;
  if (fs::exists(options.out, ec) && !fs::is_directory(options.out, ec)) {
    std::cerr << "softhom " << name << ": input error: --out '" << options.out.string()
              << "' exists and is not a directory\n";
    return 2;
  }
  // A campaign directory is cleaned by its store, under the store's lock and only for this host's
  // pids (on a shared filesystem another host's live sweep has pids this host cannot see).
  if (std::string_view(name) != "sweep")
    for (const auto& p : io::remove_stale_temporaries(options.out))
      if (!options.quiet) std::cerr << "softhom " << name << ": removed stale temporary " << p.string() << "\n";
  int code = 1;
  try {
    code = run(options);
  } catch (...) {
    code = exit_code_of_exception(name);
  }
  io::remove_own_temporaries(options.out);
  return code;
}

namespace {

// A scene is read by the checked opener every named file goes through (io::read_input_file): a
// regular TOML text file of at most 4 MiB; anything else is refused here, without opening it.
std::string check_scene_path(const std::string& path) { return io::input_file_problem(path, io::kSceneFile); }

// "" would be the current directory, which is no output directory the user named.
std::string check_out_path(const std::string& path) {
  return path.empty() ? "is empty: name the output directory (e.g. --out results)" : std::string();
}

CLI::Validator parallelism_range(const std::string& zero_means) {
  const int max = jobs::max_parallelism();
  return CLI::Validator(
      [](std::string& text) -> std::string {
        long v = 0;
        const auto r = std::from_chars(text.data(), text.data() + text.size(), v);
        if (r.ec != std::errc{} || r.ptr != text.data() + text.size())
          return "'" + text + "' is not a whole number";
        return jobs::parallelism_problem(v);
      },
      "INT in [0, " + std::to_string(max) + "] (0: " + zero_means + ")");
}

}  // namespace

/// The options of the subcommand `name` (every subcommand: scene, --out, --threads, --quiet,
/// --print-default; the others where they apply).
void declare_options(CLI::App& sub, const std::string& name, CommandOptions& options, bool& print_default) {
  sub.add_option("scene", options.scene, "scene file (TOML); omitted: the embedded default scene")
      ->check(CLI::Validator(check_scene_path, "FILE"));
  sub.add_option("-o,--out", options.out, "output directory (created if needed)")
      ->capture_default_str()
      ->check(CLI::Validator(check_out_path, "DIR"));
  sub.add_option("-j,--threads", options.threads, "threads (0: all cores)")->check(parallelism_range("all cores"));
  sub.add_flag("-q,--quiet", options.quiet, "no progress on stderr");
  sub.add_flag("--print-default", print_default, "write the embedded default scene to stdout and exit");
  if (name == "sweep" || name == "demo") {
    sub.add_option("--jobs", options.jobs,
                   "cases run in parallel, the threads split between them (0: one single-threaded job per thread)")
        ->check(parallelism_range("one single-threaded job per thread"))
        ->capture_default_str();
    sub.add_flag("--no-warm-start", options.no_warm_start, "run every case from the undeformed state");
  }
  if (name == "rve")
    sub.add_flag("--resume", options.resume,
                 "continue the unfinished run whose checkpoint is in --out (FFT engine), from its last "
                 "converged output step");
  if (name == "sweep") {
    sub.add_flag("--retry-failed", options.retry_failed, "rerun the cases stored as failed");
    sub.add_flag("--dry-run", options.dry_run, "list the cases (and which are already stored), run nothing");
  }
}

}  // namespace softhom::app

int main(int argc, char** argv) {
  using namespace softhom;
  io::mark_run_started();
  // MPI only under an MPI launcher (mpirun, srun); a plain start is the one-process program.
  mpi::Environment mpi_environment(argc, argv);
  // PETSc (the macro petsc linear solver, initialised on first use) ends before MPI does.
  struct PetscScope {
    ~PetscScope() { fe::petsc_finalize(); }
  } petsc_scope;
  CLI::App cli{"softhom " + io::softhom_version() +
               ": multiscale mechanics of soft fiber composites (materials, FFT/FE RVE, macro FE)"};
  cli.set_version_flag("--version", "softhom " + io::softhom_version());
  cli.require_subcommand(1);
  cli.footer(
      "Exit codes: 0 completed; 1 stopped early (converged rows kept) or an output file could not be "
      "written; 2 bad command line or scene; 128+N interrupted by signal N (130 Ctrl-C, 143 SIGTERM), "
      "converged rows and summary.json (status \"interrupted\") kept; softhom rve continues a stopped run "
      "with --resume.");
  install_stop_handlers();
  io::silence_hdf5_errors();

  app::CommandOptions options;
  struct Sub {
    const char* name;
    const char* help;
    int (*run)(const app::CommandOptions&);
  };
  const Sub subs[] = {
      {"point", "material-point driver: homogeneous deformation under mixed control", app::run_point},
      {"rve", "periodic RVE homogenization (FFT engine)", app::run_rve},
      {"macro", "structure-scale nonlinear FE (tubes, balloons, plates, actuators)", app::run_macro},
      {"sweep", "sweep campaign over microstructures and load cases (RVE)", app::run_sweep},
      {"calibrate", "fits the macro Gent + HGO (+ QLV) model to RVE or CSV curves", app::run_calibrate},
      {"demo", "runs the built-in example scenes and reports where the results are", app::run_demo},
  };
  const Sub* chosen = nullptr;
  bool print_default = false;
  for (const Sub& s : subs) {
    CLI::App* sub = cli.add_subcommand(s.name, s.help);
    app::declare_options(*sub, s.name, options, print_default);
    sub->callback([&chosen, &s] { chosen = &s; });
  }
  std::string keys_command = "all";
  bool keys_markdown = false;
  CLI::App* keys = cli.add_subcommand("keys", "lists every scene key: type, default, allowed values, unit, meaning");
  keys->add_option("command", keys_command, "point, rve, macro, sweep, calibrate or all")->capture_default_str();
  keys->add_flag("--markdown", keys_markdown, "Markdown (docs/keys.md)");
  try {
    cli.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return cli.exit(e);  // --help, --version
    // CLI11's own codes (105, 109, ...) are one documented code here: bad command line = bad input.
    std::cerr << "softhom: command line: " << e.what() << "\nRun 'softhom --help' for the options.\n";
    return 2;
  }
  try {
    if (keys->parsed()) return app::run_keys(keys_command, keys_markdown);
    if (print_default) return app::print_default_scene(chosen->name);
    jobs::check_thread_count(options.threads, "--threads");
  } catch (const InputError& e) {
    std::cerr << "softhom " << (chosen ? chosen->name : "keys") << ": input error: " << e.what() << "\n";
    return 2;
  }
  if (options.threads > 0) omp_set_num_threads(options.threads);
  return app::run_command(chosen->name, chosen->run, options);
}
