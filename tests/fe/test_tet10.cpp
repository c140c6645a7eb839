// Quadratic tetrahedron basics: interpolation property, partition of unity, derivatives against
// finite differences and exactness of the degree-2 rule. Tolerances: shape functions are exact
// quadratics (round-off ~1e-15); central differences of a quadratic are exact up to round-off/h.
#include <gtest/gtest.h>

#include <random>

#include "softhom/fe/tet10.hpp"

namespace softhom::fe {
namespace {

Eigen::Vector3d node_xi(int a) {
  const Eigen::Vector3d v[4] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  if (a < 4) return v[a];
  return 0.5 * (v[kTet10Edges[a - 4][0]] + v[kTet10Edges[a - 4][1]]);
}

TEST(Tet10, KroneckerAtNodesAndPartitionOfUnity) {
  for (int a = 0; a < 10; ++a) {
    const Tet10Vec N = tet10_shape(node_xi(a));
    for (int b = 0; b < 10; ++b) EXPECT_NEAR(N[b], a == b ? 1.0 : 0.0, 1e-15) << a << " " << b;
  }
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0.0, 0.33);
  for (int k = 0; k < 20; ++k) {
    const Eigen::Vector3d xi(u(rng), u(rng), u(rng));
    EXPECT_NEAR(tet10_shape(xi).sum(), 1.0, 1e-14);
    EXPECT_LT(tet10_shape_derivatives(xi).colwise().sum().norm(), 1e-13);
  }
}

TEST(Tet10, DerivativesMatchFiniteDifferences) {
  const Eigen::Vector3d xi(0.21, 0.17, 0.34);
  const Tet10Grad d = tet10_shape_derivatives(xi);
  const double h = 1e-6;
  for (int J = 0; J < 3; ++J) {
    Eigen::Vector3d e = Eigen::Vector3d::Zero();
    e[J] = h;
    const Tet10Vec fd = (tet10_shape(xi + e) - tet10_shape(xi - e)) / (2 * h);
    EXPECT_LT((fd - d.col(J)).cwiseAbs().maxCoeff(), 1e-9) << "J = " << J;
  }
}

TEST(Tet10, DegreeTwoRuleIsExactForQuadratics) {
  // ∫_T ξ1² dV = 2!/5! = 1/60, ∫ ξ1 ξ2 dV = 1/120, ∫ 1 dV = 1/6.
  double v = 0, x2 = 0, xy = 0;
  for (const auto& q : tet_rule_degree2()) {
    v += q.w;
    x2 += q.w * q.xi[0] * q.xi[0];
    xy += q.w * q.xi[0] * q.xi[1];
  }
  EXPECT_NEAR(v, 1.0 / 6.0, 1e-15);
  EXPECT_NEAR(x2, 1.0 / 60.0, 1e-15);
  EXPECT_NEAR(xy, 1.0 / 120.0, 1e-15);
}

}  // namespace
}  // namespace softhom::fe
