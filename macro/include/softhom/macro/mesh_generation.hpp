#pragma once
// Meshes a Gmsh geometry (.geo) at run time with the `gmsh` program into quadratic tetrahedra (MSH
// 4.1) and caches the result: the scene names a .geo and a mesh size instead of a committed mesh.
//
//   gmsh GEO -3 -order 2 -setnumber mesh_size H -format msh41 -o CACHE/<stem>-<hash>-h<H>.msh
//
// The .geo reads the size as `DefineConstant[ mesh_size = ... ];` (studies/meshes/*.geo). The cache
// name holds a hash of the .geo text and the size, so an edited geometry or another size meshes again
// and an unchanged one is reused (files the .geo includes are not hashed). The program is `gmsh` on
// PATH, or $SOFTHOM_GMSH. It runs by fork/exec with an argument vector (no shell), its output in
// CACHE/<name>.log; a mesh is renamed into place only when gmsh succeeded, so concurrent runs never
// read a half-written file.
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace softhom::macro {

/// The mesh cache of a run writing into `out`: $SOFTHOM_MESH_CACHE when set (one cache shared by
/// runs, e.g. the fine benchmark meshes), else out/mesh, else (no out) <temp>/softhom-mesh-cache.
std::filesystem::path mesh_cache_dir(const std::filesystem::path& out = {});

/// Path of the cached mesh of `geo` at `mesh_size` (mm), generating it when absent. `field` names the
/// scene key in errors: InputError when the .geo is missing, gmsh is not installed, or gmsh fails (its
/// error lines in the message). `parameters` are passed as further -setnumber NAME VALUE (and hashed).
/// `dimension` 2 meshes the surfaces only, into 3-node triangles (`gmsh -2 -order 1`: shells).
std::filesystem::path mesh_from_geo(const std::filesystem::path& geo, double mesh_size,
                                    const std::filesystem::path& cache_dir, const std::string& field,
                                    const std::vector<std::pair<std::string, double>>& parameters = {},
                                    int dimension = 3);

/// The mesh file of a scene's [geometry]: `file`, or `geo` meshed at `mesh_size` (mesh_from_geo with
/// `dimension` and `parameters`), both relative to scene_file. Throws InputError naming geometry.file,
/// geometry.geo or geometry.mesh_size when neither or both are given, mesh_size is missing with geo or
/// given without it, or the file does not exist.
std::filesystem::path scene_mesh_file(const std::string& file, const std::string& geo, double mesh_size,
                                      const std::filesystem::path& scene_file, const std::filesystem::path& mesh_cache,
                                      int dimension, const std::vector<std::pair<std::string, double>>& parameters = {});

}  // namespace softhom::macro
