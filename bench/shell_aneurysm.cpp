// The idealized cerebral aneurysm as a shell (studies/structures/aneurysm_*.toml, studies/meshes/
// aneurysm.geo): the scene's pressure path to 0.025 MPa, with the mesh's size, the wall time, Newton
// iterations, where the time goes (assembly against the linear solver's analysis, factorization and
// solves) and the peak memory, and the sac's maximum principal stress and stretch.
// Usage (in the source tree): bench_shell_aneurysm [scene=studies/structures/aneurysm_gent_fine.toml] [t_end=1]
// (t_end < 1 stops early: one step to a small pressure gives the cost of a Newton iteration)
// (the .geo is meshed into $SOFTHOM_MESH_CACHE, or <temp>/softhom-mesh-cache, once).
#include <chrono>
#include <ctime>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "softhom/io/files.hpp"
#include "softhom/io/scene.hpp"
#include "softhom/macro/scene.hpp"
#include "softhom/macro/structures.hpp"

using namespace softhom;

namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// CPU seconds of this process (all threads): comparable across runs on a shared machine.
double cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

/// The value of the probe `name` of the shell's report at the simulation's state.
double probe(const macro::Structure& s, const fe::Simulation& sim, const std::string& name) {
  fe::ContributionReport r;
  fe::Iterate it;
  const std::vector<double> u = sim.displacement();
  it.u = &u;
  s.shell->report(s.model.mesh, it, r);
  for (const auto& [n, v] : r.probes)
    if (n == name) return v;
  return 0.0;
}

}  // namespace

int main(int argc, char** argv) {
  std::setvbuf(stdout, nullptr, _IOLBF, 0);  // progress lines as they come (long runs, redirected)
  const std::string scene = argc > 1 ? argv[1] : "studies/structures/aneurysm_gent_fine.toml";  // from the source tree
  const double t_end = argc > 2 ? std::atof(argv[2]) : 1.0;  // stop at this time of the path (cost per iteration)
  auto t0 = std::chrono::steady_clock::now();
  const macro::MacroScene m = macro::parse_macro_scene(io::load_scene(scene), scene);
  const double mesh_time = seconds_since(t0);
  t0 = std::chrono::steady_clock::now();
  const macro::Structure s = macro::build_structure(m.spec);
  fe::Simulation sim(s.model, m.newton);
  const double setup = seconds_since(t0);
  std::printf("%s\ntriangles %zu, free dofs %d, meshing + reading %.1f s, setup %.1f s\n", scene.c_str(),
              s.shell->triangles().size(), sim.num_free_dofs(), mesh_time, setup);
  std::printf("%8s %10s %8s %10s %10s %10s %8s %14s %14s\n", "t", "p [MPa]", "Newton", "wall [s]", "CPU [s]", "step its",
              "cuts", "sac σ1 [MPa]", "sac λ1 [-]");
  t0 = std::chrono::steady_clock::now();
  const double cpu0 = cpu_seconds();
  bool ok = true;
  for (double t : m.times) {
    if (t <= 0.0) continue;
    if (t > t_end) t = t_end;
    const fe::AdvanceResult a = sim.advance_to(t);
    if (!a.reached()) {
      std::printf("stopped at t = %g: %s\n", t, a.message.c_str());
      ok = false;
      break;
    }
    std::printf("%8.3f %10.5f %8d %10.1f %10.1f %10d %8d %14.7g %14.6f\n", t, m.spec.load(t), sim.stats().newton_iterations,
                seconds_since(t0), cpu_seconds() - cpu0, a.counts.newton_iterations, a.counts.cutbacks,
                probe(s, sim, "shell sac max principal stress [MPa]"),
                probe(s, sim, "shell sac max principal stretch [-]"));
    if (t >= t_end) break;
  }
  const double wall = seconds_since(t0);
  const fe::RunStats st = sim.stats();
  const int it = std::max(1, st.newton_iterations);
  const double cpu = cpu_seconds() - cpu0;
  std::printf("%s: %.1f s wall, %.1f s CPU, %d Newton iterations (%d cut-backs), %.2f s wall per iteration\n",
              ok ? "reached" : "stopped", wall, cpu, st.newton_iterations, st.cutbacks, wall / it);
  std::printf("assembly %.1f s (%d with tangent, %d residual only), "
              "linear: analysis %.1f s, factorization %.1f s (%d), solves %.1f s (%d, %d GMRES iterations); %s: %s\n",
              st.assembly_time, st.tangent_assemblies, st.residual_assemblies,
              st.linear.analysis, st.linear.factorization, st.linear.factorizations, st.linear.solve, st.linear.solves,
              st.krylov_iterations, st.linear_solver.route.c_str(), st.linear_solver.description.c_str());
  std::printf("peak memory %.2f GiB\n", io::peak_memory_bytes() / 1073741824.0);
  return ok ? 0 : 1;
}
