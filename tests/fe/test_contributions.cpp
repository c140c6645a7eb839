// The built-in contributions (model.hpp) through the public AssemblySink: the follower pressure's
// tangent and the cavity's tangent and border (∂R/∂p, ∂V/∂u) against central differences of their
// residual and volume, on the faces of one distorted hex8 (quads) and of its split into tet10 (6-node
// triangles), and the nodal load's residual.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>

#include "softhom/fe/model.hpp"
#include "softhom/fe/mesh.hpp"
#include "dense_sink.hpp"

using namespace softhom;
using namespace softhom::fe;

namespace {

using test::DenseSink;

/// A unit cube's hex8 with its corners moved by up to 0.15 (seeded), and its six faces (outward).
Mesh distorted_cube() {
  Mesh m;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> shift(-0.15, 0.15);
  for (int k = 0; k < 8; ++k) {
    const Vec3 corner((k == 1 || k == 2 || k == 5 || k == 6) ? 1.0 : 0.0, (k == 2 || k == 3 || k == 6 || k == 7) ? 1.0 : 0.0,
                      k >= 4 ? 1.0 : 0.0);
    m.nodes.push_back(corner + Vec3(shift(rng), shift(rng), shift(rng)));
  }
  m.hexes.push_back({0, 1, 2, 3, 4, 5, 6, 7});
  for (const auto& f : kHexFaces) m.surfaces["all"].push_back({f[0], f[1], f[2], f[3]});
  return m;
}

std::vector<double> random_displacement(int ndof, double amplitude) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> d(-amplitude, amplitude);
  std::vector<double> u(ndof);
  for (double& v : u) v = d(rng);
  return u;
}

DenseSink evaluate(const Contribution& c, const Mesh& mesh, const std::vector<double>& u, double p, bool tangent) {
  DenseSink sink(mesh.num_dofs(), tangent);
  Iterate it;
  it.t = it.t_stiffness = 1.0;
  it.u = &u;
  it.bordered = p;
  EXPECT_EQ(c.assemble(mesh, it, sink), MaterialStatus::ok);
  return sink;
}

/// max |K − ∂R/∂u (central differences)| / max |K|, and the same for the cavity's g against ∂c/∂u.
struct FdGaps {
  double tangent = 0.0, volume_gradient = 0.0;
};

FdGaps finite_difference_gaps(const Contribution& c, const Mesh& mesh, double p) {
  const int n = mesh.num_dofs();
  const std::vector<double> u = random_displacement(n, 0.1);
  const DenseSink at = evaluate(c, mesh, u, p, true);
  const double h = 1e-6;
  Eigen::MatrixXd K_fd(n, n);
  Eigen::VectorXd g_fd(n);
  for (int j = 0; j < n; ++j) {
    std::vector<double> up = u, um = u;
    up[j] += h;
    um[j] -= h;
    const DenseSink sp = evaluate(c, mesh, up, p, false), sm = evaluate(c, mesh, um, p, false);
    K_fd.col(j) = (sp.R - sm.R) / (2 * h);
    g_fd[j] = (sp.c - sm.c) / (2 * h);
  }
  FdGaps gaps;
  gaps.tangent = (at.K - K_fd).cwiseAbs().maxCoeff() / at.K.cwiseAbs().maxCoeff();
  if (at.g.cwiseAbs().maxCoeff() > 0.0) gaps.volume_gradient = (at.g - g_fd).cwiseAbs().maxCoeff() / at.g.cwiseAbs().maxCoeff();
  return gaps;
}

// a(x) is quadratic in the nodal coordinates (n = x_ξ × x_η) and V cubic: the central differences
// (h = 1e-6, entries of order one) are exact for a and off by ~h² for V, and carry ~1e-16 / h of
// round-off, so 1e-7 leaves room and still catches a wrong sign or factor.
constexpr double kFdTolerance = 1e-7;

}  // namespace

TEST(Contributions, FollowerPressureTangentMatchesFiniteDifferencesOnQuadsAndTri6) {
  const Mesh hex = distorted_cube();
  const PressureLoad quads(hex.surface("all"), PiecewiseLinear::constant(0.7));
  EXPECT_LT(finite_difference_gaps(quads, hex, 0.0).tangent, kFdTolerance);
  const Mesh tet = hex_to_tet10(hex);
  const PressureLoad tris({}, PiecewiseLinear::constant(0.7), tet.tri_surface("all"));
  ASSERT_FALSE(tris.tris.empty());
  EXPECT_LT(finite_difference_gaps(tris, tet, 0.0).tangent, kFdTolerance);
}

TEST(Contributions, CavityTangentAndVolumeGradientMatchFiniteDifferences) {
  const Mesh hex = distorted_cube();
  for (const Vec3& mask : {Vec3(1, 1, 1), Vec3(1, 1, 0)}) {
    const CavityControl quads(hex.surface("all"), mask, PiecewiseLinear::constant(1.0));
    const FdGaps q = finite_difference_gaps(quads, hex, 0.4);
    EXPECT_LT(q.tangent, kFdTolerance);
    EXPECT_LT(q.volume_gradient, kFdTolerance);
  }
  const Mesh tet = hex_to_tet10(hex);
  const CavityControl tris({}, Vec3(1, 1, 1), PiecewiseLinear::constant(1.0), tet.tri_surface("all"));
  const FdGaps t = finite_difference_gaps(tris, tet, 0.4);
  EXPECT_LT(t.tangent, kFdTolerance);
  EXPECT_LT(t.volume_gradient, kFdTolerance);
}

TEST(Contributions, CavityBorderIsTheResidualPerUnitPressureAndItsValueTheEnclosedVolume) {
  const Mesh hex = distorted_cube();
  const CavityControl cavity(hex.surface("all"), Vec3(1, 1, 1), PiecewiseLinear::constant(1.0));
  const std::vector<double> u = random_displacement(hex.num_dofs(), 0.1);
  const DenseSink s = evaluate(cavity, hex, u, 0.4, false);
  // R = p a exactly (one product per entry).
  EXPECT_LT((s.R - 0.4 * s.a).cwiseAbs().maxCoeff(), 1e-15 * s.R.cwiseAbs().maxCoeff());
  // The constraint value is cavity_volume of the current faces (the same quadrature, so to round-off).
  std::vector<Vec3> x(hex.nodes);
  for (std::size_t n = 0; n < x.size(); ++n) x[n] += Vec3(u[3 * n], u[3 * n + 1], u[3 * n + 2]);
  const double v = cavity_volume(x, hex.surface("all"), Vec3(1, 1, 1));
  EXPECT_NEAR(s.c, v, 1e-14 * std::abs(v));
  // The solid's own outward faces enclose it with the opposite sign: V = −(volume of the hex).
  EXPECT_LT(v, 0.0);
}

TEST(Contributions, NodalLoadAddsMinusItsForce) {
  Mesh m = distorted_cube();
  const NodalLoad load({2, 7}, {1.5, -0.5}, PiecewiseLinear{{0.0, 2.0}, {0.0, 2.0}});
  const DenseSink s = evaluate(load, m, std::vector<double>(m.num_dofs(), 0.0), 0.0, true);
  // At t = 1 the value is 1: R = −f exactly, and no tangent.
  EXPECT_EQ(s.R[2], -1.5);
  EXPECT_EQ(s.R[7], 0.5);
  EXPECT_EQ(s.K.cwiseAbs().maxCoeff(), 0.0);
}
