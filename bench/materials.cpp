// Material-point kernel throughput: stress (+ tangent) evaluations per second on one core.
//
//   bench_materials --benchmark_filter=. [--benchmark_repetitions=5]
//
// Every benchmark cycles through 256 precomputed deformation gradients (random rotations, stretches
// in ±30 %, J in [0.9, 1.1]: fibers in tension and compression), the way a solver sweeps its voxels,
// so neither branch prediction nor constant folding sees one repeated input. items/s = material calls/s.
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include <Eigen/Geometry>

#include "softhom/materials/laws.hpp"

using namespace softhom;

namespace {

constexpr int kPoints = 256;

std::vector<Mat3> deformations() {
  std::mt19937 rng(2024);
  std::normal_distribution<double> n(0.0, 1.0);
  std::uniform_real_distribution<double> u(-0.3, 0.3), uj(0.9, 1.1);
  const auto rotation = [&] {
    Eigen::Quaterniond q(n(rng), n(rng), n(rng), n(rng));
    q.normalize();
    return Mat3(q.toRotationMatrix());
  };
  std::vector<Mat3> Fs;
  for (int k = 0; k < kPoints; ++k) {
    Vec3 e(u(rng), u(rng), u(rng));
    e.array() -= e.mean();
    const Vec3 l = e.array().exp() * std::cbrt(uj(rng));
    Fs.push_back(rotation() * l.asDiagonal() * rotation());
  }
  return Fs;
}

ElasticLawPtr gent() { return make_gent_hgo({0.017, 14.0, 2000.0, {}, FiberInvariant::full, true}); }

ElasticLawPtr gent_2hgo(FiberInvariant inv = FiberInvariant::full) {
  GentHGOParams p{0.017, 14.0, 2000.0, {}, inv, true};
  // ecoflex-anisotropic, two families at ±30° in the plate plane (spec §7)
  p.fibers = {{Vec3(0.5, 0.866, 0.0), 0.8, 18.0}, {Vec3(-0.5, 0.866, 0.0), 0.8, 18.0}};
  return make_gent_hgo(p);
}

PronySeries prony3() { return {0.4, {{0.3, 1.0}, {0.2, 10.0}, {0.1, 100.0}}}; }

void run(benchmark::State& state, const Material& m, bool tangent) {
  const auto Fs = deformations();
  const int ns = m.state_size();
  // One history slice per point, as a solver stores it; the old state is never overwritten so every
  // iteration does the same work.
  std::vector<double> old(std::size_t(kPoints) * ns), fresh(std::size_t(ns) + 1);
  for (int k = 0; k < kPoints; ++k)
    if (ns) m.init_state(old.data() + std::size_t(k) * ns);
  Mat3 P;
  Mat9 A;
  Mat9* Ap = tangent ? &A : nullptr;
  int k = 0;
  int failures = 0;
  for (auto _ : state) {
    const MaterialStatus st =
        m.evaluate(Fs[k], ns ? old.data() + std::size_t(k) * ns : nullptr, ns ? fresh.data() : nullptr, 0.1, P, Ap);
    failures += st != MaterialStatus::ok;
    benchmark::DoNotOptimize(P.data());
    if (tangent) benchmark::DoNotOptimize(A.data());
    benchmark::ClobberMemory();
    k = (k + 1) & (kPoints - 1);
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["failures"] = failures;
}

// Generic route for comparison: second_piola (material CC) + piola_tangent_from_material.
void run_generic_route(benchmark::State& state, const ElasticLaw& law) {
  const auto Fs = deformations();
  Mat3 S, P;
  Mat9 CC, A;
  int k = 0;
  for (auto _ : state) {
    const Mat3& F = Fs[k];
    const Mat3 C = F.transpose() * F;
    law.second_piola(F, C, F.determinant(), S, &CC);
    P.noalias() = F * S;
    piola_tangent_from_material(F, S, CC, A);
    benchmark::DoNotOptimize(P.data());
    benchmark::DoNotOptimize(A.data());
    benchmark::ClobberMemory();
    k = (k + 1) & (kPoints - 1);
  }
  state.SetItemsProcessed(state.iterations());
}

void BM_Gent_StressTangent(benchmark::State& s) { run(s, *make_material(gent()), true); }
void BM_Gent_Stress(benchmark::State& s) { run(s, *make_material(gent()), false); }
void BM_Gent2HGO_StressTangent(benchmark::State& s) { run(s, *make_material(gent_2hgo()), true); }
void BM_Gent2HGO_Stress(benchmark::State& s) { run(s, *make_material(gent_2hgo()), false); }
void BM_Gent2HGOIsochoric_StressTangent(benchmark::State& s) {
  run(s, *make_material(gent_2hgo(FiberInvariant::isochoric)), true);
}
void BM_Gent2HGO_QLV3_StressTangent(benchmark::State& s) { run(s, *make_material(gent_2hgo(), prony3()), true); }
void BM_Gent2HGO_QLV3_Stress(benchmark::State& s) { run(s, *make_material(gent_2hgo(), prony3()), false); }
void BM_Gent2HGO_GenericRoute_StressTangent(benchmark::State& s) { run_generic_route(s, *gent_2hgo()); }
void BM_NeoHookean_StressTangent(benchmark::State& s) {
  run(s, *make_material(make_neo_hookean(NeoHookeanParams::from_young(10.0, 0.3))), true);
}
void BM_Ogden3_StressTangent(benchmark::State& s) {
  run(s, *make_material(make_ogden({{0.0111, 1.119e-5, 0.0114}, {2.393, 8.123, -2.168}, 2000.0})), true);
}

}  // namespace

BENCHMARK(BM_Gent_StressTangent);
BENCHMARK(BM_Gent_Stress);
BENCHMARK(BM_Gent2HGO_StressTangent);
BENCHMARK(BM_Gent2HGO_Stress);
BENCHMARK(BM_Gent2HGOIsochoric_StressTangent);
BENCHMARK(BM_Gent2HGO_QLV3_StressTangent);
BENCHMARK(BM_Gent2HGO_QLV3_Stress);
BENCHMARK(BM_Gent2HGO_GenericRoute_StressTangent);
BENCHMARK(BM_NeoHookean_StressTangent);
BENCHMARK(BM_Ogden3_StressTangent);

BENCHMARK_MAIN();
