// Contact between deformable surfaces and self-contact (fe/surface_contact.hpp): the closest-point
// projection, the tangent against central differences (quads and 6-node triangles, a pair and a
// self-contact, curved master faces), the contact patch test of two stacked blocks with non-matching
// meshes, the self-contact of two bodies declared as one surface (its force is the load), and the
// refusals of bad input.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <map>
#include <memory>

#include "surface_contact_blocks.hpp"
#include "surface_contact_tangent.hpp"
#include "softhom/fe/solver.hpp"
#include "softhom/fe/surface_contact.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/materials/laws.hpp"

using namespace softhom;
using namespace softhom::fe;
using test::stack;
using test::Stack;
using test::surface;
using test::pressed_and_wrinkled;
using test::two_blocks;

namespace {

SurfaceContact::Options options(double penalty, const std::string& field = "contact.pairs[0]") {
  return test::contact_options(penalty, field);
}

/// max |K − K_fd| / max |K| of the contact at u (pairing and multipliers λ0 of u).
double tangent_error(const SurfaceContact& c, const Mesh& m, const std::vector<double>& u, double lambda0,
                     int* active = nullptr) {
  return test::contact_tangent_error(c, m, u, test::paired_state(c, m, u, lambda0), active);
}

}  // namespace

// The closest point of a curved quad and of a curved 6-node triangle: the distance is stationary there
// (the offset is along the normal) and the parametric point lies inside the face.
TEST(SurfaceContact, ProjectionFindsTheClosestPointOfCurvedFaces) {
  std::vector<Vec3> x = {{0, 0, 0}, {1, 0, 0.1}, {1, 1, 0}, {0, 1, 0.2}};
  SurfaceContact::Face quad;
  quad.nodes = {0, 1, 2, 3, 0, 0};
  const Vec3 point(0.3, 0.6, 0.7);
  const FaceProjection q = project_on_face(quad, x, point, 0.0, 0.0);
  EXPECT_EQ(q.free, 2);
  // Newton to round-off: the offset's tangential part vanishes to 1e-12 of the distance.
  EXPECT_LT(((point - q.x) - q.gap * q.normal).norm(), 1e-12 * q.distance);
  x = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0.5, 0, 0.1}, {0.5, 0.5, 0.1}, {0, 0.5, 0.05}};
  SurfaceContact::Face tri;
  tri.nodes_count = 6;
  tri.nodes = {0, 1, 2, 3, 4, 5};
  const FaceProjection t = project_on_face(tri, x, Vec3(0.2, 0.3, -0.5), 1.0 / 3, 1.0 / 3);
  EXPECT_EQ(t.free, 2);
  EXPECT_LT((Vec3(0.2, 0.3, -0.5) - t.x - t.gap * t.normal).norm(), 1e-12 * t.distance);
  EXPECT_LT(t.gap, 0.0);  // below the face: its normal (counter-clockwise corners) points up
  // Beyond the quad's edge ξ = 1: clamped there, with η the one free direction.
  const FaceProjection c = project_on_face(quad, {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}}, Vec3(1.5, 0.5, 0.2), 0.0, 0.0);
  EXPECT_EQ(c.free, 1);
  EXPECT_NEAR(c.xi, 1.0, 1e-15);
  EXPECT_NEAR(c.eta, 0.0, 1e-12);
}

// The tangent of the pressed, wrinkled pair against central differences (step 1e-6: truncation
// ~1e-12 and round-off ~1e-16/1e-6 of the entries' scale, so 1e-6 relative leaves three decades), with
// multipliers λ0 = 1 twice the penalty pressure so that the geometric term p ∂²g (the closest point
// sliding over the curved master face, its normal turning) is tested, not only ε ∂g⊗∂g.
TEST(SurfaceContact, TangentMatchesCentralDifferences) {
  for (bool tet10 : {false, true}) {
    const double gap = 0.01;
    const Mesh m = two_blocks(2, 3, gap, tet10, Vec3(0.03, 0.02, 0.0));
    const std::vector<double> u = pressed_and_wrinkled(m, gap);
    const SurfaceContact pair(m, surface(m, "upper_bottom"), surface(m, "lower_top"), options(20.0));
    int active = 0;
    const double error = tangent_error(pair, m, u, 1.0, &active);
    std::printf("tangent against central differences, %s: %.2g of the largest entry\n", tet10 ? "tet10" : "hex8", error);
    EXPECT_LT(error, 1e-6) << (tet10 ? "tet10" : "hex8");
    EXPECT_GT(active, 0);
  }
}

// The same for a self-contact surface (both facing surfaces as one, two-pass): its own faces and
// their neighbours are skipped, so only the facing ones pair.
TEST(SurfaceContact, SelfContactTangentMatchesCentralDifferences) {
  const double gap = 0.01;
  const Mesh m = two_blocks(2, 3, gap, false, Vec3(0.03, 0.02, 0.0));
  ContactSurface both = surface(m, "upper_bottom");
  const ContactSurface lower = surface(m, "lower_top");
  both.quads.insert(both.quads.end(), lower.quads.begin(), lower.quads.end());
  both.name = "facing";
  const SurfaceContact self(m, both, options(20.0, "contact.self[0]"));
  const std::vector<double> u = pressed_and_wrinkled(m, gap);
  EXPECT_LT(tangent_error(self, m, u, 1.0), 1e-6);
}

namespace {

double max_relative_deviation(const Stack& s) {
  double worst = 0.0;
  for (double p : s.pressure) worst = std::max(worst, std::abs(p - s.applied) / s.applied);
  return worst;
}

}  // namespace

// Contact patch test, one pass with the finer side as slave and its faces nested in the master's
// (4 × 4 on 2 × 2): a master face's shape functions are then polynomials on every slave face, which
// the slave rule integrates exactly, so the master receives the consistent loads of a uniform pressure
// and the state stays uniform. Every slave face's pressure is the applied traction to 1e-6 (Newton's
// tolerance is 1e-8 of the force scale: two decades), on hex8 quads and on the 6-node triangles of the
// split, and the contact's force is the load.
TEST(SurfaceContact, PatchTestNestedSlaveTransmitsUniformPressure) {
  for (bool tet10 : {false, true}) {
    const Stack s = stack(2, 4, tet10, true, false);
    ASSERT_GT(s.applied, 0.0);
    ASSERT_FALSE(s.pressure.empty());
    EXPECT_LT(max_relative_deviation(s), 1e-6) << (tet10 ? "tet10" : "hex8");
    EXPECT_NEAR(s.normal_force, -s.reaction, 1e-6 * -s.reaction);
  }
}

// The contact patch test between non-matching meshes (3 × 3 on 4 × 4 and the reverse, one pass or
// two, hex8 quads and the 6-node triangles of the split): on segments the master's loads are the exact
// quadrature of its shape functions, so every slave face's pressure is the applied traction to 1e-6
// (Newton's tolerance is 1e-8 of the force scale: two decades), and the contact's force is the load.
// With two passes each surface's faces show their own pass's pressure, the penalty of its own faces
// (100 G/h) times the common gap: uniform on each surface to 1e-6, and the traction their mean.
TEST(SurfaceContact, PatchTestNonMatchingMeshesTransmitsUniformPressure) {
  struct Case {
    int lower, upper;
    bool two_pass;
  };
  for (bool tet10 : {false, true})
    for (const Case c : {Case{4, 3, false}, Case{3, 4, false}, Case{3, 4, true}, Case{2, 3, false}}) {
      Stack s = stack(c.lower, c.upper, tet10, true, c.two_pass);
      ASSERT_FALSE(s.pressure.empty());
      if (c.two_pass) {  // the two levels: each face at one of them, their mean the traction
        const auto [lo, hi] = std::minmax_element(s.pressure.begin(), s.pressure.end());
        const double a = *lo, b = *hi;
        EXPECT_GT((b - a) / s.applied, 0.1);  // the two penalties differ (h = 1/3 and 1/4)
        for (double& p : s.pressure) p = std::abs(p - a) < std::abs(p - b) ? p - a + 0.5 * (a + b) : p - b + 0.5 * (a + b);
      }
      const double dev = max_relative_deviation(s);
      std::printf("patch test upper %d on lower %d, %s, %s, segments: max face deviation %.3g\n", c.upper, c.lower,
                  c.two_pass ? "two passes" : "one pass", tet10 ? "tet10" : "hex8", dev);
      EXPECT_LT(dev, 1e-6) << c.upper << " on " << c.lower << (tet10 ? " tet10" : " hex8");
      EXPECT_NEAR(s.normal_force, -s.reaction, 1e-6 * -s.reaction);
    }
}

// The same on the faces' Gauss points: a master shape function has a kink inside some slave faces,
// the slave rule integrates it inexactly and the state is not uniform. Measured worst face deviations
// from the applied traction (hex8, a face's force over its area): 3×3 slave on 4×4 master (the
// coarser side as slave) 0.140, 4×4 slave on 3×3 master 0.0145, two passes 0.202; the bounds are these
// with a margin of 1.3, and each is above 1e-3: the segments' exactness is what passes the test above.
TEST(SurfaceContact, PatchTestGaussPointsBetweenNonNestedFacesMeasured) {
  struct Case {
    int lower, upper;
    bool two_pass;
    double bound;
  };
  for (const Case c : {Case{4, 3, false, 0.18}, Case{3, 4, false, 0.019}, Case{3, 4, true, 0.26}}) {
    const Stack s = stack(c.lower, c.upper, false, true, c.two_pass, false, SolverKind::cholmod,
                          SurfaceContact::Options::Integration::points);
    const double dev = max_relative_deviation(s);
    EXPECT_LT(dev, c.bound);
    EXPECT_GT(dev, 1e-3);
    std::printf("patch test upper %d on lower %d, %s, Gauss points: max face deviation %.3g\n", c.upper, c.lower,
                c.two_pass ? "two passes" : "one pass", dev);
    EXPECT_NEAR(s.normal_force, -s.reaction, 1e-6 * -s.reaction);
  }
}

// Self-contact of two bodies declared as one surface: each point pairs with the facing body's faces
// (never its own face or a neighbour), both passes weighted one half; the upper block's only support
// is the contact, so its force is the load (to Newton's tolerance), with no penetration beyond the
// penalty's bound (p/G) h/100 (p = applied traction, G = 1, h = 1/4).
TEST(SurfaceContact, SelfContactForceBalancesTheLoad) {
  const Stack s = stack(2, 4, false, true, false, true);
  ASSERT_GT(s.applied, 0.0);
  EXPECT_NEAR(s.normal_force, -s.reaction, 1e-6 * -s.reaction);
  EXPECT_LT(s.max_penetration, s.applied * 0.25 / 100.0);
}

namespace {

/// The status of the pair's assembly with the upper block (3 × 3 faces, h = 1/3) pushed `depth` into
/// the lower one, every point solving with the multiplier λ (its converged pressure), from a converged
/// state (where the pairing was made) with the block `start` deep.
MaterialStatus pushed_in(double depth, double lambda, bool augmented, double start = 0.0) {
  const double gap = 0.01;
  const Mesh m = two_blocks(2, 3, gap, false);
  SurfaceContact::Options o = options(0.0);  // the default penalty 100 G/h of the slave faces
  o.augmented = augmented;
  const SurfaceContact pair(m, surface(m, "upper_bottom"), surface(m, "lower_top"), o);
  auto pushed = [&](double d) {
    std::vector<double> u(m.num_dofs(), 0.0);
    for (int n = 0; n < m.num_nodes(); ++n)
      if (m.nodes[n][2] > 1.0 + gap / 2) u[3 * n + 2] = -(gap + d);
    return u;
  };
  const std::vector<double> state = test::paired_state(pair, m, pushed(start), lambda);
  const std::vector<double> u = pushed(depth);
  std::vector<double> scratch(state);
  test::DenseSink sink(m.num_dofs(), false);
  Iterate it;
  it.u = &u;
  it.state_old = state.data();
  it.state_new = scratch.data();
  return pair.assemble(m, it, sink);
}

}  // namespace

// The pressure bound: under ε = 100 G/h (G = 1, h = 1/3, ε = 300) an iterate whose penalty pressure
// ε (−g) exceeds 10 G above what the point carried at the step's start, i.e. deeper than 1/30 +
// max(λ/300, the start's depth), is refused; the same iterate is admitted where the points already
// carry λ = 5 (converged, augmented or pure penalty alike), or start 1/30 deep (paired inside a face
// they bore nothing on). The depths straddle each bound by 10 % of 1/30: far from the face's own bound
// (1/2) and from round-off.
TEST(SurfaceContact, PenaltyPressureBeyondTenShearModuliPerStepIsRefused) {
  const double bound = 10.0 / 300.0, below = bound - 0.1 * bound, above = bound + 0.1 * bound;
  EXPECT_EQ(pushed_in(below, 0.0, true), MaterialStatus::ok);
  EXPECT_EQ(pushed_in(above, 0.0, true), MaterialStatus::penetration);
  for (bool augmented : {true, false}) {
    const double carried = 5.0 / 300.0;
    EXPECT_EQ(pushed_in(above, 5.0, augmented), MaterialStatus::ok) << augmented;
    EXPECT_EQ(pushed_in(carried + below, 5.0, augmented), MaterialStatus::ok) << augmented;
    EXPECT_EQ(pushed_in(carried + above, 5.0, augmented), MaterialStatus::penetration) << augmented;
  }
  EXPECT_EQ(pushed_in(bound + below, 0.0, true, bound), MaterialStatus::ok);
  EXPECT_EQ(pushed_in(bound + above, 0.0, true, bound), MaterialStatus::penetration);
}

// The patch test on the petsc path: the pairing's couplings enter PETSc's matrix as the set moves; the
// face pressures of the CHOLMOD run to 1e-6.
TEST(SurfaceContact, PatchTestOnPetscPathEqualsCholmod) {
  const Stack direct = stack(2, 4, false, true, false);
  const Stack petsc = stack(2, 4, false, true, false, false, SolverKind::petsc);
  ASSERT_EQ(petsc.pressure.size(), direct.pressure.size());
  for (std::size_t f = 0; f < petsc.pressure.size(); ++f)
    EXPECT_NEAR(petsc.pressure[f], direct.pressure[f], 1e-6 * direct.applied);
}

// Bad input, each naming its key: an empty surface, an overlap at the start (naming the point), a
// friction coefficient out of range, a negative penalty or tangential penalty.
TEST(SurfaceContact, RefusesBadInputNamingTheKey) {
  const Mesh m = two_blocks(2, 2, 0.0, false);
  auto message = [&](const SurfaceContact& c) {
    try {
      c.validate(m);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  const ContactSurface up = surface(m, "upper_bottom"), low = surface(m, "lower_top");
  EXPECT_NE(message(SurfaceContact(m, ContactSurface{{}, {}, "none"}, low, options(1.0))).find("contact.pairs[0].slave"),
            std::string::npos);
  EXPECT_NE(message(SurfaceContact(m, up, ContactSurface{{}, {}, "none"}, options(1.0))).find("contact.pairs[0].master"),
            std::string::npos);
  EXPECT_NE(message(SurfaceContact(m, ContactSurface{{}, {}, "none"}, options(1.0, "contact.self[0]"))).find("contact.self[0].self"),
            std::string::npos);
  SurfaceContact::Options o = options(1.0);
  o.friction = -0.1;
  EXPECT_NE(message(SurfaceContact(m, up, low, o)).find("contact.pairs[0].friction"), std::string::npos);
  o.friction = 3.5;
  EXPECT_NE(message(SurfaceContact(m, up, low, o)).find("contact.pairs[0].friction"), std::string::npos);
  o.friction = 0.3;
  o.tangential_penalty = -2.0;
  EXPECT_NE(message(SurfaceContact(m, up, low, o)).find("contact.pairs[0].tangential_penalty"), std::string::npos);
  o.tangential_penalty = 0.0;
  EXPECT_EQ(message(SurfaceContact(m, up, low, o)), "accepted");
  EXPECT_NE(message(SurfaceContact(m, up, low, options(-1.0))).find("contact.pairs[0].penalty"), std::string::npos);
  // The upper block moved 0.05 into the lower one: refused, naming a point of the overlap.
  Mesh overlap = m;
  for (int n = 18; n < overlap.num_nodes(); ++n) overlap.nodes[n][2] -= 0.05;  // the upper block's nodes
  const SurfaceContact deep(overlap, surface(overlap, "upper_bottom"), surface(overlap, "lower_top"), options(1.0));
  try {
    deep.validate(overlap);
    ADD_FAILURE() << "an overlap at the start was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("overlap"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("0.05"), std::string::npos) << e.what();
  }
  // Touching (gap 0) is accepted.
  EXPECT_EQ(message(SurfaceContact(m, up, low, options(1.0))), "accepted");
}

namespace {

/// A ring slice (plane strain: every u_z = 0) of radii ri, ro, one unit thick in z, `around` × 2 hex8,
/// surfaces inner and outer. Node (i, k, l): radius i of 3, angle k of `around`, z level l.
struct Ring {
  Mesh mesh;
  int around = 0;
  int node(int i, int k, int l) const { return i + 3 * (((k % around) + around) % around + around * l); }
};

Ring ring(double ri, double ro, int around) {
  Ring r;
  r.around = around;
  Mesh& m = r.mesh;
  for (int l = 0; l < 2; ++l)
    for (int k = 0; k < around; ++k)
      for (int i = 0; i < 3; ++i) {
        const double rad = ri + (ro - ri) * i / 2.0, th = 2.0 * M_PI * k / around;
        m.nodes.emplace_back(rad * std::cos(th), rad * std::sin(th), double(l));
      }
  for (int k = 0; k < around; ++k)
    for (int i = 0; i < 2; ++i)
      m.hexes.push_back({r.node(i, k, 0), r.node(i + 1, k, 0), r.node(i + 1, k + 1, 0), r.node(i, k + 1, 0),
                         r.node(i, k, 1), r.node(i + 1, k, 1), r.node(i + 1, k + 1, 1), r.node(i, k + 1, 1)});
  orient_hexes(m);
  name_boundary_faces(m, [](const Vec3& c, const Vec3& n) -> std::string {
    if (std::abs(n[2]) > 0.9) return "";
    return n.dot(Vec3(c[0], c[1], 0.0)) < 0.0 ? "inner" : "outer";
  });
  return r;
}

}  // namespace

namespace {

/// What the pinched ring shows at the end of its pinch.
struct Pinch {
  std::map<std::string, double> probes;
  double p_max = 0.0;        ///< the fold's largest face pressure [MPa]
  double asymmetry = 0.0;    ///< the largest mismatch of mirrored nodes' displacements / the largest one
  double face_size = 0.0;    ///< an inner face's size (√area)
  RunStats stats;
};

/// The ring of ring(4.5, 5.5, 64) (plane strain) pinched between two frictionless rigid plates, held by
/// symmetry alone (u_x = 0 at the top and bottom, u_y = 0 at the sides), its inner surface in
/// self-contact with Coulomb coefficient mu: the plates travel 4.6 each in `steps` steps, 0.1 beyond the
/// walls' first touch, so the two walls are pressed together along a band.
Pinch pinch_ring(double mu, int steps = 20) {
  const Ring r = ring(4.5, 5.5, 64);
  const Mesh& m = r.mesh;
  FeModel model;
  model.mesh = m;
  model.element_material.assign(m.num_elements(), make_material(make_neo_hookean({1.0, 20.0})));
  DirichletGroup plane, sym_x, sym_y;
  for (int n = 0; n < m.num_nodes(); ++n) plane.dofs.push_back(3 * n + 2);
  for (int i = 0; i < 3; ++i)
    for (int l = 0; l < 2; ++l) {
      for (int k : {r.around / 4, 3 * r.around / 4}) sym_x.dofs.push_back(3 * r.node(i, k, l));
      for (int k : {0, r.around / 2}) sym_y.dofs.push_back(3 * r.node(i, k, l) + 1);
    }
  model.dirichlet = {plane, sym_x, sym_y};
  const double travel = 4.6;
  for (double side : {1.0, -1.0}) {
    RigidObstacle o;
    o.point = Vec3(0.0, side * 5.5, 0.0);
    o.direction = Vec3(0.0, -side, 0.0);
    o.path[1] = PiecewiseLinear{{0.0, 1.0}, {0.0, -side * travel}};
    ObstacleContact::Options opt;
    opt.shear_modulus = 1.0;
    opt.field = side > 0 ? "contact.obstacles[0]" : "contact.obstacles[1]";
    opt.label = side > 0 ? "top" : "bottom";
    model.add(std::make_shared<ObstacleContact>(m, m.surfaces.at("outer"), std::vector<Tri6>{}, o, opt));
  }
  SurfaceContact::Options so = options(0.0, "contact.self[0]");
  so.label = "fold";
  so.friction = mu;
  model.add(std::make_shared<SurfaceContact>(m, surface(m, "inner"), so));
  Simulation sim(model);
  Pinch out;
  for (int s = 1; s <= steps; ++s) {
    const AdvanceResult a = sim.advance_to(double(s) / steps);
    EXPECT_TRUE(a.reached()) << "step " << s << ": " << a.message;
    if (!a.reached()) return out;
  }
  ContributionReport report;
  sim.report(report);
  for (const auto& [name, value] : report.probes) out.probes[name] = value;
  for (const ReportField& f : report.fields)
    if (f.cells.stem == "fold")
      for (const ReportArray& a : f.arrays)
        if (a.name == "contact_pressure") out.p_max = *std::max_element(a.values.begin(), a.values.end());
  out.face_size = std::sqrt(2 * M_PI * 4.5 / 64 * 1.0);
  const std::vector<double>& u = sim.displacement();
  double largest = 0.0, asym = 0.0;
  for (int n = 0; n < m.num_nodes(); ++n) largest = std::max(largest, std::hypot(u[3 * n], u[3 * n + 1]));
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < r.around; ++k) {
      const int a = r.node(i, k, 0), bx = r.node(i, r.around / 2 - k, 0), by = r.node(i, -k, 0);
      asym = std::max({asym, std::abs(u[3 * a] + u[3 * bx]), std::abs(u[3 * a + 1] - u[3 * bx + 1]),
                       std::abs(u[3 * a] - u[3 * by]), std::abs(u[3 * a + 1] + u[3 * by + 1])});
    }
  out.asymmetry = asym / largest;
  out.stats = sim.stats();
  std::printf("ring, mu = %g: plate force %.4g N, fold force %.4g N (tangential %.3g N) on %g points, penetration "
              "%.3g mm; largest face pressure %.3g MPa; asymmetry %.3g; %d pattern rebuilds, %d Newton iterations, "
              "%d cut-backs\n",
              mu, out.probes["top_normal_force [N]"], out.probes["fold_normal_force [N]"],
              out.probes["fold_tangential_force [N]"], out.probes["fold_active_points [1]"],
              out.probes["fold_max_penetration [mm]"], out.p_max, out.asymmetry, out.stats.pattern_rebuilds,
              out.stats.newton_iterations, out.stats.cutbacks);
  return out;
}

}  // namespace

// The frictionless pinch. The solution must be the symmetric one: mirrored nodes' displacements agree
// to 1e-6 of the largest (Newton's tolerance is 1e-8 of the force scale; the pairing breaks ties by face
// number, and mirror-image faces' segments agree to the round-off of their corners' projections:
// measured 1.4e-8 on segments, 9e-16 on Gauss points). The fold's pressures stay below G, where the penalty's bound
// (p/G) h/100 is under 1 % of a face, and so does its penetration (measured 0.00375 mm, 56 % of 1 % of a
// face; a point's pressure exceeds its face's mean, so the bound is not taken at the face means).
TEST(SurfaceContact, RingPinchedUntilItsInnerWallFoldsOntoItself) {
  Pinch p = pinch_ring(0.0);
  EXPECT_GT(p.probes["fold_active_points [1]"], 0.0);
  EXPECT_GT(p.probes["fold_normal_force [N]"], 0.0);
  EXPECT_LT(p.p_max, 1.0);  // below G: the penalty's bound (p/G) h/100 is under 1 % of a face
  EXPECT_LT(p.probes["fold_max_penetration [mm]"], p.face_size / 100.0);
  EXPECT_LT(p.asymmetry, 1e-6);
}

// The same pinch with friction on the fold (μ = 0.5). The two walls pressed together are mirror images
// of each other, so facing points move alike along the fold and the walls do not slide on each other:
// the friction must leave the symmetric solution as it is, its resultant vanishing (to 1e-6 of the
// normal force, the symmetry's tolerance; measured 3e-8 on segments, 4e-16 on Gauss points) with the
// displacements mirror-symmetric to 1e-5 (measured 7.3e-7: where the segments' layout changes, a new
// point takes the stick anchor of the nearest old point of its face, ties in slot order, which mirror
// images do not share; 9e-16 on Gauss points) and the penetration within the frictionless bound.
TEST(SurfaceFriction, RingPinchWithFrictionStaysSymmetric) {
  Pinch p = pinch_ring(0.5);
  EXPECT_GT(p.probes["fold_active_points [1]"], 0.0);
  EXPECT_GT(p.probes["fold_normal_force [N]"], 0.0);
  EXPECT_LT(p.probes["fold_tangential_force [N]"], 1e-6 * p.probes["fold_normal_force [N]"]);
  EXPECT_LT(p.probes["fold_max_penetration [mm]"], p.face_size / 100.0);
  EXPECT_LT(p.asymmetry, 1e-5);
}
