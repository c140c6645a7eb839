// Cavity-volume control of tubes whose free end moves (clamped at z = 0): capped (the cavity faces
// close it) and open (closed by the moving plane z = z_end through the in-plane mask). The bordered
// Newton system must be the exact linearization of (R(u, p), V(u) − V̄): with ∂V/∂u = −a (the pressure
// vector) on the open tube Newton converged linearly (the volume error fell by ~5x per iteration),
// 54 iterations for these 5 steps; with the exact volume gradient 30 (capped: 20, where g = −a).
#include <gtest/gtest.h>

#include "softhom/macro/structures.hpp"
#include "softhom/materials/laws.hpp"

using namespace softhom;
using namespace softhom::macro;

namespace {

struct Inflation {
  int newton, cutbacks, steps;
  double axial, volume_error;
};

Inflation inflate(double cap) {
  GentHGOParams p;
  p.G = 0.017;
  p.Jm = 14.0;
  p.K = 2000.0;
  StructureSpec spec;
  spec.kind = StructureKind::tube;
  spec.tube = {5.0, 7.5, 20.0, 1, 12, 5, 360.0, cap, 1, 2, false};
  spec.material = make_material(make_gent_hgo(p));
  spec.control = LoadControl::volume;
  spec.load = {{0.0, 1.0}, {1.0, 1.5}};
  const Structure s = build_structure(spec);
  fe::NewtonOptions o;
  o.verbose = std::getenv("SOFTHOM_VERBOSE") != nullptr;
  fe::Simulation sim(s.model, o);
  const double v0 = fe::cavity_volume(s.model.mesh.nodes, s.model.cavity->faces, s.model.cavity->mask);
  const int steps = 5;
  for (int k = 1; k <= steps; ++k) EXPECT_TRUE(sim.advance_to(double(k) / steps).reached());
  const auto v = probe_values(s, sim);  // time, pressure, volume, inner_radius, stretch, axial, twist
  const fe::RunStats st = sim.stats();
  std::cerr << (cap > 0 ? "capped" : "open") << " tube, volume control: " << st.steps << " steps, "
            << st.newton_iterations << " Newton iterations, p = " << v[1] << ", axial " << v[5] << "\n";
  return {st.newton_iterations, st.cutbacks, st.steps, v[5], std::abs(v[2] / v0 - 1.5)};
}

}  // namespace

TEST(CavityNewton, TubesWithMovingEndConvergeQuadratically) {
  for (const double cap : {2.5, 0.0}) {
    const Inflation r = inflate(cap);
    EXPECT_EQ(r.cutbacks, 0);
    EXPECT_EQ(r.steps, 5);
    // The free end moves (the case of interest): the capped end is pushed out, the open tube shortens.
    EXPECT_GT(std::abs(r.axial - 1.0), 0.02);
    EXPECT_LT(r.volume_error, 1e-8);  // the constraint holds to the solver's 1e-9 of V0
    // Measured 20 (capped) and 30 (open; 54 with the inconsistent −a): a regression to the linear
    // convergence adds ≥ 20, a small change of the iteration path a few.
    EXPECT_LE(r.newton, cap > 0 ? 22 : 34) << (cap > 0 ? "capped" : "open");
  }
}
