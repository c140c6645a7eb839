// Hertz indentation by the contact contribution (fe/contact.hpp), refined: a rigid sphere (R = 1) pressed
// 0.01 into a graded quarter block of neo-Hookean solid (G = 1, ν = 0.3), macro/contact_benchmarks.hpp.
// Per mesh: cells, h/a at the contact, the error of the Hertz coefficient of F(d) fitted beyond the far
// field's linear compliance (as a force error at equal indentation), the contact radius against Hertz's,
// the penetration, Newton iterations and time; then the observed order of the force error.
//
//   build/bench/bench_contact_hertz [max_level]     (levels 0 … 4, default 4)
//
// Mode `spheres`: two elastic spheres (R1 = 1, G1 = 1 on R2 = 2, G2 = 2, ν = 0.3) pressed together
// through the contact between deformable surfaces (macro::make_hertz_spheres_problem), refined: per mesh
// the error of the Hertz coefficient (effective radius and modulus of both bodies) as a force error at
// equal approach, the contact radius against Hertz's, Newton iterations, time and peak memory; then the
// observed order of the force error.
//
//   build/bench/bench_contact_hertz spheres [max_level]     (levels 0 … 3, default 3)
#include <chrono>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include <string>

#include "softhom/fe/solver.hpp"
#include "softhom/io/files.hpp"
#include "softhom/macro/contact_benchmarks.hpp"

using namespace softhom;

namespace {

void print_orders(const std::vector<double>& hs, const std::vector<double>& errs) {
  for (std::size_t k = 1; k < hs.size(); ++k)
    std::printf("observed order %zu→%zu: %.2f\n", k - 1, k, std::log(errs[k - 1] / errs[k]) / std::log(hs[k - 1] / hs[k]));
}

/// Force (the quarter's × 4) against travel − penetration over `steps` equal steps, kept from a quarter
/// of the travel on (a contact patch of at least 2 cells), with the last contact radius (the farthest
/// active point from the axis) and penetration. False when a step stops.
struct Series {
  std::vector<double> force, indentation;
  double radius = 0.0, penetration = 0.0;
};

template <class Problem>
bool press(const Problem& p, double travel, int steps, fe::Simulation& sim, Series& out) {
  for (int s = 1; s <= steps; ++s) {
    const double t = double(s) / steps;
    if (!sim.advance_to(t).reached()) {
      std::printf("stopped at t = %g\n", t);
      return false;
    }
    const fe::Iterate it = sim.converged_iterate(*p.contact);
    const fe::ContactTotals tot = p.contact->totals(p.model.mesh, it);
    if (s <= steps / 4) continue;
    out.force.push_back(4.0 * tot.normal_force);
    out.indentation.push_back(travel * t - tot.max_penetration);
    out.radius = 0.0;
    for (const Vec3& x : p.contact->active_positions(p.model.mesh, it)) out.radius = std::max(out.radius, std::hypot(x[0], x[1]));
    out.penetration = tot.max_penetration;
  }
  return true;
}

/// The series' Hertz coefficient against (3 / (4 E* √R))^{2/3}, as a force error at equal indentation.
double force_error(const Series& r, double modulus, double radius) {
  const double alpha = macro::hertz_coefficient(r.force, r.indentation);
  return std::pow(std::pow(3.0 / (4.0 * modulus * std::sqrt(radius)), 2.0 / 3.0) / alpha, 1.5) - 1.0;
}

int spheres(int max_level) {
  const int fine[] = {4, 6, 8, 12}, coarse[] = {4, 5, 6, 8};
  std::printf("%6s %8s %8s %12s %12s %12s %8s %8s %8s\n", "cells", "h/a", "dofs", "force_err", "radius_err", "pen/h",
              "newton", "time_s", "mem_MiB");
  std::vector<double> hs, errs;
  for (int level = 0; level <= max_level && level < 4; ++level) {
    const auto t0 = std::chrono::steady_clock::now();
    const macro::HertzSpheresProblem p = macro::make_hertz_spheres_problem(fine[level], coarse[level]);
    fe::Simulation sim(p.model);
    Series r;
    if (!press(p, p.approach, 8, sim, r)) return 1;
    const double error = force_error(r, p.effective_modulus, p.effective_radius);
    const std::vector<double>& force = r.force;
    const double a = r.radius, penetration = r.penetration;
    const double a_final = std::sqrt(p.effective_radius * p.approach), h_over_a = p.fine_size / a_final;
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("%6d %8.4f %8d %12.4e %12.4e %12.3e %8d %8.2f %8.0f\n", fine[level] + coarse[level], h_over_a,
                sim.num_free_dofs(), error, a / p.contact_radius(force.back()) - 1.0, penetration / p.fine_size,
                sim.stats().newton_iterations, seconds, double(io::peak_memory_bytes()) / (1 << 20));
    hs.push_back(h_over_a);
    errs.push_back(std::abs(error));
  }
  print_orders(hs, errs);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc > 1 && std::string(argv[1]) == "spheres") return spheres(argc > 2 ? std::atoi(argv[2]) : 3);
  const int max_level = argc > 1 ? std::atoi(argv[1]) : 4;
  const int fine[] = {4, 6, 8, 12, 16}, coarse[] = {4, 5, 6, 8, 10};
  std::printf("%6s %8s %8s %12s %12s %12s %8s %8s\n", "cells", "h/a", "dofs", "force_err", "radius_err", "pen/h",
              "newton", "time_s");
  std::vector<double> hs, errs;
  for (int level = 0; level <= max_level && level < 5; ++level) {
    const auto t0 = std::chrono::steady_clock::now();
    const macro::HertzProblem p = macro::make_hertz_problem(fine[level], coarse[level]);
    fe::Simulation sim(p.model);
    Series r;
    if (!press(p, p.depth, 8, sim, r)) return 1;
    const double error = force_error(r, p.effective_modulus, p.radius);
    const std::vector<double>& force = r.force;
    const double a = r.radius, penetration = r.penetration;
    const double a_hertz = p.contact_radius(force.back());
    const double h_over_a = 1.25 / fine[level];
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("%6d %8.4f %8d %12.4e %12.4e %12.3e %8d %8.2f\n", fine[level] + coarse[level], h_over_a,
                sim.num_free_dofs(), error, a / a_hertz - 1.0, penetration / (h_over_a * std::sqrt(p.depth)),
                sim.stats().newton_iterations, seconds);
    hs.push_back(h_over_a);
    errs.push_back(std::abs(error));
  }
  print_orders(hs, errs);
  return 0;
}
