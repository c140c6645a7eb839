// Where a command's scene comes from (scene_source.hpp).
#include "scene_source.hpp"

#include "embedded_scenes.hpp"
#include "softhom/io/scene.hpp"
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
