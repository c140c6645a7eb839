// Fibers tied to the solid (fe/fibers.hpp): the 1D laws and the host's uniaxial stress against central
// differences; a fiber along a block in uniform tension carries the rule-of-mixtures force, with and
// without the volume correction, on hex8 and tet10 hosts and wherever the fiber crosses the host's
// faces and edges; a rigid rotation gives no force; the contribution's tangent against central
// differences; bad input refused naming its key.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <random>

#include "dense_sink.hpp"
#include "softhom/core/input_error.hpp"
#include "softhom/fe/fibers.hpp"
#include "softhom/fe/solver.hpp"
#include "softhom/materials/laws.hpp"

using namespace softhom;
using namespace softhom::fe;

namespace {

using test::DenseSink;

DenseSink evaluate(const Contribution& c, const Mesh& mesh, const std::vector<double>& u, bool tangent) {
  return test::evaluate_dense(c, mesh, u, tangent);
}

/// A box [0, size] of n cells per direction (hex8), node (i, j, k) at i + (n0+1)(j + (n1+1) k); nodes
/// not on the box's faces moved by up to `jitter` of a cell (seeded), and its six faces named.
Mesh block(const Vec3& size, std::array<int, 3> n, double jitter = 0.0, const Vec3& offset = Vec3::Zero()) {
  Mesh m;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> d(-jitter, jitter);
  for (int k = 0; k <= n[2]; ++k)
    for (int j = 0; j <= n[1]; ++j)
      for (int i = 0; i <= n[0]; ++i) {
        Vec3 X(size[0] * i / n[0], size[1] * j / n[1], size[2] * k / n[2]);
        const bool interior = i > 0 && i < n[0] && j > 0 && j < n[1] && k > 0 && k < n[2];
        if (interior) X += Vec3(d(rng) * size[0] / n[0], d(rng) * size[1] / n[1], d(rng) * size[2] / n[2]);
        m.nodes.push_back(X + offset);
      }
  auto id = [&](int i, int j, int k) { return i + (n[0] + 1) * (j + (n[1] + 1) * k); };
  for (int k = 0; k < n[2]; ++k)
    for (int j = 0; j < n[1]; ++j)
      for (int i = 0; i < n[0]; ++i)
        m.hexes.push_back({id(i, j, k), id(i + 1, j, k), id(i + 1, j + 1, k), id(i, j + 1, k), id(i, j, k + 1),
                           id(i + 1, j, k + 1), id(i + 1, j + 1, k + 1), id(i, j + 1, k + 1)});
  m.region.assign(m.hexes.size(), 0);
  const Vec3 lo = offset, hi = offset + size;
  name_boundary_faces(m, [&](const Vec3& c, const Vec3& nrm) -> std::string {
    static const char* names[3][2] = {{"xmin", "xmax"}, {"ymin", "ymax"}, {"zmin", "zmax"}};
    for (int a = 0; a < 3; ++a) {
      if (std::abs(c[a] - lo[a]) < 1e-9 && nrm[a] < -0.5) return names[a][0];
      if (std::abs(c[a] - hi[a]) < 1e-9 && nrm[a] > 0.5) return names[a][1];
    }
    return "";
  });
  return m;
}

FiberLines straight(const Vec3& a, const Vec3& b, int segments) {
  FiberLines l;
  l.lines.emplace_back();
  for (int s = 0; s <= segments; ++s) l.lines[0].push_back(a + (b - a) * double(s) / segments);
  return l;
}

std::vector<double> affine(const Mesh& mesh, const Mat3& F) {
  std::vector<double> u(mesh.num_dofs());
  for (int n = 0; n < mesh.num_nodes(); ++n) {
    const Vec3 d = (F - Mat3::Identity()) * mesh.nodes[n];
    for (int c = 0; c < 3; ++c) u[3 * n + c] = d[c];
  }
  return u;
}

MaterialPtr matrix_material() { return make_material(make_neo_hookean({1.0, 10.0})); }  // compressible: lateral stretch ≠ λ^-1/2

FiberOptions glass(bool correction = false) {
  FiberOptions o;
  o.law = {FiberLawKind::neo_hookean, 100.0, 0.05, false};
  o.volume_correction = correction;
  return o;
}

}  // namespace

TEST(Fibers, LawsMatchTheirDerivativeByCentralDifferences) {
  // N(λ) is smooth away from the cable's kink: central differences with h = 1e-6 carry O(h²) ≈ 1e-12
  // and ~1e-16 / h of round-off relative to EA; 1e-8 still catches a wrong factor.
  for (FiberLawKind kind : {FiberLawKind::linear, FiberLawKind::neo_hookean})
    for (double lambda : {0.7, 1.0, 1.3, 2.5}) {
      const FiberLaw law{kind, 10.0, 0.2, false};
      const double h = 1e-6;
      const double fd = (fiber_force(law, lambda + h).force - fiber_force(law, lambda - h).force) / (2 * h);
      EXPECT_NEAR(fiber_force(law, lambda).stiffness, fd, 1e-8 * 2.0) << int(kind) << " " << lambda;
    }
  const FiberLaw cable{FiberLawKind::linear, 10.0, 0.2, true};
  EXPECT_EQ(fiber_force(cable, 0.9).force, 0.0);
  EXPECT_EQ(fiber_force(cable, 0.9).stiffness, 0.0);
  EXPECT_NEAR(fiber_force(cable, 1.1).force, 10.0 * 0.2 * 0.1, 1e-15);  // (1.1 − 1 is not 0.1 in binary)
  // The neo-Hookean fiber's small-strain modulus is E: N ≈ E A (λ − 1) near λ = 1.
  EXPECT_NEAR(fiber_force({FiberLawKind::neo_hookean, 10.0, 0.2, false}, 1.0).stiffness, 2.0, 1e-15);
}

TEST(Fibers, HostUniaxialStressIsTheLawsUniaxialResponse) {
  // Lateral stresses vanish at the returned state; the stiffness is dP/dλ along the uniaxial path
  // (central differences, tolerance as above on the scale of 3G).
  const MaterialPtr m = matrix_material();
  const Vec3 T = Vec3(1.0, 2.0, -0.5).normalized();
  for (double lambda : {0.8, 1.0, 1.4}) {
    FiberForce p, pp, pm;
    ASSERT_EQ(uniaxial_nominal_stress(*m, T, lambda, p), MaterialStatus::ok);
    const double h = 1e-6;
    ASSERT_EQ(uniaxial_nominal_stress(*m, T, lambda + h, pp), MaterialStatus::ok);
    ASSERT_EQ(uniaxial_nominal_stress(*m, T, lambda - h, pm), MaterialStatus::ok);
    EXPECT_NEAR(p.stiffness, (pp.force - pm.force) / (2 * h), 1e-7);
    if (lambda == 1.0) {
      EXPECT_NEAR(p.force, 0.0, 1e-14);
    }
  }
  FiberForce small;
  ASSERT_EQ(uniaxial_nominal_stress(*m, T, 1.0, small), MaterialStatus::ok);
  // Young's modulus of the compressible law: 9 K G / (3 K + G).
  EXPECT_NEAR(small.stiffness, 9 * 10.0 * 1.0 / (30.0 + 1.0), 1e-10);
}

namespace {

/// Block 2 × 1 × 1 of `matrix` stretched along x to λ over t ∈ [0, 1] and held there (xmin held in x,
/// xmax moved, rigid modes pinned) with the fiber (y0, z0) along x, solved by the Newton driver: the
/// reaction at xmax at each of `times`.
std::vector<double> block_reactions(const Mesh& mesh, const MaterialPtr& matrix, double lambda,
                                    const std::optional<FiberOptions>& fibers, double y0, double z0,
                                    const std::vector<double>& times) {
  FeModel model;
  model.mesh = mesh;
  model.element_material.assign(mesh.num_elements(), matrix);
  const auto xmin = surface_nodes(mesh, "xmin"), xmax = surface_nodes(mesh, "xmax");
  DirichletGroup held, moved;
  for (int n : xmin) held.dofs.push_back(3 * n);
  std::vector<int> reaction;
  for (int n : xmax) {
    moved.dofs.push_back(3 * n);
    reaction.push_back(3 * n);
  }
  moved.value = PiecewiseLinear{{0.0, 1.0, 1e9}, {0.0, 2.0 * (lambda - 1.0), 2.0 * (lambda - 1.0)}};
  const int origin = select_nodes(mesh, [](const Vec3& x) { return x.norm() < 1e-12; })[0];
  const int corner = select_nodes(mesh, [](const Vec3& x) { return (x - Vec3(0, 1, 0)).norm() < 1e-12; })[0];
  held.dofs.insert(held.dofs.end(), {3 * origin + 1, 3 * origin + 2, 3 * corner + 2});
  model.dirichlet = {held, moved};
  if (fibers)
    model.add(std::make_shared<TiedFibers>(model.mesh, straight({0.0, y0, z0}, {2.0, y0, z0}, 5), *fibers,
                                           model.element_material));
  NewtonOptions o;
  o.tolerance = 1e-13;  // the uniform state is the discrete solution: Newton reaches round-off
  o.mixed = false;
  Simulation sim(model, o);
  std::vector<double> out;
  for (double t : times) {
    EXPECT_TRUE(sim.advance_to(t).reached());
    out.push_back(sim.reaction(reaction));
  }
  return out;
}

double block_reaction(const Mesh& mesh, double lambda, const std::optional<FiberOptions>& fibers, double y0, double z0) {
  return block_reactions(mesh, matrix_material(), lambda, fibers, y0, z0, {1.0})[0];
}

void expect_rule_of_mixtures(const Mesh& mesh) {
  const double lambda = 1.3;
  const double block = block_reaction(mesh, lambda, std::nullopt, 0.5, 0.5);  // A_block P_m (A_block = 1)
  FiberForce matrix;
  ASSERT_EQ(uniaxial_nominal_stress(*matrix_material(), Vec3::UnitX(), lambda, matrix), MaterialStatus::ok);
  // The FE block is in the same uniaxial state as the law's point (Newton to round-off).
  EXPECT_NEAR(block, matrix.force, 1e-11 * block);
  for (bool correction : {false, true}) {
    const FiberOptions o = glass(correction);
    const double Nf = fiber_force(o.law, lambda).force;
    const double expected = block + Nf - (correction ? o.law.area * matrix.force : 0.0);
    // A generic position, then on an element edge (y, z on mesh lines): the same force. Both to 1e-10
    // of the total: the uniform state is exact, and Newton at 1e-13 of the force scale leaves less.
    for (auto [y0, z0] : {std::pair{0.37, 0.61}, std::pair{0.5, 0.5}}) {
      const double total = block_reaction(mesh, lambda, o, y0, z0);
      EXPECT_NEAR(total, expected, 1e-10 * expected) << "correction " << correction << " at " << y0 << ", " << z0;
    }
  }
}

}  // namespace

TEST(Fibers, RuleOfMixturesInUniformTensionOnHex8) { expect_rule_of_mixtures(block({2, 1, 1}, {4, 2, 2})); }

TEST(Fibers, RuleOfMixturesInUniformTensionOnTet10) { expect_rule_of_mixtures(hex_to_tet10(block({2, 1, 1}, {2, 2, 2}))); }

TEST(Fibers, InARelaxingQlvHostTheForceFollowsTheRuleOfMixtures) {
  // A QLV matrix (g∞ = 0.4, τ = 1) stretched to 1.3 over t ∈ [0, 1] and held to t = 6: the block alone
  // relaxes (its reaction R_m(t) falls toward g∞ of the elastic one); the elastic fiber keeps its force
  // N_f = E A (λ − 1), so with the fiber the reaction is R_m(t) + N_f at every time, and with the volume
  // correction (the fiber displaces area A of the relaxing matrix, per unit block area 1)
  // R_m(t) (1 − A) + N_f: the correction follows the host's relaxation through its own history. The
  // uniform state is the discrete solution at each step (Newton at 1e-13), and the corrected fiber's
  // uniaxial history integrates the same law over the same steps as the block's points: 1e-9 of the force.
  const Mesh mesh = block({2, 1, 1}, {2, 1, 1});
  const MaterialPtr qlv = make_material(make_neo_hookean({1.0, 10.0}), PronySeries{0.4, {{0.6, 1.0}}});
  const std::vector<double> times{0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 4.5, 6.0};
  const double lambda = 1.3;
  const std::vector<double> matrix = block_reactions(mesh, qlv, lambda, std::nullopt, 0.5, 0.5, times);
  EXPECT_LT(matrix.back(), 0.6 * matrix[3]);  // it did relax (to about g∞ = 0.4 of the ramp's end)
  for (bool correction : {false, true}) {
    const FiberOptions o = glass(correction);
    const std::vector<double> with = block_reactions(mesh, qlv, lambda, o, 0.37, 0.61, times);
    for (std::size_t k = 0; k < times.size(); ++k) {
      const double stretch = 1.0 + (lambda - 1.0) * std::min(times[k], 1.0);
      const double expected = matrix[k] * (correction ? 1.0 - o.law.area : 1.0) + fiber_force(o.law, stretch).force;
      EXPECT_NEAR(with[k], expected, 1e-9 * expected) << "correction " << correction << " at t = " << times[k];
    }
  }
}

TEST(Fibers, EveryElementCarriesTheAffineForceWhereverTheHostCutsTheFiber) {
  // An inclined fiber (3-node elements) through a regular block and through the same block with its
  // interior nodes moved by up to 30 % of a cell and shifted: the fiber crosses other faces and edges,
  // and under an affine motion every element carries N(|F T|) to round-off.
  Mat3 F;
  F << 1.2, 0.1, -0.05, 0.02, 0.9, 0.1, 0.0, -0.08, 1.1;
  const Vec3 a(0.1, 0.2, 0.15), b(1.9, 0.85, 0.8);
  const double expected = fiber_force(glass().law, (F * (b - a).normalized()).norm()).force;
  for (const Mesh& mesh : {block({2, 1, 1}, {4, 2, 2}), block({2.2, 1.2, 1.2}, {5, 3, 3}, 0.3, Vec3(-0.1, -0.1, -0.1)),
                           hex_to_tet10(block({2.2, 1.2, 1.2}, {3, 2, 2}, 0.2, Vec3(-0.1, -0.1, -0.1)))}) {
    FiberOptions o = glass();
    o.order = 2;
    const TiedFibers fibers(mesh, straight(a, b, 8), o);
    const std::vector<double> u = affine(mesh, F);
    Iterate it;
    it.u = &u;
    for (const FiberElementState& s : fibers.states(mesh, it)) EXPECT_NEAR(s.force, expected, 1e-12 * expected);
  }
}

TEST(Fibers, ARigidRotationGivesNoForce) {
  const Mesh mesh = block({2, 1, 1}, {4, 2, 2}, 0.2);
  const Mat3 R = Eigen::AngleAxisd(1.1, Vec3(0.3, -1.0, 0.4).normalized()).toRotationMatrix();
  for (bool correction : {false, true}) {
    FiberOptions o = glass(correction);
    const std::vector<MaterialPtr> materials(mesh.num_elements(), matrix_material());
    const TiedFibers fibers(mesh, straight({0.1, 0.2, 0.3}, {1.9, 0.7, 0.8}, 6), o, materials);
    const DenseSink s = evaluate(fibers, mesh, affine(mesh, R), false);
    // λ = 1 to round-off (1e-16 relative): forces of order E A 1e-16 = 5e-16; allow 1e-13.
    EXPECT_LT(s.R.cwiseAbs().maxCoeff(), 1e-13) << "correction " << correction;
  }
}

namespace {

double tangent_gap(const Mesh& mesh, const TiedFibers& fibers, double amplitude) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> d(-amplitude, amplitude);
  std::vector<double> u = affine(mesh, Vec3(1.3, 0.9, 1.1).asDiagonal());
  for (double& v : u) v += d(rng);
  const DenseSink at = evaluate(fibers, mesh, u, true);
  const Eigen::MatrixXd fd = test::central_difference_tangent(fibers, mesh, u, 1e-6);
  return (at.K - fd).cwiseAbs().maxCoeff() / at.K.cwiseAbs().maxCoeff();
}

}  // namespace

TEST(Fibers, TangentMatchesCentralDifferences) {
  // Central differences, h = 1e-6 on displacements of order 0.1–0.3 and entries of order EA: O(h²) and
  // ~1e-16 / h round-off leave ~1e-10 relative; 1e-7 catches a missing geometric term or factor.
  const Mesh hex = block({1, 1, 1}, {2, 1, 1}, 0.0);
  const Mesh tet = hex_to_tet10(block({1, 1, 1}, {1, 1, 1}));
  const std::vector<MaterialPtr> mh(hex.num_elements(), matrix_material()), mt(tet.num_elements(), matrix_material());
  for (int order : {1, 2})
    for (bool correction : {false, true}) {
      FiberOptions o = glass(correction);
      o.order = order;
      const FiberLines line = straight({0.05, 0.3, 0.2}, {0.95, 0.75, 0.85}, 4);
      EXPECT_LT(tangent_gap(hex, TiedFibers(hex, line, o, mh), 0.05), 1e-7) << "hex8, order " << order << " correction " << correction;
      EXPECT_LT(tangent_gap(tet, TiedFibers(tet, line, o, mt), 0.05), 1e-7) << "tet10, order " << order << " correction " << correction;
    }
  FiberOptions cable = glass();
  cable.law = {FiberLawKind::linear, 10.0, 0.1, true};
  EXPECT_LT(tangent_gap(hex, TiedFibers(hex, straight({0.05, 0.3, 0.2}, {0.95, 0.75, 0.85}, 3), cable), 0.05), 1e-7);
}

TEST(Fibers, SurfaceTieInterpolatesTheFaceOnly) {
  // A fiber on the top face, tied to "zmax": it couples only that face's nodes, and carries the affine force.
  const Mesh mesh = block({2, 1, 1}, {4, 2, 2});
  FiberOptions o = glass();
  o.tie = FiberTie::surface;
  o.surface = "zmax";
  const TiedFibers fibers(mesh, straight({0.1, 0.3, 1.0}, {1.9, 0.8, 1.0}, 5), o);
  const auto top = surface_nodes(mesh, "zmax");
  Couplings c;
  fibers.declare_couplings(c);
  for (int n : c.nodes) EXPECT_TRUE(std::binary_search(top.begin(), top.end(), n));
  const Mat3 F = Vec3(1.2, 1.1, 0.9).asDiagonal();
  const std::vector<double> u = affine(mesh, F);
  Iterate it;
  it.u = &u;
  const double expected = fiber_force(o.law, (F * Vec3(1.8, 0.5, 0.0).normalized()).norm()).force;
  for (const auto& s : fibers.states(mesh, it)) EXPECT_NEAR(s.force, expected, 1e-12 * expected);
}

TEST(Fibers, BadInputIsRefusedNamingItsKey) {
  const Mesh mesh = block({2, 1, 1}, {2, 1, 1});
  auto field_of = [&](const FiberLines& l, const FiberOptions& o) -> std::string {
    try {
      TiedFibers f(mesh, l, o);
    } catch (const InputError& e) {
      return e.what();
    }
    return "accepted";
  };
  FiberOptions o = glass();
  EXPECT_NE(field_of(straight({0.1, 0.5, 0.5}, {2.5, 0.5, 0.5}, 4), o).find("outside every host element"), std::string::npos);
  o.law.area = 0.0;
  EXPECT_NE(field_of(straight({0.1, 0.5, 0.5}, {1.5, 0.5, 0.5}, 4), o).find("fibers.area"), std::string::npos);
  o = glass();
  o.tie = FiberTie::surface;
  o.surface = "lid";
  EXPECT_NE(field_of(straight({0.1, 0.5, 1.0}, {1.5, 0.5, 1.0}, 4), o).find("fibers.surface"), std::string::npos);
  o.surface = "zmax";
  EXPECT_NE(field_of(straight({0.1, 0.5, 0.5}, {1.5, 0.5, 0.5}, 4), o).find("not on surface"), std::string::npos);
}

TEST(Fibers, ReportGivesPolylinesWithStretchForceAndAngle) {
  // The field's cells are the fiber elements (line3 for 3-node ones, in XDMF order: ends, then middle),
  // on the reference points; its arrays are the states of the elements (the same numbers).
  const Mesh mesh = block({2, 1, 1}, {4, 2, 2});
  FiberOptions o = glass();
  o.order = 2;
  o.field = "fibers[1]";
  const TiedFibers fibers(mesh, straight({0.1, 0.2, 0.3}, {1.9, 0.7, 0.8}, 6), o);
  const std::vector<double> u = affine(mesh, Vec3(1.2, 1.0, 1.0).asDiagonal());
  Iterate it;
  it.u = &u;
  ContributionReport r;
  fibers.report(mesh, it, r);
  ASSERT_EQ(r.fields.size(), 1u);
  const ReportField& f = r.fields[0];
  EXPECT_EQ(f.cells.stem, "fibers_1");
  EXPECT_EQ(f.cells.type, ReportCells::Type::line3);
  ASSERT_EQ(f.cells.connectivity.size(), 3u * fibers.num_elements());
  EXPECT_EQ(f.cells.connectivity[2], 1);  // the first element's middle node is the polyline's second point
  const auto states = fibers.states(mesh, it);
  ASSERT_EQ(f.arrays.size(), 4u);
  for (int e = 0; e < fibers.num_elements(); ++e) {
    EXPECT_EQ(f.arrays[0].values[e], states[e].stretch);
    EXPECT_EQ(f.arrays[1].values[e], states[e].force);
    EXPECT_EQ(f.arrays[2].values[e], states[e].angle_deg);
  }
  ASSERT_EQ(r.probes.size(), 3u);
  EXPECT_EQ(r.probes[1].first, "fibers_1_max_force [N]");
  // The first element's current angle from the z axis: its chord (1.2 · 0.6, 1/6, 1/6) between the
  // current points 0 and 2, split into the hoop direction at its midpoint and z (to round-off).
  const Vec3 d(1.2 * 0.6, 1.0 / 6, 1.0 / 6), mid(1.2 * 0.4, 0.2 + 1.0 / 12, 0.3 + 1.0 / 12);
  const Vec3 e_theta = Vec3(-mid[1], mid[0], 0.0).normalized();
  EXPECT_NEAR(f.arrays[2].values[0], std::atan2(d.dot(e_theta), d[2]) * 180 / M_PI, 1e-9);
}
