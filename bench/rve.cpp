// FFT RVE benchmark: Newton/Krylov iterations versus stiffness contrast, matrix K/G and resolution;
// cost per Krylov iteration versus the FFTs alone. Plain program (no timing loop of Google
// Benchmark: one solve is already seconds). Usage:
//   bench_rve contrast [n ...]     fiber/matrix shear contrast 10 … 1e6, one load step λ = 1.05
//   bench_rve bulk [n ...]         matrix K/G 10 … 1.2e5 at contrast 230, λ = 1.5 in 8 steps, mixed (u,p)
//                                  Newton iteration on and off
//   bench_rve fftcost n            cost of one Krylov iteration vs a 9·nq-field FFT round trip
//   bench_rve resolution pdms|ecoflex [n ...]
//                                  time versus error of P11 at λ = 1.5 (8 steps) for each discretization,
//                                  error against the Richardson extrapolation of the two finest grids
#include <omp.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "softhom/fft/gradient.hpp"
#include "softhom/materials/laws.hpp"
#include "softhom/rve/fft_solver.hpp"
#include "softhom/rve/geometry.hpp"

using namespace softhom;
using namespace softhom::rve;

namespace {

PhaseImage circle_cell(int n) {
  FiberCellSpec spec;
  spec.shape = SectionShape::circle;
  spec.arrangement = Arrangement::square;
  spec.volume_fraction = 0.23;
  spec.radius = 0.2;
  return voxelize_section(generate_section(spec), n, n);
}

MixedControl ramp(double lambda, int steps) {
  MixedControl c = uniaxial_control(PiecewiseLinear{{0.0, 1.0}, {1.0, lambda}});
  c.times.clear();
  for (int s = 1; s <= steps; ++s) c.times.push_back(double(s) / steps);
  return c;
}
MixedControl one_step(double lambda) { return ramp(lambda, 1); }

void solve_and_print(const char* label, double value, int n, fft::Discretization d, MaterialPtr m, MaterialPtr f,
                     bool mixed = true, const MixedControl& control = one_step(1.05)) {
  FftSolverOptions o;
  o.mixed_pressure = mixed;
  o.discretization = d;
  o.tolerance = 1e-6;
  o.plan.rigor = fft::PlanRigor::measure;
  FftRveSolver solver(circle_cell(n), m, f, 45.0, Mat3::Identity(), o);
  const auto t0 = std::chrono::steady_clock::now();
  const RveRunResult r = solver.run(control);
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const int newton = r.total_newton_iterations, krylov = r.total_krylov_iterations;
  std::printf("%-8s %10.3g %5d %-9s %-5s %4s newton %4d krylov %6d krylov/newton %7.1f cutbacks %d shifted %d time %7.2f s P11 %.6g\n",
              label, value, n, fft::to_string(d), mixed ? "mixed" : "plain", r.completed ? "ok" : "FAIL", newton, krylov,
              newton ? double(krylov) / newton : 0.0, r.cutbacks, r.shifted_solves, s, r.steps.back().P(0, 0));
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  const std::string mode = argc > 1 ? argv[1] : "contrast";
  std::vector<int> sizes;
  for (int i = 2; i < argc; ++i) sizes.push_back(std::atoi(argv[i]));
  if (sizes.empty()) sizes = {32, 64, 128};
  std::printf("# threads %d\n", omp_get_max_threads());
  if (mode == "contrast") {
    // Matrix neo-Hookean μ = 1, K = 10 (K/G = 10); fiber μ = c, K = 10 c.
    for (double c : {10.0, 230.0, 1e3, 1e4, 1e6})
      for (int n : sizes)
        for (auto d : {fft::Discretization::rotated, fft::Discretization::hex, fft::Discretization::spectral})
          solve_and_print("contrast", c, n, d, make_material(make_neo_hookean({1.0, 10.0})),
                          make_material(make_neo_hookean({c, 10.0 * c})));
  } else if (mode == "bulk") {
    // Matrix Gent G = 0.017, Jm = 14, K = KG · G; glass fiber (contrast ≈ 230).
    for (double kg : {10.0, 1e2, 1e3, 1e4, 1.2e5})
      for (int n : sizes)
        for (bool mixed : {true, false})
          solve_and_print("K/G", kg, n, fft::Discretization::rotated,
                          make_material(make_gent_hgo({0.017, 14.0, 0.017 * kg, {}, FiberInvariant::full, true})),
                          make_material(make_neo_hookean(NeoHookeanParams::from_young(10.0, 0.3))), mixed, ramp(1.5, 8));
  } else if (mode == "resolution") {
    const std::string matrix = argc > 2 ? argv[2] : "pdms";
    sizes.clear();
    for (int i = 3; i < argc; ++i) sizes.push_back(std::atoi(argv[i]));
    if (sizes.empty()) sizes = {16, 32, 64, 128};
    const double G = matrix == "ecoflex" ? 0.017 : 0.65, Jm = matrix == "ecoflex" ? 14.0 : 5.0;
    const MaterialPtr m = make_material(make_gent_hgo({G, Jm, 2000.0, {}, FiberInvariant::full, true}));
    const MaterialPtr f = make_material(make_neo_hookean(NeoHookeanParams::from_young(10.0, 0.3)));
    for (auto d : {fft::Discretization::rotated, fft::Discretization::hex, fft::Discretization::spectral}) {
      std::vector<double> p11, secs;
      for (int n : sizes) {
        FftSolverOptions o;
        o.discretization = d;
        o.tolerance = 1e-7;
        FftRveSolver solver(circle_cell(n), m, f, 45.0, Mat3::Identity(), o);
        const auto t0 = std::chrono::steady_clock::now();
        const RveRunResult r = solver.run(ramp(1.5, 8));
        secs.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
        p11.push_back(r.completed ? r.steps.back().P(0, 0) : std::nan(""));
        std::printf("resolution %-8s %-9s n %4d %s P11 %.8g newton %d krylov %d time %.2f s mem/voxel %.0f B\n", matrix.c_str(),
                    fft::to_string(d), n, r.completed ? "ok" : "FAIL", p11.back(), r.total_newton_iterations,
                    r.total_krylov_iterations, secs.back(), double(solver.memory_bytes()) / double(n) / n);
        std::fflush(stdout);
      }
      const std::size_t k = p11.size();
      if (k >= 3) {
        // Observed order from the three finest grids (ratio 2), Richardson limit from the two finest.
        const double e1 = p11[k - 3] - p11[k - 2], e2 = p11[k - 2] - p11[k - 1];
        const double order = std::log2(std::abs(e1 / e2));
        const double limit = p11[k - 1] + (p11[k - 1] - p11[k - 2]) / (std::pow(2.0, order) - 1.0);
        for (std::size_t i = 0; i < k; ++i)
          std::printf("error %-8s %-9s n %4d rel.error %.3e time %.2f s\n", matrix.c_str(), fft::to_string(d), sizes[i],
                      std::abs(p11[i] - limit) / std::abs(limit), secs[i]);
        std::printf("order %-8s %-9s observed %.2f limit %.8g\n", matrix.c_str(), fft::to_string(d), order, limit);
      }
    }
  } else if (mode == "fftcost") {
    for (int n : sizes)
      for (auto d : {fft::Discretization::rotated, fft::Discretization::hex, fft::Discretization::spectral}) {
        fft::Grid g{{n, n, 1}, {1.0, 1.0, 1.0 / n}};
        fft::GradientOperator op(g, d);
        fft::BatchedFFT fftw(g, 9 * op.points(), {fft::PlanRigor::measure, 0, {}});
        const int reps = 20;
        const auto t0 = std::chrono::steady_clock::now();
        for (int i = 0; i < reps; ++i) {
          fftw.forward();
          fftw.backward();
        }
        const double fft_ms = 1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / reps;
        // One Newton step with a fixed number of Krylov iterations gives the per-iteration cost.
        FftSolverOptions o;
        o.discretization = d;
        o.max_newton_iterations = 1;
        o.max_cutbacks = 0;
        o.krylov_tolerance = 1e-30;
        o.max_krylov_iterations = 50;
        FftRveSolver solver(circle_cell(n), make_material(make_neo_hookean({1.0, 10.0})),
                            make_material(make_neo_hookean({100.0, 1000.0})), 45.0, Mat3::Identity(), o);
        const auto t1 = std::chrono::steady_clock::now();
        const RveRunResult r = solver.run(one_step(1.05));
        const double total_ms = 1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
        const int k = std::max(1, r.total_krylov_iterations);
        std::printf("fftcost %5d %-9s fft-roundtrip %8.3f ms  per-krylov %8.3f ms (%d its, incl. 2 evaluations)  ratio %.2f  mem/voxel %.0f B\n",
                    n, fft::to_string(d), fft_ms, total_ms / k, k, total_ms / k / fft_ms,
                    double(solver.memory_bytes()) / double(n) / n);
        std::fflush(stdout);
      }
  }
  return 0;
}
