// softhom keys: the scene keys of every subcommand, printed from their declarations (docs/keys.md is
// `softhom keys --markdown all`), and `softhom COMMAND --print-default`.
#include "cmd_keys.hpp"

#include <iostream>

#include "softhom/jobs/scene.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/macro/scene.hpp"
#include "softhom/materials/scene_keys.hpp"
#include "softhom/studies/calibration.hpp"
#include "softhom/studies/campaign_definition.hpp"
#include "softhom/studies/rve_fe_scene.hpp"

namespace softhom::app {

std::vector<keys::SceneKeys> scene_key_registry() {
  return {
      {"point", "material-point driver: a homogeneous deformation of one material under mixed control",
       point_scene_tables()},
      {"rve", "periodic RVE homogenization (FFT or FE engine) of a fiber cell under the load of softhom point",
       studies::rve_scene_tables()},
      {"macro", "structure-scale nonlinear FE", macro::macro_scene_tables()},
      {"sweep", "sweep campaigns over microstructures and load cases", studies::campaign_tables()},
      {"calibrate", "fits of the macro model to RVE or CSV curves", studies::calibration_tables()},
  };
}

int run_keys(const std::string& command, bool markdown) {
  std::vector<keys::SceneKeys> chosen;
  std::string known;
  for (auto& s : scene_key_registry()) {
    known += (known.empty() ? "" : ", ") + s.command;
    if (command == "all" || command == s.command) chosen.push_back(std::move(s));
  }
  if (chosen.empty()) throw InputError("keys", command, "unknown subcommand (" + known + " or all)");
  if (markdown) {
    std::cout << keys::format_keys_markdown(chosen);
  } else {
    for (std::size_t i = 0; i < chosen.size(); ++i) std::cout << (i ? "\n" : "") << keys::format_keys_text(chosen[i]);
  }
  return 0;
}

int print_default_scene(const std::string& command) {
  const std::string name = jobs::default_scene_name(command);
  const auto& scenes = jobs::embedded_scenes();
  const auto it = scenes.find(name);
  if (name.empty() || it == scenes.end())
    throw InputError("--print-default", command, "this subcommand has no embedded default scene (give a file)");
  std::cout << it->second;
  return 0;
}

}  // namespace softhom::app
