// Ironing (Puso & Laursen 2004, CMAME 193; macro/contact_benchmarks.hpp): a rigid cylindrical die pressed
// 1.0 into a neo-Hookean block (E = 1, ν = 0.3) and slid 10 along it with Coulomb friction μ = 0.3. The
// die is rigid in this version (the published die is a stiff elastic body, E = 1000). Per mesh: the
// die's reaction forces F_x (against the sliding) and F_z (holding it down) at every step, then over the
// slide past its start-up (t ≥ 1.25, the die 2.5 along): their mean, the ratio F_x/F_z, and the largest
// step-to-step change of each relative to its mean (how smooth the forces are in time), the penetration,
// Newton iterations and CPU time.
//
//   build/bench/bench_ironing [max_cells_per_unit] [steps_of_the_slide] [friction]     (default 2, 40, 0.3)
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <vector>

#include "softhom/fe/solver.hpp"
#include "softhom/macro/contact_benchmarks.hpp"

using namespace softhom;

int main(int argc, char** argv) {
  const int max_cells = argc > 1 ? std::atoi(argv[1]) : 2;
  const int slide_steps = argc > 2 ? std::atoi(argv[2]) : 40;
  const double friction = argc > 3 ? std::atof(argv[3]) : 0.3;
  int status = 0;
  for (int cells = 1; cells <= max_cells; ++cells) {
    const double t0 = double(std::clock()) / CLOCKS_PER_SEC;
    const macro::IroningProblem p = macro::make_ironing_problem(cells, friction);
    fe::Simulation sim(p.model);
    std::printf("cells per unit %d: %d elements, %d free dofs\n%8s %10s %10s %8s %6s\n", cells,
                p.model.mesh.num_elements(), sim.num_free_dofs(), "t", "F_x", "F_z", "F_x/F_z", "newton");
    std::vector<double> fx, fz;
    double penetration = 0.0;
    const int press_steps = 10;
    for (int s = 1; s <= press_steps + slide_steps; ++s) {
      const double t = s <= press_steps ? double(s) / press_steps : 1.0 + double(s - press_steps) / slide_steps;
      const fe::AdvanceResult r = sim.advance_to(t);
      if (!r.reached()) {
        std::printf("stopped at t = %g\n", t);
        status = 1;
        break;
      }
      const fe::ContactTotals tot = p.contact->totals(p.model.mesh, sim.converged_iterate(*p.contact));
      const double Fx = -tot.force[0], Fz = -tot.force[2];  // the body's force on the die
      std::printf("%8.4f %10.5f %10.5f %8.4f %6d\n", t, Fx, Fz, Fz != 0.0 ? -Fx / Fz : 0.0, r.counts.newton_iterations);
      if (t >= 1.25 - 1e-12) {
        fx.push_back(Fx);
        fz.push_back(Fz);
        penetration = std::max(penetration, tot.max_penetration);
      }
    }
    if (fx.size() < 2) continue;
    auto mean = [](const std::vector<double>& v) {
      double s = 0.0;
      for (double x : v) s += x;
      return s / double(v.size());
    };
    auto jump = [](const std::vector<double>& v) {
      double j = 0.0;
      for (std::size_t k = 1; k < v.size(); ++k) j = std::max(j, std::abs(v[k] - v[k - 1]));
      return j;
    };
    const double mx = mean(fx), mz = mean(fz);
    std::printf("slide t >= 1.25: mean F_x %.5f, F_z %.5f, F_x/F_z %.4f; largest step change F_x %.2f %%, F_z %.2f %%; "
                "penetration %.3e; %d Newton iterations, %.1f s CPU\n",
                mx, mz, -mx / mz, 100.0 * jump(fx) / std::abs(mx), 100.0 * jump(fz) / std::abs(mz), penetration,
                sim.stats().newton_iterations, double(std::clock()) / CLOCKS_PER_SEC - t0);
  }
  return status;
}
