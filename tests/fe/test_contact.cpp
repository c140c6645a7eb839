// Contact with rigid obstacles (fe/contact.hpp): the point law's and the contribution's tangents against
// central differences (normal, stick, slip; plane, sphere, cylinder; quads and 6-node triangles), a block
// pressed onto a rigid plane (uniform pressure equal to the applied one, hex8 and tet10), its penetration
// against the stated bound, a block pressed and pulled sideways (stick, then slip at μN), and the
// refusals of a body overlapping an obstacle and of out-of-range values.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <memory>
#include <random>

#include "softhom/fe/contact.hpp"
#include "softhom/fe/solver.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/materials/laws.hpp"

using namespace softhom;
using namespace softhom::fe;

namespace {

/// Residual and tangent of one contribution, dense over the mesh's dofs.
class DenseContactSink final : public AssemblySink {
 public:
  DenseContactSink(int ndof, bool tangent)
      : AssemblySink(tangent), R(Eigen::VectorXd::Zero(ndof)), K(Eigen::MatrixXd::Zero(ndof, ndof)) {}
  void add_residual(int n, const int* dofs, const double* r) override {
    for (int i = 0; i < n; ++i) R[dofs[i]] += r[i];
  }
  void add_tangent(int nr, const int* rows, int nc, const int* cols, const double* k) override {
    for (int j = 0; j < nc; ++j)
      for (int i = 0; i < nr; ++i) K(rows[i], cols[j]) += k[i + nr * j];
  }
  void add_border(int, const int*, const double*, const double*) override {}
  void add_constraint_value(double) override {}
  Eigen::VectorXd R;
  Eigen::MatrixXd K;
};

/// A box [0, L]² × [0, H] of nx × nx × nz hex8 with surfaces xmin, ymin, bottom (z = 0), top.
Mesh block(int nx, int nz, double L, double H, double z0 = 0.0) {
  Mesh m;
  auto id = [&](int i, int j, int k) { return i + (nx + 1) * (j + (nx + 1) * k); };
  for (int k = 0; k <= nz; ++k)
    for (int j = 0; j <= nx; ++j)
      for (int i = 0; i <= nx; ++i) m.nodes.emplace_back(L * i / nx, L * j / nx, z0 + H * k / nz);
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < nx; ++j)
      for (int i = 0; i < nx; ++i)
        m.hexes.push_back({id(i, j, k), id(i + 1, j, k), id(i + 1, j + 1, k), id(i, j + 1, k), id(i, j, k + 1),
                           id(i + 1, j, k + 1), id(i + 1, j + 1, k + 1), id(i, j + 1, k + 1)});
  name_boundary_faces(m, [&](const Vec3&, const Vec3& n) -> std::string {
    if (n[2] < -0.9) return "bottom";
    if (n[2] > 0.9) return "top";
    if (n[0] < -0.9) return "xmin";
    if (n[1] < -0.9) return "ymin";
    return "";
  });
  return m;
}

ObstacleContact::Options law_options(double penalty, double friction, bool augmented = true) {
  ObstacleContact::Options o;
  o.law.penalty = o.law.tangential_penalty = penalty;
  o.law.friction = friction;
  o.augmented = augmented;
  o.field = "contact.obstacles[0]";
  return o;
}

RigidObstacle plane_at(double z) {
  RigidObstacle o;
  o.point = Vec3(0, 0, z);
  return o;
}

std::shared_ptr<ObstacleContact> contact_on(const Mesh& m, const std::string& surface, RigidObstacle o,
                                            ObstacleContact::Options opt) {
  const std::vector<Quad> quads = m.surfaces.count(surface) ? m.surfaces.at(surface) : std::vector<Quad>{};
  return std::make_shared<ObstacleContact>(m, quads, m.tri_surface(surface), std::move(o), std::move(opt));
}

/// max |K − ∂R/∂u| / max |K| by central differences of the residual.
double tangent_gap(const ObstacleContact& c, const Mesh& mesh, const std::vector<double>& u0) {
  Iterate it;
  it.t = it.t_stiffness = 0.0;
  it.u = &u0;
  DenseContactSink s(mesh.num_dofs(), true);
  EXPECT_EQ(c.assemble(mesh, it, s), MaterialStatus::ok);
  const double h = 1e-7;
  double gap = 0.0;
  for (int d = 0; d < mesh.num_dofs(); ++d) {
    std::vector<double> up = u0, um = u0;
    up[d] += h;
    um[d] -= h;
    DenseContactSink sp(mesh.num_dofs(), false), sm(mesh.num_dofs(), false);
    it.u = &up;
    c.assemble(mesh, it, sp);
    it.u = &um;
    c.assemble(mesh, it, sm);
    gap = std::max(gap, ((sp.R - sm.R) / (2 * h) - s.K.col(d)).cwiseAbs().maxCoeff());
  }
  return gap / s.K.cwiseAbs().maxCoeff();
}

}  // namespace

// The point law: central differences of the traction at a penetrating point against its derivative, for
// the three obstacles, frictionless, sticking and slipping. Step 1e-6 on O(1) data: the truncation error
// O(h²) and the round-off O(1e-16/h) both stay below 1e-8 of the derivative's size; 1e-7 leaves room.
TEST(Contact, PointLawTangentMatchesDifferences) {
  RigidObstacle plane = plane_at(0.0), sphere, cylinder;
  plane.direction = Vec3(0.2, -0.1, 1.0).normalized();
  sphere.shape = RigidObstacle::Shape::sphere;
  sphere.point = Vec3(0.1, 0.0, -1.0);
  sphere.radius = 1.0;
  cylinder.shape = RigidObstacle::Shape::cylinder;
  cylinder.point = Vec3(0.0, 0.0, -1.0);
  cylinder.direction = Vec3(1.0, 0.3, 0.0).normalized();
  cylinder.radius = 1.0;
  const Vec3 x(0.2, 0.15, -0.05), stick_near(0.2005, 0.1502, 0.0), stick_far(0.0, 0.0, 0.0);
  for (const RigidObstacle* o : {&plane, &sphere, &cylinder})
    for (int mode = 0; mode < 3; ++mode) {  // frictionless, stick, slip
      ContactLaw law{10.0, 8.0, mode == 0 ? 0.0 : 0.4};
      const Vec3 stick = mode == 2 ? stick_far : stick_near;
      const ObstacleGap g = obstacle_gap(*o, x, 0.0);
      const PointTraction t = contact_traction(g, x, stick, 0.05, law);
      ASSERT_TRUE(t.active);
      EXPECT_EQ(t.slip, mode == 2) << o->shape_name() << " mode " << mode;
      Mat3 fd;
      const double h = 1e-6;
      for (int j = 0; j < 3; ++j) {
        Vec3 xp = x, xm = x;
        xp[j] += h;
        xm[j] -= h;
        fd.col(j) = (contact_traction(obstacle_gap(*o, xp, 0.0), xp, stick, 0.05, law).traction -
                     contact_traction(obstacle_gap(*o, xm, 0.0), xm, stick, 0.05, law).traction) / (2 * h);
      }
      EXPECT_LT((fd - t.dtraction).cwiseAbs().maxCoeff(), 1e-7 * t.dtraction.cwiseAbs().maxCoeff())
          << o->shape_name() << " mode " << mode;
    }
}

// The contribution's tangent on the faces of a 2 × 2 × 1 block's bottom (quads) and of its tet10 split
// (6-node triangles) pressed into a sphere, without friction, sticking (the stick points of t = 0 and a
// small tangential shift) and slipping (a large one). Step 1e-7 on O(0.1) displacements: truncation and
// round-off below 1e-7 of max |K|; the bound 1e-5 leaves two decades.
TEST(Contact, ContributionTangentMatchesDifferences) {
  const Mesh hex = block(2, 1, 1.0, 0.5, 0.02);
  const Mesh tet = hex_to_tet10(hex);
  RigidObstacle sphere;
  sphere.shape = RigidObstacle::Shape::sphere;
  sphere.point = Vec3(0.45, 0.55, -3.0);
  sphere.radius = 3.0;
  for (const Mesh* m : {&hex, &tet})
    for (int mode = 0; mode < 3; ++mode) {
      const auto c = contact_on(*m, "bottom", sphere, law_options(50.0, mode == 0 ? 0.0 : 0.5));
      std::vector<double> u(m->num_dofs(), 0.0);
      std::mt19937 rng(3);
      std::uniform_real_distribution<double> jitter(-0.005, 0.005);
      const double shift = mode == 2 ? 0.2 : 0.001;
      for (int n = 0; n < m->num_nodes(); ++n) {
        u[3 * n] = shift + jitter(rng);
        u[3 * n + 1] = jitter(rng);
        u[3 * n + 2] = -0.06 + jitter(rng);
      }
      const std::vector<double> u0 = u;
      Iterate it;
      it.u = &u0;
      const ContactTotals tot = c->totals(*m, it);
      ASSERT_GT(tot.active_points, 0);
      if (mode == 1) { EXPECT_LT(tot.slipping_points, tot.active_points); }  // the patch's rim (p → 0) slips
      if (mode == 2) { EXPECT_EQ(tot.slipping_points, tot.active_points); }
      EXPECT_LT(tangent_gap(*c, *m, u0), 1e-5) << (m == &hex ? "hex8" : "tet10") << " mode " << mode;
    }
}

namespace {

struct PressedBlock {
  double reaction_z = 0.0, top_area = 0.0;
  ContactTotals totals;
  std::vector<double> pressure, gap;
  ContributionReport report;
  double face_size = 0.0, penalty = 0.0, shear_modulus = 1.0;
};

/// A unit block on a frictionless rigid plane at z = 0, symmetry planes x = 0 and y = 0, the top moved
/// down by `delta` in `steps` load steps: a uniform uniaxial state whose top traction is what the plane
/// must transmit.
PressedBlock press_block(bool tet10, double delta, int steps, bool augmented,
                         SolverKind solver = SolverKind::automatic) {
  Mesh m = block(3, 2, 1.0, 1.0);
  if (tet10) m = hex_to_tet10(m);
  FeModel model;
  model.mesh = m;
  model.element_material.assign(m.num_elements(), make_material(make_neo_hookean({1.0, 20.0})));
  auto fix = [&](const std::string& surface, int comp, PiecewiseLinear v) {
    DirichletGroup g;
    for (int n : surface_nodes(m, surface)) g.dofs.push_back(3 * n + comp);
    g.value = std::move(v);
    model.dirichlet.push_back(g);
  };
  fix("xmin", 0, PiecewiseLinear::constant(0.0));
  fix("ymin", 1, PiecewiseLinear::constant(0.0));
  fix("top", 2, PiecewiseLinear{{0.0, 1.0}, {0.0, -delta}});
  PressedBlock out;
  out.face_size = mean_face_size(m, m.surfaces.count("bottom") ? m.surfaces.at("bottom") : std::vector<Quad>{},
                                 m.tri_surface("bottom"));
  out.penalty = default_contact_penalty(1.0, out.face_size);
  const auto contact = contact_on(m, "bottom", plane_at(0.0), law_options(out.penalty, 0.0, augmented));
  model.add(contact);
  NewtonOptions newton;
  newton.solver = solver;
  Simulation sim(model, newton);
  for (int s = 1; s <= steps; ++s) EXPECT_TRUE(sim.advance_to(double(s) / steps).reached());
  std::vector<int> top_z;
  for (int n : surface_nodes(m, "top")) top_z.push_back(3 * n + 2);
  out.reaction_z = sim.reaction(top_z);
  const std::vector<double>& u = sim.displacement();
  const Iterate it = sim.converged_iterate(*contact);
  out.totals = contact->totals(m, it);
  contact->face_values(m, it, out.pressure, out.gap);
  contact->report(m, it, out.report);
  // The top is as wide as the bottom in a uniform state: its current area from the corner node (1, 1, 1).
  for (int n = 0; n < m.num_nodes(); ++n)
    if ((m.nodes[n] - Vec3(1, 1, 1)).norm() < 1e-12) out.top_area = (1 + u[3 * n]) * (1 + u[3 * n + 1]);
  return out;
}

}  // namespace

// Contact patch test on a rigid plane: every face of the bottom (3×3 quads, or the 18 6-node triangles
// of the split) carries the same Cauchy pressure, equal to the top's traction −R_z/a. The state is
// uniform, so the FE solution is exact and the only error is Newton's tolerance (1e-8 of the force
// scale): 1e-6 relative is two decades above it. On the triangles the pressure reaches the corners of
// no face (∫ N_corner da = 0), which a node-to-surface scheme could not transmit.
TEST(Contact, PressedBlockTransmitsUniformPressure) {
  for (bool tet10 : {false, true}) {
    const PressedBlock b = press_block(tet10, 0.05, 2, true);
    const double applied = -b.reaction_z / b.top_area;
    ASSERT_GT(applied, 0.0);
    for (double p : b.pressure) EXPECT_NEAR(p, applied, 1e-6 * applied) << (tet10 ? "tet10" : "hex8");
    EXPECT_NEAR(b.totals.normal_force, -b.reaction_z, 1e-6 * applied) << (tet10 ? "tet10" : "hex8");
    EXPECT_NEAR(b.totals.area, b.top_area, 1e-9);
  }
}

// The same on the PETSc path (the contact's couplings in its preallocation, its tangent through PETSc's
// fill): the pressure of the CHOLMOD run to 1e-6, the tolerance of the patch test.
TEST(Contact, PressedBlockOnPetscPath) {
  const PressedBlock direct = press_block(true, 0.05, 2, true);
  const PressedBlock petsc = press_block(true, 0.05, 2, true, SolverKind::petsc);
  ASSERT_EQ(petsc.pressure.size(), direct.pressure.size());
  for (std::size_t f = 0; f < petsc.pressure.size(); ++f)
    EXPECT_NEAR(petsc.pressure[f], direct.pressure[f], 1e-6 * direct.pressure[f]);
}

// What the macro job writes: the probes (the totals) and one field on the bottom's faces with the
// face pressures and gaps, and the displacement of the faces' nodes.
TEST(Contact, ReportsProbesAndFaceField) {
  for (bool tet10 : {false, true}) {
    const PressedBlock b = press_block(tet10, 0.05, 1, true);
    ASSERT_EQ(b.report.probes.size(), 5u);
    EXPECT_EQ(b.report.probes[0].first, "contact_normal_force [N]");
    EXPECT_EQ(b.report.probes[0].second, b.totals.normal_force);
    EXPECT_EQ(b.report.probes[3].first, "contact_active_points [1]");
    EXPECT_EQ(b.report.probes[3].second, double(b.totals.active_points));
    ASSERT_EQ(b.report.fields.size(), 1u);
    const ReportField& f = b.report.fields[0];
    EXPECT_EQ(f.cells.stem, "contact");
    EXPECT_EQ(f.cells.type, tet10 ? ReportCells::Type::triangle6 : ReportCells::Type::quad4);
    EXPECT_EQ(f.cells.connectivity.size(), tet10 ? 6u * 18u : 4u * 9u);
    EXPECT_EQ(f.cells.points.size(), tet10 ? 49u : 16u);  // the bottom's nodes: 7 × 7 with mid-edge nodes, 4 × 4
    ASSERT_EQ(f.arrays.size(), 3u);
    EXPECT_EQ(f.arrays[0].values, b.pressure);
    EXPECT_EQ(f.arrays[1].values, b.gap);
    EXPECT_EQ(f.arrays[2].values.size(), 3 * f.cells.points.size());
  }
}

// Penetration against the stated bound: pure penalty in one step penetrates p/ε_N = (p/G) h/100 (p the
// nominal pressure: the normal force over the unit reference area); with the per-step augmentation over
// four steps only the last step's pressure change remains (about a quarter).
TEST(Contact, PenetrationWithinStatedBound) {
  const PressedBlock pure = press_block(false, 0.05, 1, false);
  const double p = pure.totals.normal_force;
  EXPECT_NEAR(pure.totals.max_penetration, p / pure.penalty, 1e-6 * p / pure.penalty);
  EXPECT_LE(pure.totals.max_penetration, 0.01 * (p / pure.shear_modulus) * pure.face_size * (1 + 1e-9));
  const PressedBlock aug = press_block(false, 0.05, 4, true);
  EXPECT_LT(aug.totals.max_penetration, 0.3 * pure.totals.max_penetration);
}

// Coulomb friction: a block pressed by its top (moved down 0.05, held laterally) onto a rigid plane with
// μ = 0.3, then dragged sideways. A small drag (0.01) shears the block elastically and sticks (the
// tangential force well under μN); a large one (0.3) slips every active point, and the friction force is
// μ N: the top's reactions R_x / R_z = μ. All slip tractions are μ p along the trial direction, which turns
// towards x as the drag goes on (the outward slip of the pressing decays by μp / (μp + ε_T Δx) per step;
// measured 6e-7 off x after four steps): 1e-5 relative.
TEST(Contact, PulledBlockSticksThenSlipsAtMuN) {
  const Mesh m = block(3, 2, 1.0, 1.0);
  FeModel model;
  model.mesh = m;
  model.element_material.assign(m.num_elements(), make_material(make_neo_hookean({1.0, 20.0})));
  const std::vector<int> top = surface_nodes(m, "top");
  const PiecewiseLinear press{{0.0, 1.0}, {0.0, -0.05}}, drag{{0.0, 1.0, 2.0}, {0.0, 0.0, 0.3}};
  const PiecewiseLinear paths[3] = {drag, PiecewiseLinear::constant(0.0), press};
  for (int comp = 0; comp < 3; ++comp) {
    DirichletGroup g;
    for (int n : top) g.dofs.push_back(3 * n + comp);
    g.value = paths[comp];
    model.dirichlet.push_back(g);
  }
  const double mu = 0.3;
  const auto contact = contact_on(m, "bottom", plane_at(0.0),
                                  law_options(default_contact_penalty(1.0, mean_face_size(m, m.surfaces.at("bottom"), {})), mu));
  model.add(contact);
  Simulation sim(model);
  auto forces = [&](double t, ContactTotals& tot, double& rx, double& rz) {
    ASSERT_TRUE(sim.advance_to(t).reached()) << t;
    std::vector<int> dx, dz;
    for (int n : top) {
      dx.push_back(3 * n);
      dz.push_back(3 * n + 2);
    }
    rx = sim.reaction(dx);
    rz = sim.reaction(dz);
    tot = contact->totals(m, sim.converged_iterate(*contact));
  };
  ContactTotals tot;
  double rx = 0.0, rz = 0.0;
  forces(0.5, tot, rx, rz);
  forces(1.0, tot, rx, rz);
  forces(1.0 + 0.01 / 0.3, tot, rx, rz);  // drag 0.01
  EXPECT_GT(tot.tangential_force, 0.0);
  EXPECT_LT(tot.tangential_force, 0.7 * mu * tot.normal_force);
  EXPECT_LT(std::abs(rx), 0.7 * mu * std::abs(rz));
  for (double t : {1.25, 1.5, 1.75, 2.0}) forces(t, tot, rx, rz);
  EXPECT_EQ(tot.slipping_points, tot.active_points);
  EXPECT_NEAR(tot.tangential_force / tot.normal_force, mu, 1e-5 * mu);
  EXPECT_NEAR(std::abs(rx) / std::abs(rz), mu, 1e-5 * mu);
}

// Bad input: a body starting inside the obstacle (the message names the point and the depth), a Coulomb
// coefficient out of [0, 3], an empty surface, a sphere without a radius.
TEST(Contact, RefusesOverlapAndOutOfRangeValues) {
  const Mesh m = block(2, 1, 1.0, 1.0);
  auto model_with = [&](RigidObstacle o, ObstacleContact::Options opt, const std::string& surface) {
    FeModel model;
    model.mesh = m;
    model.element_material.assign(m.num_elements(), make_material(make_neo_hookean({1.0, 20.0})));
    DirichletGroup g;
    for (int d = 0; d < 3; ++d)
      for (int n : surface_nodes(m, "top")) g.dofs.push_back(3 * n + d);
    model.dirichlet.push_back(g);
    model.add(contact_on(m, surface, std::move(o), std::move(opt)));
    return model;
  };
  try {
    Simulation sim(model_with(plane_at(0.02), law_options(100.0, 0.0), "bottom"));
    FAIL() << "overlap accepted";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("contact.obstacles[0]"), std::string::npos) << what;
    EXPECT_NE(what.find("overlaps"), std::string::npos) << what;
    EXPECT_NE(what.find("0.02 mm inside"), std::string::npos) << what;
  }
  EXPECT_THROW(Simulation(model_with(plane_at(0.0), law_options(100.0, 3.5), "bottom")), InputError);
  EXPECT_THROW(Simulation(model_with(plane_at(0.0), law_options(100.0, -0.1), "bottom")), InputError);
  EXPECT_THROW(Simulation(model_with(plane_at(0.0), law_options(100.0, 0.2), "no such surface")), InputError);
  RigidObstacle sphere;
  sphere.shape = RigidObstacle::Shape::sphere;
  sphere.point = Vec3(0.5, 0.5, -2.0);
  EXPECT_THROW(Simulation(model_with(sphere, law_options(100.0, 0.0), "bottom")), InputError);
}
