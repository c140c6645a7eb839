// Thin-shell balloon benchmark (fe/shell.hpp through macro shell structures):
//  1. refinement: the incompressible neo-Hookean octant inflated by cavity-volume control through its
//     pressure maximum to V/V0 = 8, cells 8..64 per octant edge: the largest relative error of the
//     pressure against P = 2 (H/R) G (λ² − λ⁻⁴)/λ³ over 16 steps, wall time, observed order;
//  2. time per Newton iteration against unknowns on the CHOLMOD and PETSc paths: the octant under a
//     follower pressure (two steps up to P = 0.5 P_max).
// Usage: bench_shell_balloon [max_cells_refinement=64] [sizes=80,256] (sizes: cells per octant edge,
// ~1.5 n² dofs).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

#include "softhom/io/files.hpp"
#include "softhom/macro/structures.hpp"
#include "softhom/materials/laws.hpp"

using namespace softhom;
using namespace softhom::macro;

namespace {

constexpr double kR = 10.0, kH = 0.1, kG = 0.5;

double closed_form(double l) { return 2 * kH / kR * kG * (l * l - std::pow(l, -4)) / (l * l * l); }

StructureSpec octant(int cells, LoadControl control, PiecewiseLinear load) {
  NeoHookeanParams p;
  p.mu = kG;
  p.K = 1000 * kG;
  StructureSpec s;
  s.kind = StructureKind::shell;
  s.shell.shape = ShellShape::sphere_octant;
  s.shell.radius = kR;
  s.shell.cells = cells;
  s.shell.section = std::make_shared<ShellSection>(std::vector<ShellLayer>{{make_material(make_neo_hookean(p)), kH, 3}});
  s.control = control;
  s.load = std::move(load);
  return s;
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void refinement(int max_cells) {
  std::printf("refinement (volume control to V/V0 = 8, 16 steps)\n%6s %8s %12s %10s %8s %6s\n", "cells", "dofs", "max error", "wall [s]",
              "Newton", "order");
  double last = 0.0;
  for (int n = 8; n <= max_cells; n *= 2) {
    const auto t0 = std::chrono::steady_clock::now();
    const Structure s = build_structure(octant(n, LoadControl::volume, PiecewiseLinear{{0.0, 1.0}, {1.0, 8.0}}));
    fe::Simulation sim(s.model);
    double error = 0.0;
    for (int k = 1; k <= 16; ++k) {
      if (!sim.advance_to(k / 16.0).reached()) {
        std::printf("n = %d: stopped at step %d\n", n, k);
        break;
      }
      const double l = std::cbrt(probe_values(s, sim)[3]);
      error = std::max(error, std::abs(sim.cavity_pressure() - closed_form(l)) / closed_form(l));
    }
    const double wall = seconds_since(t0);
    std::printf("%6d %8d %12.4e %10.2f %8d %6s\n", n, sim.num_free_dofs(), error, wall, sim.stats().newton_iterations,
                last > 0 ? std::to_string(std::log2(last / error)).substr(0, 5).c_str() : "");
    last = error;
  }
}

void newton_cost(const std::vector<int>& sizes) {
  std::printf("time per Newton iteration (follower pressure, 2 steps)\n%8s %10s %8s %12s %12s %10s\n", "cells", "dofs", "solver",
              "s/iteration", "assembly [s]", "peak [GiB]");
  for (int n : sizes)
    for (fe::SolverKind kind : {fe::SolverKind::cholmod, fe::SolverKind::petsc}) {
      const Structure s = build_structure(octant(n, LoadControl::pressure, PiecewiseLinear{{0.0, 1.0}, {0.0, 0.5 * 0.0062}}));
      fe::NewtonOptions o;
      o.solver = kind;
      fe::Simulation sim(s.model, o);
      const auto t0 = std::chrono::steady_clock::now();
      bool ok = sim.advance_to(0.5).reached() && sim.advance_to(1.0).reached();
      const double wall = seconds_since(t0);
      const fe::RunStats st = sim.stats();
      std::printf("%8d %10d %8s %12.3f %12.2f %10.2f%s\n", n, sim.num_free_dofs(), fe::to_string(kind),
                  wall / std::max(1, st.newton_iterations), st.assembly_time, io::peak_memory_bytes() / 1073741824.0,
                  ok ? "" : " (stopped)");
    }
}

}  // namespace

int main(int argc, char** argv) {
  const int max_cells = argc > 1 ? std::atoi(argv[1]) : 64;
  std::vector<int> sizes{80, 256};
  if (argc > 2) {
    sizes.clear();
    std::stringstream ss(argv[2]);
    for (std::string item; std::getline(ss, item, ',');) sizes.push_back(std::atoi(item.c_str()));
  }
  refinement(max_cells);
  newton_cost(sizes);
  return 0;
}
