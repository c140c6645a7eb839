#pragma once
// Subcommands of the one `softhom` program. Each reads SCENE.toml (or an embedded default), writes
// OUT/response.csv, OUT/summary.json and, where there are fields, OUT/fields.h5 + OUT/fields.xdmf,
// and returns the process exit code. Errors in input are reported by main() (InputError → exit 2).
#include <filesystem>
#include <string>

namespace softhom::app {

struct CommandOptions {
  std::filesystem::path scene;  ///< empty: the command's embedded default scene
  std::filesystem::path out = "softhom-out";
  int threads = 0;              ///< 0: OpenMP default
  bool quiet = false;           ///< no progress on stderr
  // rve only
  bool resume = false;          ///< continue the unfinished run whose checkpoint is in `out`
  // sweep / demo only
  int jobs = 0;                 ///< cases in parallel, threads split between them (0: one job per thread)
  bool retry_failed = false;    ///< rerun cases stored as failed
  bool no_warm_start = false;   ///< every case from F = I
  bool dry_run = false;         ///< sweep: list the cases and their state, run nothing
};

int run_point(const CommandOptions& options);
int run_rve(const CommandOptions& options);
int run_macro(const CommandOptions& options);
int run_demo(const CommandOptions& options);
int run_sweep(const CommandOptions& options);
int run_calibrate(const CommandOptions& options);

}  // namespace softhom::app
