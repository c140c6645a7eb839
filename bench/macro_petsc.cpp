// The macro engine's petsc linear solver: Krylov iterations per Newton step over mesh size and K/G
// (Cook's membrane, plane strain), and the helix tube (bench_macro's tube, follower pressure) with
// CHOLMOD vs PETSc: wall time, Newton and Krylov iterations, peak memory.
//
//   bench_macro_petsc --cook                 n = 8, 16, 32 (BENCH_COOK_N) × K/G = 1e2 … 1e5, one load step;
//                                            BENCH_TET10=1: the hexes split into tet10
//   bench_macro_petsc --tube-table           helix tube, 1e3 / 4e3 / 1e4 dofs (BENCH_DOFS) × K/G = 1e2 … 1e5,
//                                            first load step; BENCH_TET10=1: the hexes split into tet10;
//                                            BENCH_ISOTROPIC=1: the Gent matrix without the fibers
//                                            (both tables: BENCH_FRESH=1 sets up a preconditioner for every
//                                            tangent, [solver] reuse_preconditioner = false, so that the counts
//                                            do not depend on the timing-based reuse of an expensive set-up)
//   bench_macro_petsc --tube DOFS [STEPS]    helix tube, cholmod then petsc (under mpirun: petsc only)
//   mpirun -n 2 bench_macro_petsc --tube DOFS [STEPS]
//   [mpirun -n R] bench_macro_petsc --scene FILE [STEPS]   a macro scene with its [solver] settings:
//                                            assembly and linear-solver time per Newton iteration,
//                                            peak memory of every rank
// PETSC_OPTIONS in the environment is not read; pass options with --options "…". BENCH_P_MULTIGRID=on|off sets
// [solver] petsc_p_multigrid of the tables and the tube (automatic otherwise).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "softhom/fe/petsc.hpp"
#include "softhom/fe/solver.hpp"
#include "softhom/io/files.hpp"
#include <mpi.h>
#include <sys/resource.h>

#include "softhom/core/mpi.hpp"
#include "softhom/io/scene.hpp"
#include "softhom/macro/benchmark_problems.hpp"
#include "softhom/macro/geometry.hpp"
#include "softhom/macro/scene.hpp"
#include "softhom/macro/structures.hpp"
#include "softhom/materials/laws.hpp"

using namespace softhom;
using namespace softhom::fe;

namespace {

/// Cook's membrane of n × n hexes, or with BENCH_TET10 set the same hexes split into 10-node tets (P2/P0).
FeModel cook(int n, double kg) {
  return macro::make_cook_membrane_problem(n, 83.3, kg, 5.0, std::getenv("BENCH_TET10") != nullptr);
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// A comma-separated list of numbers in the environment variable `name`, or `fallback`.
std::vector<double> list_from_env(const char* name, std::vector<double> fallback) {
  const char* env = std::getenv(name);
  if (!env) return fallback;
  std::vector<double> out;
  for (const char* p = env; *p;) {
    char* end = nullptr;
    out.push_back(std::strtod(p, &end));
    if (end == p) break;
    p = *end == ',' ? end + 1 : end;
  }
  return out;
}

/// [solver] petsc_p_multigrid of the runs: BENCH_P_MULTIGRID=on|off, automatic otherwise.
PMultigrid p_multigrid_from_env() {
  const char* env = std::getenv("BENCH_P_MULTIGRID");
  if (!env) return PMultigrid::automatic;
  return std::strcmp(env, "off") == 0 ? PMultigrid::off : PMultigrid::on;
}

/// K/G of the tables: 1e2 … 1e5, or those listed in BENCH_KG (e.g. "1e2,1e5") for a quick look.
std::vector<double> ratios() { return list_from_env("BENCH_KG", {1e2, 1e3, 1e4, 1e5}); }

int cook_table(const std::string& options) {
  if (mpi::world_rank() == 0)
    std::printf("%6s %8s %8s %7s %7s %12s %9s\n", "mesh", "K/G", "dofs", "newton", "solves", "krylov/solve", "time[s]");
  for (double mesh : list_from_env("BENCH_COOK_N", {8, 16, 32}))
    for (double kg : ratios()) {
      const int n = int(mesh);
      NewtonOptions o;
      o.solver = SolverKind::petsc;
      o.petsc_options = options;
      o.petsc_p_multigrid = p_multigrid_from_env();
      o.reuse_preconditioner = std::getenv("BENCH_FRESH") == nullptr;
      o.verbose = std::getenv("SOFTHOM_VERBOSE") != nullptr;
      const auto t0 = std::chrono::steady_clock::now();
      Simulation sim(cook(n, kg), o);
      const bool ok = sim.advance_to(1.0).reached();
      const RunStats s = sim.stats();
      if (mpi::world_rank() == 0)
        std::printf("%3dx%-2d %8.0e %8d %7d %7d %12.1f %9.2f%s\n", n, n, kg, sim.num_free_dofs(), s.newton_iterations,
                    s.linear.solves, double(s.krylov_iterations) / std::max(1, s.linear.solves), seconds_since(t0),
                    ok ? "" : "  (failed)");
      std::fflush(stdout);
    }
  return 0;
}

/// The helix tube of about `dofs` hex8 dofs; with BENCH_TET10 set, its hexes split into 10-node tets (about
/// 7× the dofs; the PETSc path then takes the p-multigrid of quadratic tets).
macro::StructureSpec helix_tube(double dofs, double kg = 2000.0 / 0.017) {
  macro::StructureSpec spec = macro::make_helix_tube_spec(dofs, kg);
  spec.tet10 = std::getenv("BENCH_TET10") != nullptr;
  if (std::getenv("BENCH_ISOTROPIC")) {  // the Gent matrix alone: the fibers' share of the counts
    GentHGOParams matrix = macro::helix_tube_law(kg);
    matrix.fibers.clear();
    spec.material = make_material(make_gent_hgo(matrix));
  }
  return spec;
}

int tube_run(double dofs, int steps, const std::string& options) {
  const macro::Structure s = macro::build_structure(helix_tube(dofs));
  std::vector<SolverKind> kinds{SolverKind::petsc};
  if (mpi::world_size() == 1) kinds.insert(kinds.begin(), SolverKind::cholmod);
  for (SolverKind kind : kinds) {
    NewtonOptions o;
    o.solver = kind;
    o.petsc_options = options;
    o.petsc_p_multigrid = p_multigrid_from_env();
    o.verbose = std::getenv("SOFTHOM_VERBOSE") != nullptr;
    const auto t0 = std::chrono::steady_clock::now();
    Simulation sim(s.model, o);
    bool ok = true;
    for (int k = 1; k <= steps && ok; ++k) ok = sim.advance_to(180.0 * k / steps).reached();
    const double wall = seconds_since(t0);
    const RunStats st = sim.stats();
    if (mpi::world_rank() == 0)
      std::printf("tube %s ranks %d dofs %d steps %d newton %d krylov %d (%.1f/solve) wall %.2f s  %.3f s/newton  "
                  "factor+setup %.2f s solve %.2f s assembly %.2f s (element loop %.2f s)  peak %.0f MiB (%.0f B/dof)%s\n",
                  to_string(kind), mpi::world_size(), sim.num_free_dofs(), st.steps, st.newton_iterations,
                  st.krylov_iterations, double(st.krylov_iterations) / std::max(1, st.linear.solves), wall,
                  wall / std::max(1, st.newton_iterations), st.linear.factorization, st.linear.solve, st.assembly_time,
                  st.element_loop_time, io::peak_memory_bytes() / 1048576.0, io::peak_memory_bytes() / double(sim.num_free_dofs()),
                  ok ? "" : "  (failed)");
    std::fflush(stdout);
  }
  return 0;
}

int scene_run(const std::string& file, int steps) {
  const macro::MacroScene ms = macro::parse_macro_scene(io::load_scene(file), file);
  const macro::Structure s = macro::build_structure(ms.spec);
  const auto t0 = std::chrono::steady_clock::now();
  Simulation sim(s.model, ms.newton);
  bool ok = true;
  const int n = std::min<int>(steps, int(ms.times.size()));
  for (int k = 0; k < n && ok; ++k) ok = sim.advance_to(ms.times[k]).reached();
  const double wall = seconds_since(t0);
  const RunStats st = sim.stats();
  // Peak resident memory of every rank (the distributed assembly stores 1/R of the matrix, the element
  // loop's data and the history per rank; mesh and Newton vectors are replicated).
  // CPU seconds of every rank too: on a shared machine wall times follow the load, the work per rank
  // does not (Open MPI's waits spin, so a waiting rank's CPU counts as well).
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  const double cpu = double(ru.ru_utime.tv_sec + ru.ru_stime.tv_sec) + 1e-6 * double(ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
  const int it = std::max(1, st.newton_iterations);
  std::vector<double> mine{io::peak_memory_bytes() / 1048576.0, cpu, st.element_loop_time / it, st.element_loop_cpu / it};
  std::vector<double> all(4 * mpi::world_size(), 0.0);
  if (mpi::active()) MPI_Gather(mine.data(), 4, MPI_DOUBLE, all.data(), 4, MPI_DOUBLE, 0, MPI_COMM_WORLD);
  else all = mine;
  if (mpi::world_rank() != 0) return ok ? 0 : 1;
  std::printf("scene %s ranks %d solver %s dofs %d steps %d newton %d tangents %d residuals %d krylov %d wall %.2f s | per "
              "Newton: assembly %.3f s, setup %.3f s, solve %.3f s | peak MiB per rank:",
              file.c_str(), mpi::world_size(), to_string(sim.solver_kind()), sim.num_free_dofs(), st.steps,
              st.newton_iterations, st.tangent_assemblies, st.residual_assemblies, st.krylov_iterations, wall,
              st.assembly_time / it, st.linear.factorization / it, st.linear.solve / it);
  for (int r = 0; r < mpi::world_size(); ++r) std::printf(" %.0f", all[4 * r]);
  std::printf(" | CPU s per rank:");
  for (int r = 0; r < mpi::world_size(); ++r) std::printf(" %.1f", all[4 * r + 1]);
  std::printf(" | element loop per Newton, wall / CPU s per rank:");
  for (int r = 0; r < mpi::world_size(); ++r) std::printf(" %.3f / %.3f", all[4 * r + 2], all[4 * r + 3]);
  std::printf("%s\n", ok ? "" : "  (failed)");
  for (const std::string& line : st.log) std::printf("  %s\n", line.c_str());
  std::fflush(stdout);
  return ok ? 0 : 1;
}

/// Krylov iterations per Newton step on the helix tube over three meshes (h ratios 1.54, 1.27) and K/G = 1e2 … 1e5:
/// the first load step of bench_macro's run (pressure 45 of 180), PETSc only. BENCH_DOFS: other sizes.
int tube_table(const std::string& options) {
  if (mpi::world_rank() == 0)
    std::printf("%8s %8s %7s %7s %12s %9s %10s %9s %9s\n", "dofs", "K/G", "newton", "solves", "krylov/solve", "time[s]",
                "s/newton", "setup[s]", "krylov[s]");
  for (double target : list_from_env("BENCH_DOFS", {1e3, 4e3, 1e4}))
    for (double kg : ratios()) {
      const macro::Structure s = macro::build_structure(helix_tube(target, kg));
      NewtonOptions o;
      o.solver = SolverKind::petsc;
      o.petsc_options = options;
      o.petsc_p_multigrid = p_multigrid_from_env();
      o.reuse_preconditioner = std::getenv("BENCH_FRESH") == nullptr;
      o.verbose = std::getenv("SOFTHOM_VERBOSE") != nullptr;
      const auto t0 = std::chrono::steady_clock::now();
      Simulation sim(s.model, o);
      const bool ok = sim.advance_to(45.0).reached();
      const double wall = seconds_since(t0);
      const RunStats st = sim.stats();
      if (mpi::world_rank() == 0)
        std::printf("%8d %8.0e %7d %7d %12.1f %9.2f %10.3f %9.2f %9.2f%s\n", sim.num_free_dofs(), kg,
                    st.newton_iterations, st.linear.solves, double(st.krylov_iterations) / std::max(1, st.linear.solves),
                    wall, wall / std::max(1, st.newton_iterations), st.linear.factorization, st.linear.solve,
                    ok ? "" : "  (failed)");
      std::fflush(stdout);
    }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  mpi::Environment env(argc, argv);
  std::string options;
  std::vector<std::string> args;
  for (int k = 1; k < argc; ++k) {
    if (std::strcmp(argv[k], "--options") == 0 && k + 1 < argc) options = argv[++k];
    else args.push_back(argv[k]);
  }
  int rc = 2;
  if (!args.empty() && args[0] == "--cook") rc = cook_table(options);
  else if (!args.empty() && args[0] == "--tube-table") rc = tube_table(options);
  else if (args.size() >= 2 && args[0] == "--scene") rc = scene_run(args[1], args.size() >= 3 ? std::stoi(args[2]) : 1 << 30);
  else if (args.size() >= 2 && args[0] == "--tube") rc = tube_run(std::stod(args[1]), args.size() >= 3 ? std::stoi(args[2]) : 4, options);
  else std::fprintf(stderr, "usage: bench_macro_petsc --cook | --tube-table | --tube DOFS [STEPS] | --scene FILE [STEPS] [--options \"...\"]\n");
  petsc_finalize();
  return rc;
}
