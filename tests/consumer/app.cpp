// Uses an installed softhom through its public headers: a material built from its description, evaluated
// at a simple shear, and a material-point run under uniaxial stress, each against a closed form.
#include <cmath>
#include <cstdio>

#include "softhom/materials/driver.hpp"
#include "softhom/materials/library.hpp"
#include "softhom/materials/loading.hpp"
#include "softhom/rve/fft_solver.hpp"

int main() {
  using namespace softhom;
  // Isochoric neo-Hookean: at a simple shear F = I + γ e1 ⊗ e2 (J = 1, no volumetric stress)
  // P12 = μ γ exactly, so only round-off separates the two (1e-12 relative is ~1e4 ulp).
  MaterialSpec spec;
  spec.law = LawKind::neo_hookean;
  spec.neo_hookean.mu = 0.5;
  spec.neo_hookean.K = 50.0;
  const MaterialPtr material = build_material(spec);
  const double gamma = 0.3;
  Mat3 F = Mat3::Identity();
  F(0, 1) = gamma;
  Mat3 P;
  Mat9 A;
  if (material->evaluate(F, nullptr, nullptr, 0.0, P, &A) != MaterialStatus::ok) return 1;
  const double p12_error = std::abs(P(0, 1) - spec.neo_hookean.mu * gamma) / (spec.neo_hookean.mu * gamma);
  std::printf("simple shear: P12 = %.15g (closed form %.15g), relative error %.2e\n", P(0, 1),
              spec.neo_hookean.mu * gamma, p12_error);
  if (!(p12_error < 1e-12)) return 1;

  // Uniaxial stress to λ = 1.2 with the material-point driver: the lateral stretches are solved for
  // (P22 = P33 = 0), and the incompressible-limit closed form P11 = μ (λ − λ⁻²) holds to O(μ/K) = 1 %;
  // 3 % leaves room for the compressibility of K/μ = 100 and fails on any wrong wiring of the driver.
  MixedControl control = uniaxial_control(PiecewiseLinear{{0.0, 1.0}, {1.0, 1.2}});
  control.times = {0.25, 0.5, 0.75, 1.0};
  const PointRunResult run = run_material_point(*material, control);
  if (!run.completed) return 1;
  const double lambda = run.steps.back().F(0, 0), p11 = run.steps.back().P(0, 0);
  const double closed = spec.neo_hookean.mu * (lambda - 1.0 / (lambda * lambda));
  std::printf("uniaxial: lambda = %.6g, P11 = %.9g (incompressible closed form %.9g)\n", lambda, p11, closed);
  if (!(std::abs(lambda - 1.2) < 1e-12 && std::abs(p11 - closed) < 0.03 * closed)) return 1;

  // softhom::rve brings the RVE engine; naming one of its types checks that its headers are usable.
  const rve::FftSolverOptions rve_defaults;
  std::printf("FFT RVE default tolerance %g\n", rve_defaults.tolerance);
  std::printf("consumer: ok\n");
  return 0;
}
