// Coulomb friction between deformable surfaces (fe/surface_contact.hpp): the tangent against central
// differences in stick and in slip (hex8 quads, tet10 6-node triangles, curved master faces), and a
// block pressed on another and dragged sideways, which sticks below μN and slips at μN.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <vector>

#include "surface_contact_blocks.hpp"
#include "surface_contact_tangent.hpp"
#include "softhom/fe/solver.hpp"
#include "softhom/fe/surface_contact.hpp"
#include "softhom/materials/laws.hpp"

using namespace softhom;
using namespace softhom::fe;

namespace {

/// The contact's totals at u with a state (its reported anchors and multipliers).
ContactTotals sf_totals(const SurfaceContact& c, const Mesh& m, const std::vector<double>& u,
                        const std::vector<double>& state) {
  Iterate it;
  it.u = &u;
  it.state_old = state.data();
  return c.totals(m, it);
}

}  // namespace

// The tangent of the pressed, wrinkled pair with friction against central differences (step 1e-6, as
// the frictionless test: truncation ~1e-12 and round-off ~1e-10 of the entries' scale, so 1e-6 relative
// leaves three decades), multipliers λ0 = 1 (p ≈ 0.6 … 1.8 with the penalty 20 and the wrinkles). Stick:
// μ = 3 and anchors 0.01 (parametric) off the closest points, a trial traction of ~0.04, far inside the
// cone μ p ≥ 1.8, so every point sticks and its slip's rotation with the normal is tested. Slip: μ = 0.1,
// anchors (0.3, −0.2) off with ε_T = 20, a trial of ~1 against a cone of at most 0.18, so every point
// slips and the return onto the cone (its dependence on p, the turning of the slip direction) is
// tested. The slip tangent is non-symmetric: measured, not asserted beyond being so.
TEST(SurfaceFriction, TangentMatchesCentralDifferencesInStickAndSlip) {
  struct Case {
    const char* name;
    double mu, tangential_penalty, dxi, deta;
    bool slip;
  };
  for (bool tet10 : {false, true}) {
    const double gap = 0.01;
    const Mesh m = test::two_blocks(2, 3, gap, tet10, Vec3(0.03, 0.02, 0.0));
    const std::vector<double> u = test::pressed_and_wrinkled(m, gap);
    for (const Case c : {Case{"stick", 3.0, 0.0, 0.01, 0.01, false}, Case{"slip", 0.1, 20.0, 0.3, -0.2, true}}) {
      SurfaceContact::Options o = test::contact_options(20.0);
      o.friction = c.mu;
      o.tangential_penalty = c.tangential_penalty;
      const SurfaceContact pair(m, test::surface(m, "upper_bottom"), test::surface(m, "lower_top"), o);
      const std::vector<double> state = test::paired_state(pair, m, u, 1.0, c.dxi, c.deta);
      const ContactTotals t = sf_totals(pair, m, u, state);
      ASSERT_GT(t.active_points, 0);
      EXPECT_EQ(t.slipping_points, c.slip ? t.active_points : 0) << c.name;
      EXPECT_GT(t.tangential_force, 0.0);
      const double error = test::contact_tangent_error(pair, m, u, state);
      const test::DenseSink at = test::assemble_contact(pair, m, u, state, true);
      const double asym = (at.K - at.K.transpose()).cwiseAbs().maxCoeff() / at.K.cwiseAbs().maxCoeff();
      std::printf("friction tangent, %s, %s: error %.2g, asymmetry %.2g of the largest entry (%d of %d points "
                  "slipping)\n",
                  tet10 ? "tet10" : "hex8", c.name, error, asym, t.slipping_points, t.active_points);
      EXPECT_LT(error, 1e-6) << (tet10 ? "tet10 " : "hex8 ") << c.name;
      if (c.slip) {
        EXPECT_GT(asym, 1e-3);
      }
    }
  }
}

namespace {

/// A pressed and dragged stack: the upper block [0.25, 0.75]² × [1, 2] (4 × 4 × 1 cells, the slave) on
/// the lower one [0, 1]² × [0, 1] (4 × 4 × 1, the master: the slave's faces nested in its), both
/// neo-Hookean G = 1, K = 20; the lower block's base held, the upper block's top moved down 0.05 over
/// t ∈ [0, 1] and then along x by `drag` over t ∈ [1, 2] (it stays on the lower block), its y held.
struct SfDragged {
  Mesh mesh;
  std::shared_ptr<SurfaceContact> contact;
  std::unique_ptr<Simulation> sim;
  std::vector<int> top_x, top_z;
};

SfDragged sf_dragged(bool tet10, double mu, double drag) {
  SfDragged d;
  Mesh blocks;
  test::add_block(blocks, 2, 0.0);
  const int lower_nodes = blocks.num_nodes();
  test::add_block(blocks, 2, 1.0);
  for (int n = lower_nodes; n < blocks.num_nodes(); ++n)
    for (int i = 0; i < 2; ++i) blocks.nodes[n][i] = 0.25 + 0.5 * blocks.nodes[n][i];
  name_boundary_faces(blocks, [](const Vec3& c, const Vec3& n) -> std::string {
    if (n[2] < -0.9) return c[2] < 0.5 ? "base" : "upper_bottom";
    if (n[2] > 0.9) return c[2] < 1.5 ? "lower_top" : "press";
    return "";
  });
  d.mesh = tet10 ? hex_to_tet10(blocks) : blocks;
  const Mesh& m = d.mesh;
  FeModel model;
  model.mesh = m;
  model.element_material.assign(m.num_elements(), make_material(make_neo_hookean({1.0, 20.0})));
  auto fix = [&](const std::string& name, int comp, PiecewiseLinear v) { test::hold_surface(model, name, comp, std::move(v)); };
  for (int comp = 0; comp < 3; ++comp) fix("base", comp, PiecewiseLinear::constant(0.0));
  fix("press", 0, PiecewiseLinear{{0.0, 1.0, 2.0}, {0.0, 0.0, drag}});
  fix("press", 1, PiecewiseLinear::constant(0.0));
  fix("press", 2, PiecewiseLinear{{0.0, 1.0}, {0.0, -0.05}});
  for (int n : surface_nodes(m, "press")) {
    d.top_x.push_back(3 * n);
    d.top_z.push_back(3 * n + 2);
  }
  SurfaceContact::Options o;
  o.shear_modulus = 1.0;
  o.friction = mu;
  o.field = "contact.pairs[0]";
  d.contact = std::make_shared<SurfaceContact>(m, test::surface(m, "upper_bottom"), test::surface(m, "lower_top"), o);
  model.add(d.contact);
  d.sim = std::make_unique<Simulation>(model);
  return d;
}

/// Above every point's contact pressure in the dragged stack [MPa] (measured below 0.1: 0.05 of
/// compression of two unit blocks, E ≈ 3).
constexpr double kSfPressureBound = 0.15;
/// The drag at t = 2 [mm].
constexpr double kSfDrag = 0.15;

}  // namespace

// Below μN the drag sticks: the default stick penalty ε_T = ε_N/10 = 10 G/h lets a point slide
// elastically by at most μ p/ε_T, so the facing centres of the two blocks (nodes of both meshes at
// (0.5, 0.5, 1)) move together to within that (μ = 0.3, p < 0.15 MPa here, h = 1/4: 1.1e-3 mm; the top
// moved 0.004), the friction force stays far inside the cone (T < μN/10; measured 0.017 N/N) and
// carries the pull: the contact's force along x is the top's reaction R_x to Newton's tolerance (1e-6
// of the force scale) and grows with the drag (doubling it raises R_x by more than half: measured ×2.0
// on hex8, ×1.4 on tet10, where more of the rim is on the cone already: pressing the small block into
// the large one slips the rim outwards, the punch's edge). Dragged 0.15, far beyond the blocks'
// elastic shear at μN, every active point slips, each with the traction μ p, so the friction force is
// μ times the normal force up to the spread of the slip directions over the indented patch (measured
// 1e-5 on hex8, 1.6 % on tet10; asserted to 3 %), and never above it. On hex8 and tet10 meshes.
TEST(SurfaceFriction, DraggedBlockSticksBelowMuNAndSlipsAtMuN) {
  const double mu = 0.3;
  for (bool tet10 : {false, true}) {
    const char* mesh = tet10 ? "tet10" : "hex8";
    SfDragged d = sf_dragged(tet10, mu, kSfDrag);
    Simulation& sim = *d.sim;
    for (double t : {1.0 / 3, 2.0 / 3, 1.0}) ASSERT_TRUE(sim.advance_to(t).reached()) << mesh << " " << t;
    auto contact_totals = [&] { return d.contact->totals(d.mesh, sim.converged_iterate(*d.contact)); };
    double rx[2] = {0.0, 0.0};
    ContactTotals stick;
    for (int k = 0; k < 2; ++k) {  // drags of 0.002 and 0.004
      ASSERT_TRUE(sim.advance_to(1.0 + (k + 1) * 0.002 / kSfDrag).reached()) << mesh;
      stick = contact_totals();
      rx[k] = sim.reaction(d.top_x);
      EXPECT_NEAR(-stick.force[0], rx[k], 1e-6 * std::abs(sim.reaction(d.top_z))) << mesh;
    }
    EXPECT_LT(stick.tangential_force, 0.1 * mu * stick.normal_force) << mesh;
    EXPECT_GT(rx[1], 1.2 * rx[0]) << mesh;
    // The facing centres: the lower block's node (0.5, 0.5, 1) comes first in the mesh, the upper's second.
    const std::vector<double>& u = sim.displacement();
    std::vector<double> centre_x;
    for (int n = 0; n < d.mesh.num_nodes(); ++n)
      if ((d.mesh.nodes[n] - Vec3(0.5, 0.5, 1.0)).norm() < 1e-12) centre_x.push_back(u[3 * n]);
    ASSERT_EQ(centre_x.size(), 2u);
    const double elastic_slip = mu * kSfPressureBound / (0.1 * default_contact_penalty(1.0, 0.25));
    EXPECT_LT(std::abs(centre_x[1] - centre_x[0]), elastic_slip) << mesh;
    for (double t : {1.125, 1.25, 1.5, 1.75, 2.0}) ASSERT_TRUE(sim.advance_to(t).reached()) << mesh << " " << t;
    const ContactTotals slip = contact_totals();
    std::printf("dragged block, %s: stick T/N %.3g (%d of %d points on the cone), R_x %.3g → %.3g N, centres' "
                "relative slip %.2g mm (bound %.2g); slip: %d of %d points, T/N %.6g, R_x/R_z %.5g; %d Newton "
                "iterations, %d cut-backs\n",
                mesh, stick.tangential_force / stick.normal_force, stick.slipping_points, stick.active_points, rx[0],
                rx[1], centre_x[1] - centre_x[0], elastic_slip, slip.slipping_points, slip.active_points,
                slip.tangential_force / slip.normal_force, sim.reaction(d.top_x) / sim.reaction(d.top_z),
                sim.stats().newton_iterations, sim.stats().cutbacks);
    EXPECT_EQ(slip.slipping_points, slip.active_points) << mesh;
    EXPECT_NEAR(slip.tangential_force / slip.normal_force, mu, 0.03 * mu) << mesh;
    EXPECT_LE(slip.tangential_force, mu * slip.normal_force * (1 + 1e-12)) << mesh;
  }
}
