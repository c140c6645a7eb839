// What the direct path would cost on a device scene's mesh, without running it: the CHOLMOD symbolic
// analysis (the solver's orderings and supernode amalgamation, fe/src/sparse.cpp) of the free-dof
// stiffness pattern gives the factor's storage and flops exactly; the numeric factorization is not run
// (at the dissertation's resolution it would not fit next to other jobs on the shared machine).
//
//   bench_device_direct SCENE.toml [MESH_SIZE ...]
//
// Each mesh size overrides [geometry] mesh_size of the (gmsh) scene; the meshes are cached as
// `softhom macro` caches them (SOFTHOM_MESH_CACHE, else the system's temporary directory). Printed per
// size: free dofs, elements, nnz of the full stiffness, nnz(L) and the factor's storage (values of the
// relaxed supernodes + indices), GFlop per factorization, the analysis time and peak memory, and
// macro::estimate_size's figures for both linear-solver paths (the refusal test of a scene).
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <cholmod.h>

#include "softhom/fe/sparse.hpp"
#include "softhom/io/files.hpp"
#include "softhom/io/scene.hpp"
#include "softhom/macro/mesh_generation.hpp"
#include "softhom/macro/scene.hpp"
#include "softhom/macro/structures.hpp"

using namespace softhom;

namespace {

constexpr double kGiB = 1024.0 * 1024.0 * 1024.0;

void analyze(const std::filesystem::path& scene_file, toml::table scene, double mesh_size) {
  if (mesh_size > 0.0) scene["geometry"].as_table()->insert_or_assign("mesh_size", mesh_size);
  // Parsed as a PETSc scene: the direct path's estimate would refuse the sizes this program is for.
  if (!scene.contains("solver")) scene.insert("solver", toml::table{});
  scene["solver"].as_table()->insert_or_assign("linear_solver", "petsc");
  const auto t_mesh = std::chrono::steady_clock::now();
  const macro::MacroScene ms = macro::parse_macro_scene(scene, scene_file, macro::mesh_cache_dir({}));
  const macro::Structure s = macro::build_structure(ms.spec);
  const double mesh_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_mesh).count();
  const fe::Mesh& mesh = s.model.mesh;
  std::vector<char> constrained(mesh.num_dofs(), 0);
  for (const auto& g : s.model.dirichlet)
    for (int d : g.dofs) constrained[d] = 1;
  const fe::CscMatrix K = fe::build_pattern(mesh, fe::DofMap::from_constrained(mesh.num_dofs(), constrained));
  std::vector<int> colptr(K.n + 1, 0), rows;
  for (int c = 0; c < K.n; ++c) {
    for (int k = K.colptr[c]; k < K.colptr[c + 1]; ++k)
      if (K.rowind[k] <= c) rows.push_back(K.rowind[k]);
    colptr[c + 1] = int(rows.size());
  }
  cholmod_common cm;
  cholmod_start(&cm);
  fe::apply_cholmod_settings(cm);  // the direct path's own settings
  cholmod_sparse* A = cholmod_allocate_sparse(K.n, K.n, rows.size(), 1, 1, 1, CHOLMOD_PATTERN, &cm);
  std::copy(colptr.begin(), colptr.end(), static_cast<int*>(A->p));
  std::copy(rows.begin(), rows.end(), static_cast<int*>(A->i));
  const auto t0 = std::chrono::steady_clock::now();
  cholmod_factor* L = cholmod_analyze(A, &cm);
  const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  // Storage of the numeric supernodal factor: xsize values (the relaxed supernodes' explicit zeros
  // included) and ssize row indices.
  const double factor_bytes = L ? 8.0 * double(L->xsize) + 4.0 * double(L->ssize) : 0.0;
  macro::StructureSpec direct = ms.spec, iterative = ms.spec;
  direct.factorized_solver = true;
  iterative.factorized_solver = false;
  const macro::SizeEstimate ed = macro::estimate_size(direct), ei = macro::estimate_size(iterative);
  std::printf("%6.3g %8d %8d %8.1f M %9.1f M %8.2f GiB %10.1f %7.1f s %7.1f s %7.0f MiB | estimate direct %6.2f GiB "
              "(factor %6.2f) petsc %6.2f GiB  [%s]\n",
              mesh_size, K.n, mesh.num_elements(), K.nnz() / 1e6, cm.lnz / 1e6, factor_bytes / kGiB, cm.fl / 1e9,
              mesh_seconds, t, double(io::peak_memory_bytes()) / (1 << 20), ed.bytes() / kGiB, ed.factor_bytes / kGiB,
              ei.bytes() / kGiB, cm.method[cm.selected].ordering == CHOLMOD_METIS ? "METIS" : "AMD");
  std::fflush(stdout);
  if (L) cholmod_free_factor(&L, &cm);
  cholmod_free_sparse(&A, &cm);
  cholmod_finish(&cm);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: bench_device_direct SCENE.toml [MESH_SIZE ...]\n");
    return 2;
  }
  const std::filesystem::path file = argv[1];
  const toml::table scene = io::load_scene(file);
  std::vector<double> sizes;
  for (int k = 2; k < argc; ++k) sizes.push_back(std::atof(argv[k]));
  if (sizes.empty()) sizes.push_back(0.0);
  std::printf("# CHOLMOD symbolic analysis of %s (fe::CholmodSolver settings; no numeric factorization)\n", argv[1]);
  std::printf("# %4s %8s %8s %10s %11s %12s %10s %9s %9s %11s\n", "h", "dofs", "elems", "nnz(K)", "nnz(L)", "factor",
              "GFlop/fac", "mesh+FE", "analysis", "peak");
  for (double h : sizes) analyze(file, scene, h);
  return 0;
}
