// The follower end moment of a rotation-free shell edge (fe::ShellEdgeMoment): its tangent against
// central differences, a pure couple work-conjugate to the chords' rotation, and the pairs it takes
// from a strip's edge.
#include <gtest/gtest.h>

#include <cmath>

#include "dense_sink.hpp"
#include "softhom/fe/shell.hpp"

using namespace softhom;

namespace {

/// Two chords (edge node, inner node) in general position, with shares 0.3 and 0.7.
struct TwoChords {
  fe::Mesh mesh;
  std::vector<fe::ShellEdgeMoment::Pair> pairs{{0, 1, 0.3}, {2, 3, 0.7}};
  TwoChords() { mesh.nodes = {Vec3(1.0, 0.1, 0.2), Vec3(0.2, -0.1, 0.05), Vec3(0.9, 1.1, -0.3), Vec3(0.1, 0.8, 0.4)}; }
};

}  // namespace

TEST(ShellEdgeMoment, TangentMatchesCentralDifferences) {
  const TwoChords c;
  const fe::ShellEdgeMoment moment(c.pairs, Vec3(0.2, -1.0, 0.3), PiecewiseLinear::constant(2.5), "moment");
  const std::vector<double> u{0.1, -0.2, 0.3, 0.0, 0.05, -0.1, -0.2, 0.1, 0.4, 0.3, 0.0, -0.1};
  const test::DenseSink sink = test::evaluate_dense(moment, c.mesh, u, true);
  const Eigen::MatrixXd fd = test::central_difference_tangent(moment, c.mesh, u, 1e-6);
  // Central differences of smooth trigonometric functions at h = 1e-6: truncation ~1e-12, round-off
  // ~1e-10 of entries of order 1.
  EXPECT_LT((sink.K - fd).norm(), 1e-7 * sink.K.norm());
  EXPECT_LT((sink.K - sink.K.transpose()).norm(), 1e-12 * sink.K.norm());  // conservative: symmetric
}

TEST(ShellEdgeMoment, IsAPureCoupleWorkConjugateToTheChordRotation) {
  const TwoChords c;
  const Vec3 axis = Vec3(0.2, -1.0, 0.3).normalized();
  const double M = 2.5;
  const fe::ShellEdgeMoment moment(c.pairs, axis, PiecewiseLinear::constant(M), "moment");
  const std::vector<double> u(12, 0.0);
  const Eigen::VectorXd R = test::evaluate_dense(moment, c.mesh, u, false).R;  // R = −f
  Vec3 force = Vec3::Zero(), torque = Vec3::Zero();
  for (int n = 0; n < 4; ++n) {
    const Vec3 f = -R.segment<3>(3 * n);
    force += f;
    torque += c.mesh.nodes[n].cross(f);
  }
  // Round-off of forces of order M / |chord| ~ 3.
  EXPECT_LT(force.norm(), 1e-12);
  EXPECT_NEAR(torque.dot(axis), M, 1e-12);
  // A small rigid rotation δφ of the whole about the axis does the work M δφ (to second order in δφ).
  const double dphi = 1e-6;
  const Eigen::Matrix3d rotation = Eigen::AngleAxisd(dphi, axis).toRotationMatrix();
  std::vector<double> du(12);
  for (int n = 0; n < 4; ++n)
    for (int i = 0; i < 3; ++i) du[3 * n + i] = (rotation * c.mesh.nodes[n] - c.mesh.nodes[n])[i];
  double work = 0.0;
  for (int d = 0; d < 12; ++d) work -= R[d] * du[d];
  EXPECT_NEAR(work / dphi, M, 1e-5 * M);
  EXPECT_NEAR(moment.rotation(c.mesh, du), dphi, 1e-12);
}

TEST(ShellEdgeMoment, PairsEachEdgeNodeWithTheNextRowInward) {
  // A 3 × 2 grid of the plane z = 0 (cells 1 × 1, one diagonal), edge x = 3: nodes 3, 7, 11.
  fe::Mesh mesh;
  for (int j = 0; j <= 2; ++j)
    for (int i = 0; i <= 3; ++i) mesh.nodes.emplace_back(double(i), double(j), 0.0);
  std::vector<fe::Tri3> tris;
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 3; ++i) {
      const int a = i + 4 * j;
      tris.push_back({a, a + 1, a + 5});
      tris.push_back({a, a + 5, a + 4});
    }
  const auto pairs = fe::shell_edge_moment_pairs(mesh, tris, {{3, 7}, {7, 11}}, "edge");
  ASSERT_EQ(pairs.size(), 3u);
  double total = 0.0;
  for (const auto& p : pairs) {
    EXPECT_EQ(p.inner, p.edge - 1);  // the node at x = 2 on the same row
    total += p.share;
    EXPECT_DOUBLE_EQ(p.share, p.edge == 7 ? 0.5 : 0.25);  // trapezoidal shares of a uniform moment per length
  }
  EXPECT_DOUBLE_EQ(total, 1.0);
  EXPECT_THROW(fe::shell_edge_moment_pairs(mesh, tris, {{3, 11}}, "edge"), InputError);
}
