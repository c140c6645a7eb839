// softhom: multiscale mechanics of soft fiber composites. One program, one subcommand per job.
#include <omp.h>

#include <CLI/CLI.hpp>
#include <iostream>

#include "cmd_keys.hpp"
#include "commands.hpp"
#include "embedded_scenes.hpp"
#include "scene_source.hpp"
#include "softhom/io/scene.hpp"
#include "softhom/io/summary.hpp"
#include "softhom/materials/errors.hpp"

namespace softhom::app {

LoadedScene load_scene_or_default(const CommandOptions& options, const std::string& default_name) {
  LoadedScene s;
  if (!options.scene.empty()) {
    s.file = options.scene;
    s.name = options.scene.stem().string();
    s.table = io::load_scene(options.scene);
    return s;
  }
  const auto& scenes = embedded_scenes();
  const auto it = scenes.find(default_name);
  if (it == scenes.end()) throw InputError("scene", default_name, "no embedded scene of that name");
  s.name = default_name;
  s.table = io::parse_scene(it->second, "<embedded " + default_name + ".toml>");
  return s;
}

}  // namespace softhom::app

int main(int argc, char** argv) {
  using namespace softhom;
  CLI::App cli{"softhom " + io::softhom_version() +
               ": multiscale mechanics of soft fiber composites (materials, FFT/FE RVE, macro FE)"};
  cli.set_version_flag("--version", "softhom " + io::softhom_version());
  cli.require_subcommand(1);

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
    sub->add_option("scene", options.scene, "scene file (TOML); omitted: the embedded default scene")
        ->check(CLI::ExistingFile);
    sub->add_option("-o,--out", options.out, "output directory (created if needed)")->capture_default_str();
    sub->add_option("-j,--threads", options.threads, "threads (0: all cores)")->check(CLI::NonNegativeNumber);
    sub->add_flag("-q,--quiet", options.quiet, "no progress on stderr");
    sub->add_flag("--print-default", print_default, "write the embedded default scene to stdout and exit");
    if (std::string(s.name) == "sweep" || std::string(s.name) == "demo") {
      sub->add_option("--jobs", options.jobs,
                      "cases run in parallel, the threads split between them (0: one single-threaded job per thread)")
          ->check(CLI::NonNegativeNumber)
          ->capture_default_str();
      sub->add_flag("--no-warm-start", options.no_warm_start, "run every case from the undeformed state");
    }
    if (std::string(s.name) == "sweep")
    {
      sub->add_flag("--retry-failed", options.retry_failed, "rerun the cases stored as failed");
      sub->add_flag("--dry-run", options.dry_run, "list the cases (and which are already stored), run nothing");
    }
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
    return cli.exit(e);
  }
  if (options.threads > 0) omp_set_num_threads(options.threads);
  try {
    if (keys->parsed()) return app::run_keys(keys_command, keys_markdown);
    if (print_default) return app::print_default_scene(chosen->name);
    return chosen->run(options);
  } catch (const InputError& e) {
    std::cerr << "softhom " << (chosen ? chosen->name : "keys") << ": input error: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "softhom " << (chosen ? chosen->name : "keys") << ": error: " << e.what() << "\n";
    return 1;
  }
}
