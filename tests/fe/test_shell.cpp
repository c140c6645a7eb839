// The rotation-free shell triangle (fe/shell.hpp): its tangent against central differences of its
// residual (curved patch, with clamped and free edges, with a fiber layer), the membrane patch test,
// the curvature's exactness for quadratic surfaces on an irregular mesh, and the topology checks.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "dense_sink.hpp"
#include "softhom/fe/shell.hpp"
#include "softhom/fe/solver.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/materials/laws.hpp"

using namespace softhom;
using namespace softhom::fe;

namespace {

/// An (nx × ny) grid of [0, Lx] × [0, Ly] split into triangles (alternating diagonals), nodes moved in
/// the plane by up to `jitter` of a cell (seeded), then mapped by `shape`.
struct Grid {
  Mesh mesh;
  std::vector<Tri3> tris;
  int nx, ny;
  int node(int i, int j) const { return i + (nx + 1) * j; }
};

Grid grid(int nx, int ny, double Lx, double Ly, double jitter, const std::function<Vec3(double, double)>& shape) {
  Grid g{{}, {}, nx, ny};
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> d(-jitter, jitter);
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) {
      double x = Lx * i / nx, y = Ly * j / ny;
      if (i > 0 && i < nx) x += d(rng) * Lx / nx;
      if (j > 0 && j < ny) y += d(rng) * Ly / ny;
      g.mesh.nodes.push_back(shape(x, y));
    }
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const int a = g.node(i, j), b = g.node(i + 1, j), c = g.node(i + 1, j + 1), e = g.node(i, j + 1);
      if ((i + j) % 2 == 0) {
        g.tris.push_back({a, b, c});
        g.tris.push_back({a, c, e});
      } else {
        g.tris.push_back({a, b, e});
        g.tris.push_back({b, c, e});
      }
    }
  return g;
}

std::shared_ptr<const ShellSection> neo_hookean_section(double thickness,
                                                        PlaneStressMode mode = PlaneStressMode::incompressible) {
  NeoHookeanParams p;
  p.mu = 1.0;
  p.K = mode == PlaneStressMode::incompressible ? 1000.0 : 2.0;
  return std::make_shared<ShellSection>(std::vector<ShellLayer>{{make_material(make_neo_hookean(p)), thickness, 3}}, mode);
}

/// Two layers: neo-Hookean below, Gent with one fiber family at 30° from e1 above.
std::shared_ptr<const ShellSection> fiber_section(double thickness) {
  NeoHookeanParams nh;
  nh.mu = 1.0;
  nh.K = 1000.0;
  GentHGOParams g;
  g.G = 0.8;
  g.Jm = 20.0;
  g.K = 800.0;
  FiberFamily f;
  f.direction = Vec3(std::cos(M_PI / 6), std::sin(M_PI / 6), 0.0);
  f.k1 = 2.0;
  f.k2 = 1.5;
  g.fibers.push_back(f);
  return std::make_shared<ShellSection>(std::vector<ShellLayer>{{make_material(make_neo_hookean(nh)), 0.5 * thickness, 3},
                                                                {make_material(make_gent_hgo(g)), 0.5 * thickness, 3}});
}

test::DenseSink evaluate(const ShellDomain& shell, const Mesh& mesh, const std::vector<double>& u, bool tangent) {
  return test::evaluate_dense(shell, mesh, u, tangent);
}

/// The tangent against central differences of the residual at a random finite deformation.
void expect_tangent_matches(const ShellDomain& shell, const Mesh& mesh, double amplitude) {
  std::vector<double> u(mesh.num_dofs());
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> d(-amplitude, amplitude);
  for (double& v : u) v = d(rng);
  const test::DenseSink at = evaluate(shell, mesh, u, true);
  // Central differences: error O(h² R''') ~ 1e-10 relative at h = 1e-6, round-off ~ 1e-16 |R| / h
  // ~ 1e-10; 1e-6 of the largest entry is far above both and far below a wrong term.
  const Eigen::MatrixXd fd = test::central_difference_tangent(shell, mesh, u, 1e-6);
  const double scale = fd.cwiseAbs().maxCoeff();
  EXPECT_GT(scale, 0.0);
  EXPECT_LT((at.K - fd).cwiseAbs().maxCoeff(), 1e-6 * scale);
}

Vec3 cylinder(double x, double y) {  // radius 2 about the x axis, y the arc length
  return {x, 2.0 * std::sin(y / 2.0), 2.0 * std::cos(y / 2.0)};
}

}  // namespace

TEST(ShellTriangle, TangentMatchesDifferencesOnACurvedPatchWithFreeEdges) {
  const Grid g = grid(3, 3, 1.0, 1.2, 0.2, cylinder);
  const ShellDomain shell(g.mesh, {g.tris, {}, neo_hookean_section(0.1), {}, true, {}});
  expect_tangent_matches(shell, g.mesh, 0.04);
}

TEST(ShellTriangle, TangentMatchesDifferencesOfACompressibleSection) {
  const Grid g = grid(3, 3, 1.0, 1.2, 0.2, cylinder);
  const ShellDomain shell(g.mesh, {g.tris, {}, neo_hookean_section(0.1, PlaneStressMode::compressible), {}, true, {}});
  expect_tangent_matches(shell, g.mesh, 0.04);
}

TEST(ShellTriangle, TangentMatchesDifferencesWithClampedEdgesAndAFiberLayer) {
  const Grid g = grid(3, 3, 1.0, 1.2, 0.2, cylinder);
  ShellSpec spec{g.tris, {}, fiber_section(0.1), {}, true, {}};
  for (int j = 0; j < g.ny; ++j) spec.edges.push_back({{g.node(0, j), g.node(0, j + 1)}, ShellEdge::clamped});
  for (int i = 0; i < g.nx; ++i) spec.edges.push_back({{g.node(i, 0), g.node(i + 1, 0)}, ShellEdge::clamped});
  const ShellDomain shell(g.mesh, spec);
  expect_tangent_matches(shell, g.mesh, 0.04);
}

TEST(ShellTriangle, UniformStretchOfAFlatPatchGivesUniformStressAndNoBending) {
  // Patch test: u = ((λ1 − 1) x, (λ2 − 1) y, 0) on an irregular flat mesh is in equilibrium at every
  // interior node (residual at round-off) and every triangle has the section's N of ε = ½(λ² − 1), κ = 0.
  const Grid g = grid(4, 4, 1.0, 1.0, 0.25, [](double x, double y) { return Vec3(x, y, 0.0); });
  const ShellDomain shell(g.mesh, {g.tris, {}, neo_hookean_section(0.05), {}, true, {}});
  const double l1 = 1.3, l2 = 0.9;
  std::vector<double> u(g.mesh.num_dofs(), 0.0);
  for (int n = 0; n < g.mesh.num_nodes(); ++n) {
    u[3 * n] = (l1 - 1.0) * g.mesh.nodes[n].x();
    u[3 * n + 1] = (l2 - 1.0) * g.mesh.nodes[n].y();
  }
  const test::DenseSink s = evaluate(shell, g.mesh, u, false);
  double boundary_force = 0.0;
  for (int n = 0; n < g.mesh.num_nodes(); ++n) {
    const Vec3& X = g.mesh.nodes[n];
    const bool interior = X.x() > 1e-9 && X.x() < 1 - 1e-9 && X.y() > 1e-9 && X.y() < 1 - 1e-9;
    for (int i = 0; i < 3; ++i) {
      if (interior) { EXPECT_NEAR(s.R[3 * n + i], 0.0, 1e-12); }  // forces ~ N h ~ 0.02: round-off 1e-15
      else boundary_force = std::max(boundary_force, std::abs(s.R[3 * n + i]));
    }
  }
  EXPECT_GT(boundary_force, 1e-3);
  const Vec3v eps(0.5 * (l1 * l1 - 1.0), 0.5 * (l2 * l2 - 1.0), 0.0);
  SectionResponse expected;
  ASSERT_EQ(shell.section().evaluate(eps, Vec3v::Zero(), nullptr, nullptr, 0.0, false, expected), MaterialStatus::ok);
  for (const ShellPatch& p : shell.patches()) {
    std::array<Vec3, 6> x;
    for (int k = 0; k < 6; ++k)
      if (p.nodes[k] >= 0) x[k] = g.mesh.nodes[p.nodes[k]] + Vec3(u[3 * p.nodes[k]], u[3 * p.nodes[k] + 1], 0.0);
    Vec6v strains;
    shell_strains(p, x, strains);
    // The grid's frame (global x projected) is the global one: the strains are those of the stretch.
    EXPECT_NEAR((strains.head<3>() - eps).norm(), 0.0, 1e-13);
    EXPECT_NEAR(strains.tail<3>().norm(), 0.0, 1e-12);
  }
}

TEST(ShellTriangle, CurvatureIsExactForAQuadraticSurfaceOnAnIrregularMesh) {
  // x = (X, Y, q(X, Y)) with q = (c11 X² + 2 c12 X Y + c22 Y²)/2: x,αβ = (0, 0, q,αβ), so every
  // interior triangle's κ = −q,αβ t_z (t its unit normal), whatever the mesh; the fit is a 6-point
  // quadratic interpolation, so the only error is round-off (relative 1e-10 allows for its
  // conditioning on the jittered cells).
  const Grid g = grid(5, 5, 1.0, 1.0, 0.25, [](double x, double y) { return Vec3(x, y, 0.0); });
  const ShellDomain shell(g.mesh, {g.tris, {}, neo_hookean_section(0.05), {}, true, {}});
  const double c11 = 0.7, c12 = -0.3, c22 = 0.4;
  auto q = [&](const Vec3& X) { return 0.5 * (c11 * X.x() * X.x() + 2 * c12 * X.x() * X.y() + c22 * X.y() * X.y()); };
  int interior = 0;
  for (const ShellPatch& p : shell.patches()) {
    if (p.kind[0] != 1 || p.kind[1] != 1 || p.kind[2] != 1) continue;
    ++interior;
    std::array<Vec3, 6> x;
    for (int k = 0; k < 6; ++k) x[k] = g.mesh.nodes[p.nodes[k]] + Vec3(0, 0, q(g.mesh.nodes[p.nodes[k]]));
    const double tz = (x[1] - x[0]).cross(x[2] - x[0]).normalized().z();
    Vec6v s;
    shell_strains(p, x, s);
    EXPECT_NEAR(s[3], -c11 * tz, 1e-10);
    EXPECT_NEAR(s[4], -c22 * tz, 1e-10);
    EXPECT_NEAR(s[5], -2 * c12 * tz, 1e-10);
  }
  EXPECT_GT(interior, 20);
}

TEST(ShellTriangle, CurvedReferenceSurfaceStartsUnstressed) {
  const Grid g = grid(3, 4, 1.0, 2.0, 0.2, cylinder);
  const ShellDomain shell(g.mesh, {g.tris, {}, neo_hookean_section(0.1), {}, true, {}});
  const test::DenseSink s = evaluate(shell, g.mesh, std::vector<double>(g.mesh.num_dofs(), 0.0), false);
  EXPECT_LT(s.R.cwiseAbs().maxCoeff(), 1e-14);  // κ = B − B and ε = 0 exactly
}

TEST(ShellTopology, InconsistentTrianglesAreOrientedOrRefusedNamingAnElement) {
  Grid g = grid(2, 2, 1.0, 1.0, 0.0, [](double x, double y) { return Vec3(x, y, 0.0); });
  std::swap(g.tris[3][1], g.tris[3][2]);
  std::vector<Tri3> refused = g.tris;
  try {
    shell_topology(refused, g.mesh.num_nodes(), false, "shell");
    FAIL() << "inconsistent orientation accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("element"), std::string::npos) << e.what();
  }
  std::vector<Tri3> oriented = g.tris;
  const ShellTopology t = shell_topology(oriented, g.mesh.num_nodes(), true, "shell");
  EXPECT_EQ(t.flipped, 1);  // the one turned triangle, against the seven that agree with triangle 0
  EXPECT_EQ(t.boundary_edges, 8);
  EXPECT_THROW(check_closed(t, "shell"), InputError);
}

TEST(ShellTopology, ANonManifoldEdgeIsRefused) {
  Mesh m;
  m.nodes = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, -1, 0), Vec3(0, 0, 1)};
  std::vector<Tri3> tris{{0, 1, 2}, {1, 0, 3}, {0, 1, 4}};
  EXPECT_THROW(shell_topology(tris, 5, true, "shell"), InputError);
}

TEST(ShellFrame, ProjectsTheAxisAndFallsBackNearTheNormal) {
  bool fallback = false;
  const Vec3 n = Vec3(1.0, 0.0, 1.0).normalized();
  const Mat3 f = shell_frame({}, n, Vec3::Zero(), fallback);
  EXPECT_FALSE(fallback);
  EXPECT_NEAR((f.col(0) - Vec3(1.0, 0.0, -1.0).normalized()).norm(), 0.0, 1e-14);
  EXPECT_NEAR(f.col(0).dot(n), 0.0, 1e-14);
  const Mat3 g = shell_frame({}, Vec3::UnitX(), Vec3::Zero(), fallback);
  EXPECT_TRUE(fallback);  // x is the normal: y projected instead
  EXPECT_NEAR((g.col(0) - Vec3::UnitY()).norm(), 0.0, 1e-14);
}


TEST(ShellModel, EachPartMustBeHeldOnItsOwn) {
  // Two separate square patches in one shell model, the first held at every node, the second not: the
  // rigid-motion check takes the parts from the shell's couplings and names the free one (a check of
  // the whole mesh would count the first part's holds for both).
  Grid a = grid(2, 2, 1.0, 1.0, 0.0, [](double x, double y) { return Vec3(x, y, 0.0); });
  const Grid b = grid(2, 2, 1.0, 1.0, 0.0, [](double x, double y) { return Vec3(x + 3.0, y, 0.0); });
  const int offset = a.mesh.num_nodes();
  a.mesh.nodes.insert(a.mesh.nodes.end(), b.mesh.nodes.begin(), b.mesh.nodes.end());
  for (Tri3 t : b.tris) a.tris.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
  FeModel m;
  m.mesh = a.mesh;
  m.add(std::make_shared<ShellDomain>(m.mesh, ShellSpec{a.tris, {}, neo_hookean_section(0.1), {}, true, {}}));
  DirichletGroup held;
  for (int d = 0; d < 3 * offset; ++d) held.dofs.push_back(d);
  m.dirichlet.push_back(held);
  try {
    Simulation sim(m);
    FAIL() << "a free part accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("part containing node " + std::to_string(offset)), std::string::npos) << e.what();
  }
  // Held at three corners in a way that leaves no rigid motion, the same model is accepted.
  for (int c : {offset, offset + 2, offset + 8})
    for (int i = 0; i < 3; ++i) m.dirichlet.back().dofs.push_back(3 * c + i);
  EXPECT_NO_THROW(Simulation(m, NewtonOptions{}));
}

TEST(ShellResults, EquibiaxialStretchGivesTheClosedFormStressesStretchesAndFiberDirection) {
  // u = (λ − 1)(x, y, 0) on a flat patch: incompressible neo-Hookean (μ = 1) gives λ3 = λ⁻², the Cauchy
  // stress σ = μ (λ² − λ⁻⁴) in both in-plane directions at every section point (no bending), principal
  // stretches (λ, λ, λ⁻²); a fiber at 30° from e1 stays at 30° (equal stretches). Round-off of the
  // plane-stress condensation: 1e-10.
  const Grid g = grid(2, 2, 1.0, 1.0, 0.2, [](double x, double y) { return Vec3(x, y, 0.0); });
  const ShellDomain shell(g.mesh, {g.tris, {}, fiber_section(0.1), {}, true, {}});
  const double l = 1.4;
  std::vector<double> u(g.mesh.num_dofs(), 0.0);
  for (int n = 0; n < g.mesh.num_nodes(); ++n) {
    u[3 * n] = (l - 1.0) * g.mesh.nodes[n].x();
    u[3 * n + 1] = (l - 1.0) * g.mesh.nodes[n].y();
  }
  const ShellDomain::Results r = shell.results(g.mesh, u, nullptr);
  const double sigma = l * l - std::pow(l, -4);  // the neo-Hookean layer (layer 0)
  for (int e = 0; e < int(shell.triangles().size()); ++e) {
    for (int k = 0; k < 3; ++k) {  // bottom, middle, top of layer 0
      const double* c = &r.cauchy[(std::size_t(e) * 2 + 0) * 9 + 3 * k];
      EXPECT_NEAR(c[0], sigma, 1e-10);
      EXPECT_NEAR(c[1], sigma, 1e-10);
      EXPECT_NEAR(c[2], 0.0, 1e-10);
    }
    EXPECT_NEAR(r.principal_stretch[3 * e], l, 1e-12);
    EXPECT_NEAR(r.principal_stretch[3 * e + 1], l, 1e-12);
    EXPECT_NEAR(r.thickness_stretch[e], 1.0 / (l * l), 1e-10);
    EXPECT_NEAR(r.fiber[3 * e], std::cos(M_PI / 6), 1e-12);
    EXPECT_NEAR(r.fiber[3 * e + 1], std::sin(M_PI / 6), 1e-12);
  }
  EXPECT_GE(r.max_principal, sigma - 1e-10);  // the fiber layer adds its tension on top
  EXPECT_GE(r.max_element, 0);
}

// The closed-form kinematics of the assembly (shell_kinematics, shell_geometric_stiffness) against the
// forward jets of shell_strains on every patch of a jittered curved grid with clamped and free edges,
// at a random finite deformation and random section forces: the same strains, B and Σ NM_k ∂²s_k to
// round-off (1e-10 of the largest entry; a wrong term is O(1) of it).
TEST(ShellTriangle, ClosedFormKinematicsMatchTheJets) {
  Grid g = grid(4, 3, 2.0, 1.5, 0.2, cylinder);
  std::vector<std::pair<std::array<int, 2>, ShellEdge>> edges;
  for (int j = 0; j < g.ny; ++j) edges.push_back({{g.node(0, j), g.node(0, j + 1)}, ShellEdge::clamped});
  const ShellDomain shell(g.mesh, {g.tris, edges, neo_hookean_section(0.1), {}, true, {}});
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> d(-0.1, 0.1);
  for (const ShellPatch& p : shell.patches()) {
    std::array<Vec3, 6> x;
    for (int s = 0; s < 6; ++s)
      if (p.nodes[s] >= 0) x[s] = g.mesh.nodes[p.nodes[s]] + Vec3(d(rng), d(rng), d(rng));
    Vec6v NM;
    for (int k = 0; k < 6; ++k) NM[k] = 10.0 * d(rng);
    Vec6v s_jet, s_closed;
    Eigen::Matrix<double, 6, 18> B_jet, B_closed;
    std::array<Eigen::Matrix<double, 18, 18>, 6> H;
    shell_strains(p, x, s_jet, &B_jet, &H);
    Eigen::Matrix<double, 18, 18> G_jet = Eigen::Matrix<double, 18, 18>::Zero(), G_closed;
    for (int k = 0; k < 6; ++k) G_jet += NM[k] * H[k];
    shell_kinematics(p, x, s_closed, B_closed);
    shell_geometric_stiffness(p, x, NM, G_closed);
    // Absent slots carry no dofs: their rows and columns are compared as zeros on both sides.
    for (int s = 0; s < 6; ++s)
      if (p.nodes[s] < 0) {
        B_jet.middleCols<3>(3 * s).setZero();
        G_jet.middleRows<3>(3 * s).setZero();
        G_jet.middleCols<3>(3 * s).setZero();
        B_closed.middleCols<3>(3 * s).setZero();
        G_closed.middleRows<3>(3 * s).setZero();
        G_closed.middleCols<3>(3 * s).setZero();
      }
    EXPECT_LT((s_jet - s_closed).cwiseAbs().maxCoeff(), 1e-10 * s_jet.cwiseAbs().maxCoeff() + 1e-14);
    EXPECT_LT((B_jet - B_closed).cwiseAbs().maxCoeff(), 1e-10 * B_jet.cwiseAbs().maxCoeff());
    EXPECT_LT((G_jet - G_closed).cwiseAbs().maxCoeff(), 1e-10 * G_jet.cwiseAbs().maxCoeff());
  }
}
