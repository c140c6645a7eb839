// Bending actuator (dissertation Fig. 30/32): a capped two-material tube, the lower half (y < 0)
// stiffer, clamped at z = 0 and inflated by a pressure ramp; both materials are QLV with τ = 10 min.
// Under pressure (load) control the matrix creeps during a slow ramp, so the tip angle reached at the
// end of the ramp grows with the ramp time (3, 10, 20 min) and stays below the fully relaxed value.
#include <gtest/gtest.h>

#include "softhom/macro/structures.hpp"
#include "softhom/materials/laws.hpp"

using namespace softhom;
using namespace softhom::macro;

namespace {

MaterialPtr qlv_gent(double G, double g_inf) {
  GentHGOParams p;
  p.G = G;
  p.Jm = 14.0;
  p.K = 2000.0;
  if (g_inf >= 1.0) return make_material(make_gent_hgo(p));
  return make_material(make_gent_hgo(p), PronySeries{g_inf, {{1.0 - g_inf, 600.0}}});
}

/// Tip angle [deg] at the end of a pressure ramp to 4 kPa lasting `ramp` seconds.
double tip_angle(double ramp, double g_inf, double G_scale = 1.0) {
  StructureSpec spec;
  spec.kind = StructureKind::actuator;
  spec.tube = {6.0, 9.0, 60.0, 1, 8, 6, 360.0, 3.0, 1, 1, false};
  spec.material = qlv_gent(0.017 * G_scale, g_inf);
  spec.material_region1 = qlv_gent(0.17 * G_scale, g_inf);
  spec.control = LoadControl::pressure;
  spec.load = {{0.0, ramp}, {0.0, 0.004}};
  const Structure s = build_structure(spec);
  fe::NewtonOptions o;
  o.initial_substeps = 6;
  fe::Simulation sim(s.model, o);
  EXPECT_TRUE(sim.advance_to(ramp).reached());
  return probe_values(s, sim)[3];  // time, pressure, volume, tip_angle_deg, tip_deflection
}

}  // namespace

TEST(Creep, TipAngleAtEndOfRampGrowsWithRampTime) {
  const double a3 = tip_angle(180.0, 0.5), a10 = tip_angle(600.0, 0.5), a20 = tip_angle(1200.0, 0.5);
  // Bounds: instantaneous (elastic, G) and fully relaxed (elastic, g∞ G) responses.
  const double fast = tip_angle(180.0, 1.0), relaxed = tip_angle(180.0, 1.0, 0.5);
  std::cerr << "creep: tip angle at end of ramp 3 min " << a3 << ", 10 min " << a10 << ", 20 min " << a20
            << " deg; elastic " << fast << ", relaxed " << relaxed << "\n";
  EXPECT_GT(a10, a3 * 1.02);  // creep during the ramp: a visibly (> 2 %) larger angle per longer ramp
  EXPECT_GT(a20, a10 * 1.02);
  EXPECT_GT(a3, fast);         // even the fastest ramp creeps (τ = 10 min vs a 3 min ramp)
  EXPECT_LT(a20, relaxed);     // but never beyond the fully relaxed response
}
