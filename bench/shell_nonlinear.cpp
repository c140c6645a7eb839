// Geometrically nonlinear shell benchmarks of Sze, Liu & Lo (2004) with the rotation-free triangle
// (macro/shell_benchmarks.hpp):
//  1. the hemisphere with an 18° hole under alternating radial forces to P = 400, cells 8..max per
//     quarter edge: the radial displacements of the load points against the published 4.067 and 8.178;
//  2. the cantilever rolled into a circle by an end moment (fe::ShellEdgeMoment), cells along the
//     length 12..max (cells/12 across): the tip against Euler's closed form at every twentieth of
//     M_max, the error over L, and the fraction of M_max reached (the run stops where Newton does); then
//     again with u_y = 0 held (make_rolled_cantilever: the free strip drifts sideways and stops short of
//     M_max), to θ = 2π.
//  3. the open cylinder pulled out by two opposite radial forces to P = 40 000, cells 8..max along its half
//     length (1.5× around the quarter): w_A, −u_B and −u_C against Sze et al.'s table.
// Each prints wall time, Newton iterations, peak memory, the error, and the observed order from three
// successive meshes. Usage: bench_shell_nonlinear [max_hemisphere_cells=64] [max_cantilever_cells=96]
// [cantilever cells along per cell across=12] [hemisphere load steps=20] [max_pullout_cells=32]
// [pullout load steps=40]; SHELL_BENCH_TRACE=1 prints the
// cantilever's tip at every step.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "softhom/io/files.hpp"
#include "softhom/macro/shell_benchmarks.hpp"

using namespace softhom;
using namespace softhom::macro;

namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// log2 of successive differences of three solutions on meshes halved in turn (NaN when not monotone).
double observed_order(double coarse, double mid, double fine) {
  return std::log2(std::abs(mid - coarse) / std::abs(fine - mid));
}

void hemisphere(int max_cells, int steps) {
  std::printf("hemisphere, 18° hole, P = 400 in %d steps (reference: u_A 4.067, -u_B 8.178, Sze et al. 2004)\n", steps);
  std::printf("%6s %8s %9s %9s %9s %9s %10s %7s %10s\n", "cells", "dofs", "u_A", "err A %", "-u_B", "err B %", "wall [s]", "Newton",
              "peak [GiB]");
  std::vector<double> ua, ub;
  for (int n = 8; n <= max_cells; n *= 2) {
    const auto t0 = std::chrono::steady_clock::now();
    const PinchedHemisphere h = make_pinched_hemisphere(n);
    fe::Simulation sim(h.structure.model);
    bool ok = true;
    for (int k = 1; k <= steps && ok; ++k) ok = sim.advance_to(double(k) / steps).reached();
    const auto& u = sim.displacement();
    ua.push_back(u[3 * h.node_a]);
    ub.push_back(-u[3 * h.node_b + 1]);
    std::printf("%6d %8d %9.4f %9.2f %9.4f %9.2f %10.2f %7d %10.3f%s\n", n, sim.num_free_dofs(), ua.back(),
                100 * (ua.back() / kHemisphereUaAt400 - 1), ub.back(), 100 * (ub.back() / kHemisphereUbAt400 - 1), seconds_since(t0),
                sim.stats().newton_iterations, io::peak_memory_bytes() / 1073741824.0, ok ? "" : " (stopped)");
  }
  for (std::size_t k = 2; k < ua.size(); ++k)
    std::printf("observed order (cells %d, %d, %d): A %.2f, B %.2f\n", 8 << (k - 2), 8 << (k - 1), 8 << k,
                observed_order(ua[k - 2], ua[k - 1], ua[k]), observed_order(ub[k - 2], ub[k - 1], ub[k]));
}

void pullout(int max_cells, int steps) {
  std::printf("open cylinder pulled out, P = 40000 in %d steps (reference: w_A %.3f, -u_B %.3f, -u_C %.3f, Sze et al. 2004)\n", steps,
              kPulloutWaAt40k, kPulloutUbAt40k, kPulloutUcAt40k);
  std::printf("%9s %8s %9s %8s %9s %8s %9s %8s %10s %7s %10s\n", "cells", "dofs", "w_A", "err %", "-u_B", "err %", "-u_C", "err %",
              "wall [s]", "Newton", "peak [GiB]");
  std::vector<double> wa;
  for (int n = 8; n <= max_cells; n *= 2) {
    const auto t0 = std::chrono::steady_clock::now();
    // Cells near square: the quarter circle (7.78) against the half length (5.18).
    const PulloutCylinder c = make_pullout_cylinder(3 * n / 2, n);
    fe::Simulation sim(c.structure.model);
    bool ok = true;
    for (int k = 1; k <= steps && ok; ++k) ok = sim.advance_to(double(k) / steps).reached();
    const auto& u = sim.displacement();
    const double a = u[3 * c.node_a + 1], b = -u[3 * c.node_b], cc = -u[3 * c.node_c];
    wa.push_back(a);
    std::printf("%4d x %2d %8d %9.4f %8.2f %9.4f %8.2f %9.4f %8.2f %10.2f %7d %10.3f%s\n", 3 * n / 2, n, sim.num_free_dofs(), a,
                100 * (a / kPulloutWaAt40k - 1), b, 100 * (b / kPulloutUbAt40k - 1), cc, 100 * (cc / kPulloutUcAt40k - 1),
                seconds_since(t0), sim.stats().newton_iterations, io::peak_memory_bytes() / 1073741824.0, ok ? "" : " (stopped)");
  }
  for (std::size_t k = 2; k < wa.size(); ++k)
    std::printf("observed order of w_A (cells %d, %d, %d): %.2f\n", 8 << (k - 2), 8 << (k - 1), 8 << k,
                observed_order(wa[k - 2], wa[k - 1], wa[k]));
}

/// Largest |u_y| over the nodes: the exact solution (ν = 0) stays in the x–z plane.
double max_lateral(const std::vector<double>& u) {
  double m = 0.0;
  for (std::size_t q = 1; q < u.size(); q += 3) m = std::max(m, std::abs(u[q]));
  return m;
}

void cantilever(int max_cells, int across_ratio, bool hold_lateral) {
  std::printf("cantilever rolled up by an end moment to M_max = 50π/3 in 20 steps (closed form: an arc, θ = M L / (E I))%s\n",
              hold_lateral ? ", u_y = 0 held" : "");
  std::printf("%6s %8s %12s %12s %12s %10s %10s %10s %7s %10s\n", "cells", "dofs", "max err/L", "err/L at π", "err/L at 2π",
              "max |u_y|", "reached", "wall [s]", "Newton", "peak [GiB]");
  std::vector<double> tip_u_half;  // u at M_max / 2 (θ = π) for the observed order
  for (int n = 12; n <= max_cells; n *= 2) {
    const auto t0 = std::chrono::steady_clock::now();
    const RolledCantilever c = make_rolled_cantilever(n, std::max(1, n / across_ratio), 1.0, hold_lateral);
    fe::Simulation sim(c.structure.model);
    double worst = 0.0, at_half = 0.0, at_full = NAN, reached = 0.0, lateral = 0.0;
    for (int k = 1; k <= 20; ++k) {
      const fe::AdvanceResult a = sim.advance_to(k / 20.0);
      if (!a.reached()) {
        std::printf("stopped at M = %.2f M_max: %s\n", (k - 1) / 20.0, a.message.c_str());
        break;
      }
      const auto& u = sim.displacement();
      const auto exact = c.tip(k / 20.0 * c.max_moment);
      const double err = std::hypot(u[3 * c.tip_node] - exact[0], u[3 * c.tip_node + 2] - exact[1]) / c.length;
      worst = std::max(worst, err);
      lateral = std::max(lateral, max_lateral(u));
      if (std::getenv("SHELL_BENCH_TRACE"))
        std::printf("  M %.2f: tip (%.4f, %.4f) exact (%.4f, %.4f), max |u_y| %.3g, Newton %d\n", k / 20.0, u[3 * c.tip_node],
                    u[3 * c.tip_node + 2], exact[0], exact[1], max_lateral(u), sim.stats().newton_iterations);
      if (k == 10) {
        at_half = err;
        tip_u_half.push_back(u[3 * c.tip_node]);
      }
      if (k == 20) at_full = err;
      reached = k / 20.0;
    }
    std::printf("%6d %8d %12.3e %12.3e %12.3e %10.3g %10.2f %10.2f %7d %10.3f\n", n, sim.num_free_dofs(), worst, at_half, at_full,
                lateral, reached, seconds_since(t0), sim.stats().newton_iterations, io::peak_memory_bytes() / 1073741824.0);
  }
  for (std::size_t k = 2; k < tip_u_half.size(); ++k)
    std::printf("observed order of the tip's u at θ = π (cells %d, %d, %d): %.2f\n", 12 << (k - 2), 12 << (k - 1), 12 << k,
                observed_order(tip_u_half[k - 2], tip_u_half[k - 1], tip_u_half[k]));
}

}  // namespace

int main(int argc, char** argv) {
  const int max_hemisphere = argc > 1 ? std::atoi(argv[1]) : 64;
  const int max_cantilever = argc > 2 ? std::atoi(argv[2]) : 96;
  hemisphere(max_hemisphere, argc > 4 ? std::atoi(argv[4]) : 20);
  const int across = argc > 3 ? std::atoi(argv[3]) : 12;
  cantilever(max_cantilever, across, false);
  cantilever(max_cantilever, across, true);
  pullout(argc > 5 ? std::atoi(argv[5]) : 32, argc > 6 ? std::atoi(argv[6]) : 40);
  return 0;
}
