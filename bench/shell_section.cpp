// Plane-stress condensation and shell-section throughput on one core, and the Newton iterations the
// compressible mode spends on the thickness stretch λ3: cold (no guess: J = 1), warm from the previous
// step's λ3 or from its J (both converged at a strain 2 % smaller, as an element has them from its
// previous load step).
//
//   bench_shell_section --benchmark_min_time=1 --benchmark_repetitions=3 --benchmark_report_aggregates_only=true
//
// Every benchmark cycles through 256 in-plane Green–Lagrange strains (E11, E22 ∈ [−0.1, 0.2], 2E12 ∈
// ±0.2) inside the Gent limit of the dissertation's vessel (G = 0.0024 MPa, Jm = 0.9, k1 = 0.001 MPa,
// k2 = 1.2, K = 2000 MPa). items/s = point (or section) evaluations per second; "newton" = law
// evaluations per point.
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "softhom/materials/laws.hpp"
#include "softhom/materials/shell_section.hpp"

using namespace softhom;

namespace {

constexpr int kPoints = 256;
constexpr double kK = 2000.0;

GentHGOParams vessel(std::vector<double> angles, double kappa) {
  GentHGOParams p{0.0024, 0.9, kK, {}, FiberInvariant::full, true};
  for (const double a : angles) p.fibers.push_back({in_plane_direction(a), 0.001, 1.2, kappa});
  return p;
}

MaterialPtr law_named(const std::string& name) {
  if (name == "neo-Hookean") return make_material(make_neo_hookean({0.0024, kK}));
  if (name == "Gent") return make_material(make_gent_hgo(vessel({}, 0.0)));
  if (name == "Yeoh") return make_material(make_yeoh({0.008, 4e-5, 4e-5, kK}));
  if (name == "Ogden") return make_material(make_ogden({{0.0111, 1.119e-5, 0.0114}, {2.393, 8.123, -2.168}, kK}));
  if (name == "Gent+HGO") return make_material(make_gent_hgo(vessel({30.0}, 0.1)));
  return make_material(make_gent_hgo(vessel({30.0}, 0.1)), PronySeries{0.4, {{0.3, 1.0}, {0.3, 10.0}}});
}

/// Strains whose every point is admissible for every law (Ī1 − 3 < Jm at J = 1 is checked by calling).
std::vector<Vec3v> strains(const Material& law) {
  std::mt19937 rng(2026);
  std::uniform_real_distribution<double> u(-0.1, 0.2), s(-0.2, 0.2);
  std::vector<Vec3v> out;
  std::vector<double> old(std::size_t(law.state_size()) + 1), fresh = old;
  law.init_state(old.data());
  PlaneStressPoint p;
  while (int(out.size()) < kPoints) {
    const Vec3v E(u(rng), u(rng), s(rng));
    if (plane_stress(law, E, old.data(), fresh.data(), 0.0, PlaneStressMode::incompressible, p) == MaterialStatus::ok)
      out.push_back(E);
  }
  return out;
}

enum class Start { cold, lambda3, J };

void point(benchmark::State& state, const std::string& name, PlaneStressMode mode, Start start) {
  const MaterialPtr law = law_named(name);
  const auto Es = strains(*law);
  const int ns = law->state_size();
  std::vector<double> old(std::size_t(ns) + 1), fresh(std::size_t(ns) + 1);
  law->init_state(old.data());
  // Warm guesses: λ3 or J at 98 % of each strain.
  std::vector<PlaneStressPoint> guess(kPoints);
  for (int k = 0; k < kPoints; ++k) {
    PlaneStressPoint p;
    plane_stress(*law, 0.98 * Es[k], old.data(), fresh.data(), 0.1, mode, p);
    guess[k].lambda3 = start == Start::lambda3 ? p.lambda3 : 0.0;
    guess[k].J = start == Start::J ? p.J : 0.0;
  }
  long iterations = 0, failures = 0;
  int k = 0;
  PlaneStressPoint p;
  for (auto _ : state) {
    p.lambda3 = guess[k].lambda3;
    p.J = guess[k].J;
    failures += plane_stress(*law, Es[k], old.data(), fresh.data(), 0.1, mode, p) != MaterialStatus::ok;
    iterations += p.iterations;
    benchmark::DoNotOptimize(p.S.data());
    benchmark::DoNotOptimize(p.D.data());
    k = (k + 1) & (kPoints - 1);
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["newton"] = double(iterations) / double(state.iterations());
  state.counters["failures"] = double(failures);
}

/// A three-layer [+30 / −30 / +30] vessel section, 3 Lobatto points per layer (9 points), at
/// membrane strains of the list and a curvature of 0.05 /mm (h = 0.6 mm), with the tangent.
void section(benchmark::State& state, PlaneStressMode mode, bool warm) {
  const MaterialPtr plus = make_material(make_gent_hgo(vessel({30.0}, 0.0)));
  const MaterialPtr minus = make_material(make_gent_hgo(vessel({-30.0}, 0.0)));
  const ShellSection sec({{plus, 0.2}, {minus, 0.2}, {plus, 0.2}}, mode);
  const auto Es = strains(*plus);
  const Vec3v kappa(0.05, -0.05, 0.02);
  std::vector<SectionResponse> previous(kPoints);
  if (warm)
    for (int k = 0; k < kPoints; ++k) sec.evaluate(0.98 * Es[k], 0.98 * kappa, nullptr, nullptr, 0.0, false, previous[k]);
  long failures = 0;
  int k = 0;
  SectionResponse r;
  for (auto _ : state) {
    if (warm) r.points = previous[k].points;  // the element keeps one response per section
    failures += sec.evaluate(Es[k], kappa, nullptr, nullptr, 0.0, true, r) != MaterialStatus::ok;
    benchmark::DoNotOptimize(r.tangent.data());
    k = (k + 1) & (kPoints - 1);
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["failures"] = double(failures);
}

void register_all() {
  for (const std::string name : {"neo-Hookean", "Gent", "Yeoh", "Ogden", "Gent+HGO", "Gent+HGO+QLV"}) {
    benchmark::RegisterBenchmark(("point/" + name + "/incompressible").c_str(), point, name,
                                 PlaneStressMode::incompressible, Start::cold);
    benchmark::RegisterBenchmark(("point/" + name + "/compressible/cold").c_str(), point, name,
                                 PlaneStressMode::compressible, Start::cold);
    benchmark::RegisterBenchmark(("point/" + name + "/compressible/warm-lambda3").c_str(), point, name,
                                 PlaneStressMode::compressible, Start::lambda3);
    benchmark::RegisterBenchmark(("point/" + name + "/compressible/warm-J").c_str(), point, name,
                                 PlaneStressMode::compressible, Start::J);
  }
  benchmark::RegisterBenchmark("section9/incompressible", section, PlaneStressMode::incompressible, false);
  benchmark::RegisterBenchmark("section9/compressible/cold", section, PlaneStressMode::compressible, false);
  benchmark::RegisterBenchmark("section9/compressible/warm", section, PlaneStressMode::compressible, true);
}

}  // namespace

int main(int argc, char** argv) {
  register_all();
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
