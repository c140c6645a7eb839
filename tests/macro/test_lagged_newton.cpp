// The large-mesh Newton path on a small capped ecoflex helix tube (K/G ≈ 1.2e5, three-field iteration):
// the quadratic load predictor, the residual-first convergence test and the lagged factor with GMRES in
// the uncondensed (u, p_e) space must change the iteration only, never the converged state. The lagged
// path normally starts at 2 GFlop per factorization (1e5-dof tubes); lag_flops = 0 forces it here.
#include <gtest/gtest.h>

#include <cmath>

#include "softhom/macro/structures.hpp"
#include "softhom/materials/laws.hpp"

using namespace softhom;
using namespace softhom::macro;

namespace {

Structure tube() {
  StructureSpec spec;
  spec.kind = StructureKind::tube;
  spec.tube.inner_radius = 5.0;
  spec.tube.outer_radius = 7.5;
  spec.tube.length = 30.0;
  spec.tube.radial_cells = 2;
  spec.tube.circumferential_cells = 16;
  spec.tube.axial_cells = 10;
  spec.tube.sweep_deg = 360.0;
  spec.tube.cap_thickness = 2.5;
  GentHGOParams p;  // the ecoflex-anisotropic helix of bench_macro
  p.G = 0.017;
  p.Jm = 14.0;
  p.K = 2000.0;
  const double a = 45.0 * M_PI / 180.0;
  p.fibers = {{Vec3(std::sin(a), std::cos(a), 0.0), 0.8, 18.0}, {Vec3(-std::sin(a), std::cos(a), 0.0), 0.8, 18.0}};
  spec.material = make_material(make_gent_hgo(p));
  spec.fiber_frame = FiberFrame::cylindrical;
  spec.control = LoadControl::pressure;
  spec.load = {{0.0, 1.0}, {0.0, 0.01}};
  return build_structure(spec);
}

struct TubeRun {
  double axial, stretch;
  fe::RunStats stats;
};

TubeRun inflate(const fe::NewtonOptions& o, int steps = 8) {
  const Structure s = tube();
  fe::Simulation sim(s.model, o);
  for (int k = 1; k <= steps; ++k) EXPECT_TRUE(sim.advance_to(double(k) / steps).reached());
  const auto v = probe_values(s, sim);  // time, pressure, volume, inner_radius, stretch, axial_stretch, twist_deg
  return {v[5], v[4], sim.stats()};
}

// The converged states agree to the Newton tolerance (‖R‖ ≤ 1e-8 × force scale; the stretches of this
// mesh move by O(1e-2) over the ramp, so 1e-7 relative leaves two decades of margin over the
// tolerance's effect and is far below any change of the discretization).
constexpr double kSame = 1e-7;

}  // namespace

TEST(LaggedNewton, QuadraticPredictorSameStateFewerIterations) {
  fe::NewtonOptions secant, quadratic;
  secant.extrapolate_order = 1;
  quadratic.extrapolate_order = 2;
  const TubeRun a = inflate(secant), b = inflate(quadratic);
  std::cerr << "secant: Newton " << a.stats.newton_iterations << ", quadratic: " << b.stats.newton_iterations
            << "; axial " << a.axial << " / " << b.axial << "\n";
  EXPECT_NEAR(b.axial, a.axial, kSame * a.axial);
  EXPECT_NEAR(b.stretch, a.stretch, kSame * a.stretch);
  EXPECT_EQ(a.stats.cutbacks, 0);
  EXPECT_EQ(b.stats.cutbacks, 0);
  // The quadratic start leaves an O(Δ³) instead of O(Δ²) error: never more iterations on this smooth ramp.
  EXPECT_LE(b.stats.newton_iterations, a.stats.newton_iterations);
}

TEST(LaggedNewton, ResidualFirstSkipsOnlyTangents) {
  fe::NewtonOptions full, first;
  full.residual_first = false;
  first.residual_first = true;
  const TubeRun a = inflate(full), b = inflate(first);
  // With a fresh factor per iteration (small mesh: direct solves) the iterates are identical: same count,
  // same state to round-off.
  EXPECT_EQ(b.stats.newton_iterations, a.stats.newton_iterations);
  EXPECT_NEAR(b.axial, a.axial, 1e-12);
  EXPECT_NEAR(b.stretch, a.stretch, 1e-12);
}

TEST(LaggedNewton, UncondensedKrylovWithLaggedFactorSameState) {
  fe::NewtonOptions direct, saddle, condensed;
  saddle.lag_flops = 0.0;  // keep every factorization: GMRES with lagged factors from the first step on
  condensed.lag_flops = 0.0;
  condensed.saddle_krylov = false;
  const TubeRun a = inflate(direct), b = inflate(saddle), c = inflate(condensed);
  std::cerr << "direct: Newton " << a.stats.newton_iterations << ", factorizations " << a.stats.linear.factorizations
            << "; saddle: Newton " << b.stats.newton_iterations << ", factorizations " << b.stats.linear.factorizations
            << ", GMRES " << b.stats.krylov_iterations << "; condensed: Newton " << c.stats.newton_iterations
            << ", factorizations " << c.stats.linear.factorizations << ", GMRES " << c.stats.krylov_iterations << "\n";
  EXPECT_NEAR(b.axial, a.axial, kSame * a.axial);
  EXPECT_NEAR(b.stretch, a.stretch, kSame * a.stretch);
  EXPECT_NEAR(c.axial, a.axial, kSame * a.axial);
  EXPECT_EQ(b.stats.cutbacks, 0);
  // The lagged path was taken: fewer factorizations than Newton iterations, and GMRES did the rest.
  EXPECT_LT(b.stats.linear.factorizations, b.stats.newton_iterations);
  EXPECT_GT(b.stats.krylov_iterations, 0);
}
