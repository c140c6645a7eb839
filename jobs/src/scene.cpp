// Where a job's scene comes from (scene.hpp).
#include "softhom/jobs/scene.hpp"

#include "embedded_scenes.hpp"
#include "softhom/io/scene.hpp"
#include "softhom/materials/errors.hpp"

namespace softhom::jobs {

LoadedScene load_scene_file(const std::filesystem::path& file) {
  LoadedScene s;
  s.file = file;
  s.name = file.stem().string();
  s.table = io::load_scene(file);
  return s;
}

LoadedScene load_scene_or_default(const std::filesystem::path& file, const std::string& default_name) {
  if (!file.empty()) return load_scene_file(file);
  const auto& scenes = embedded_scenes();
  const auto it = scenes.find(default_name);
  if (it == scenes.end()) throw InputError("scene", default_name, "no embedded scene of that name");
  LoadedScene s;
  s.name = default_name;
  s.table = io::parse_scene(it->second, "<embedded " + default_name + ".toml>");
  return s;
}

std::string default_scene_name(const std::string& command) {
  if (command == "point") return "point_uniaxial_ecoflex";
  if (command == "rve") return "rve_homogeneous";
  if (command == "macro") return "macro_tube_plane_strain";
  return "";
}

}  // namespace softhom::jobs
