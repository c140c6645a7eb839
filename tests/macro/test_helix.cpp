// Fiber-reinforced tubes (dissertation §4.3): capped, clamped at z = 0, inflated by a follower
// pressure. With stiff fibers the kinematics of an inextensible helix decide the sign of the axial
// strain: the fiber length ℓ fixes L = ℓ cos α and the radius ∝ ℓ sin α, the volume ∝ sin²α cos α is
// largest at α = 54.7° from the axis, and inflation drives α towards it — so α < 54.7° contracts
// (McKibben) and α > 54.7° extends. A single helix (no mirror family) twists.
#include <gtest/gtest.h>

#include <cmath>

#include "softhom/macro/structures.hpp"
#include "softhom/materials/laws.hpp"

using namespace softhom;
using namespace softhom::macro;

namespace {

struct HelixResult {
  double axial_strain, twist_deg;
};

HelixResult inflate(double alpha_deg, bool double_helix, double pressure) {
  StructureSpec spec;
  spec.kind = StructureKind::tube;
  spec.tube.inner_radius = 5.0;
  spec.tube.outer_radius = 6.5;
  spec.tube.length = 30.0;
  spec.tube.radial_cells = 1;
  spec.tube.circumferential_cells = 12;
  spec.tube.axial_cells = 6;
  spec.tube.sweep_deg = 360.0;
  spec.tube.cap_thickness = 1.5;
  GentHGOParams p;
  p.G = 0.017;  // ecoflex matrix
  p.Jm = 14.0;
  p.K = 2000.0;
  const double a = alpha_deg * M_PI / 180.0, k1 = 50.0, k2 = 1.0;  // stiff fibers: k1/G ≈ 3000
  p.fibers = {{Vec3(std::sin(a), std::cos(a), 0.0), k1, k2}};
  if (double_helix) p.fibers.push_back({Vec3(-std::sin(a), std::cos(a), 0.0), k1, k2});
  spec.material = make_material(make_gent_hgo(p));
  spec.fiber_frame = FiberFrame::cylindrical;
  spec.control = LoadControl::pressure;
  spec.load = {{0.0, 1.0}, {0.0, pressure}};
  const Structure s = build_structure(spec);
  fe::NewtonOptions o;
  o.initial_substeps = 2;
  fe::Simulation sim(s.model, o);
  EXPECT_TRUE(sim.advance_to(1.0).reached());
  const auto v = probe_values(s, sim);  // time, pressure, volume, inner_radius, stretch, axial_stretch, twist_deg
  return {v[5] - 1.0, v[6]};
}

}  // namespace

TEST(Helix, AxialStrainChangesSignNearTheMagicAngle) {
  const double p = 0.004;  // MPa: hoop strain of a few per cent
  const HelixResult low = inflate(30.0, true, p), magic = inflate(54.7, true, p), high = inflate(75.0, true, p);
  std::cerr << "helix axial strain: 30 deg " << low.axial_strain << ", 54.7 deg " << magic.axial_strain << ", 75 deg "
            << high.axial_strain << " (twists " << low.twist_deg << ", " << magic.twist_deg << ", " << high.twist_deg << ")\n";
  EXPECT_LT(low.axial_strain, 0.0);   // contracts
  EXPECT_GT(high.axial_strain, 0.0);  // extends
  // At the magic angle the inextensible-fiber kinematics leave no first-order axial strain: it is a
  // small fraction of the strains on either side (finite fiber stiffness and the compliant matrix
  // shift the transition by a few degrees only).
  EXPECT_LT(std::abs(magic.axial_strain), 0.3 * std::min(-low.axial_strain, high.axial_strain));
  // A symmetric double helix does not twist (round-off only).
  EXPECT_LT(std::abs(low.twist_deg), 1e-6);
}

TEST(Helix, SingleHelixTwists) {
  const HelixResult single = inflate(45.0, false, 0.004), twin = inflate(45.0, true, 0.004);
  std::cerr << "single helix 45 deg: twist " << single.twist_deg << " deg, axial strain " << single.axial_strain
            << "; double helix twist " << twin.twist_deg << " deg\n";
  EXPECT_GT(std::abs(single.twist_deg), 0.5);      // a visible twist of the free end
  EXPECT_LT(std::abs(twin.twist_deg), 1e-6);
}
