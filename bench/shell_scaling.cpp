// Time per Newton iteration of the shell against unknowns, one size and one linear-solver route per
// process (so that the peak memory is that run's): the thin sphere octant (R = 10 mm, H = 0.1 mm,
// neo-Hookean G = 0.5 MPa, symmetry edges) inflated by a follower pressure to a quarter of its
// pressure maximum in one step, where the route's costs per iteration are those of every later step
// (assembly, factorization or preconditioner set-up, solves).
// Usage: bench_shell_scaling cells [route=cholmod|umfpack|petsc] [steps=1]   (~1.5 cells² free dofs)
// Prints one row; bench/shell_scaling.py runs the sizes and draws the figure of BENCHMARKS.md.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <string>

#include "softhom/io/files.hpp"
#include "softhom/macro/structures.hpp"
#include "softhom/materials/laws.hpp"

using namespace softhom;
using namespace softhom::macro;

namespace {

constexpr double kRadius = 10.0, kThickness = 0.1, kShear = 0.5;
/// The octant's pressure maximum 2 (H/R) G · max (λ² − λ⁻⁴)/λ³ = 0.0124 · 0.620 (at λ = 7^(1/6)).
constexpr double kPressureMaximum = 0.0062;

StructureSpec inflated_octant(int cells, double pressure) {
  NeoHookeanParams p;
  p.mu = kShear;
  p.K = 1000 * kShear;
  StructureSpec s;
  s.kind = StructureKind::shell;
  s.shell.shape = ShellShape::sphere_octant;
  s.shell.radius = kRadius;
  s.shell.cells = cells;
  s.shell.section = std::make_shared<ShellSection>(std::vector<ShellLayer>{{make_material(make_neo_hookean(p)), kThickness, 3}});
  s.control = LoadControl::pressure;
  s.load = PiecewiseLinear{{0.0, 1.0}, {0.0, pressure}};
  return s;
}

double wall_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

double process_cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

fe::SolverKind route_kind(const std::string& route) {
  if (route == "umfpack") return fe::SolverKind::umfpack;
  if (route == "petsc") return fe::SolverKind::petsc;
  return fe::SolverKind::cholmod;
}

}  // namespace

int main(int argc, char** argv) {
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  const int cells = argc > 1 ? std::atoi(argv[1]) : 80;
  const std::string route = argc > 2 ? argv[2] : "cholmod";
  const int steps = argc > 3 ? std::max(1, std::atoi(argv[3])) : 1;
  auto t0 = std::chrono::steady_clock::now();
  const Structure s = build_structure(inflated_octant(cells, 0.25 * kPressureMaximum));
  fe::NewtonOptions o;
  o.solver = route_kind(route);
  fe::Simulation sim(s.model, o);
  const double setup = wall_since(t0);
  t0 = std::chrono::steady_clock::now();
  const double cpu0 = process_cpu_seconds();
  bool ok = true;
  for (int k = 1; k <= steps && ok; ++k) ok = sim.advance_to(double(k) / steps).reached();
  const double wall = wall_since(t0), cpu = process_cpu_seconds() - cpu0;
  const fe::RunStats st = sim.stats();
  const int its = std::max(1, st.newton_iterations);
  const int factorizations = std::max(1, st.linear.factorizations);
  std::printf("# cells dofs route newton wall/it[s] cpu/it[s] assembly/it[s] factorization[s] solve/it[s] factorizations "
              "krylov peak[GiB] setup[s] description\n");
  std::printf("%d %d %s %d %.3f %.3f %.3f %.3f %.3f %d %d %.2f %.1f %s%s\n", cells, sim.num_free_dofs(), route.c_str(),
              st.newton_iterations, wall / its, cpu / its, st.assembly_time / its, st.linear.factorization / factorizations,
              st.linear.solve / its, st.linear.factorizations, st.krylov_iterations, io::peak_memory_bytes() / 1073741824.0, setup,
              st.linear_solver.description.c_str(), ok ? "" : " (stopped)");
  return ok ? 0 : 1;
}
