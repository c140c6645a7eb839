// [[fibers]] geometry = "gmsh": the polylines of a physical curve group, read from the structure's own
// Gmsh mesh or from a file of their own (a .msh, or a .geo meshed at run time).
#include "fiber_keys.hpp"
#include "softhom/core/input_error.hpp"
#include "softhom/io/gmsh.hpp"
#include "softhom/macro/mesh_generation.hpp"

namespace softhom::macro {

void read_fiber_curve_groups(std::vector<FiberSpec>& fibers, const std::filesystem::path& scene_file,
                             const std::filesystem::path& host_mesh, const std::filesystem::path& mesh_cache) {
  for (FiberSpec& f : fibers) {
    if (f.geometry != FiberGeometry::gmsh) continue;
    const std::string& field = f.options.field;
    std::filesystem::path path = f.file;
    if (f.file.empty()) {
      if (host_mesh.empty())
        throw InputError(field + ".file", "", "missing: the structure is not a Gmsh mesh, so name the file holding the group");
      path = host_mesh;
    } else {
      if (path.is_relative() && !scene_file.empty()) path = scene_file.parent_path() / path;
      if (path.extension() == ".geo")
        path = mesh_from_geo(path, f.mesh_size, mesh_cache.empty() ? mesh_cache_dir() : mesh_cache, field + ".file");
      if (!std::filesystem::exists(path)) throw InputError(field + ".file", path.string(), "no such file");
    }
    const io::GmshLineGroup g = io::read_gmsh_line_group(path, f.group, field + ".group", f.file.empty() ? "geometry.file" : field + ".file");
    const int order = g.nodes_per_line - 1;
    if (f.options.order == 2 && order == 1)
      throw InputError(field + ".order", "2", "the group \"" + f.group + "\" has 2-node lines (3-node fibers need 3-node lines)");
    f.options.order = order;  // 3-node lines make 3-node fibers
    f.polylines = g.polylines;
  }
}

}  // namespace softhom::macro
