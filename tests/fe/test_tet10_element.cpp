// Element-level checks of the tet10 kernels: consistent tangent against central differences of the
// element residual (plain, F-bar and the condensed three-field iteration), zero force under rigid
// motion, the 6-node-triangle pressure load stiffness and closed-surface identities, and the
// hex → tet10 splitting used by the structured tet meshes of the tests.
#include <gtest/gtest.h>

#include <random>

#include "fe/local_law.hpp"
#include "softhom/fe/mesh.hpp"
#include "softhom/fe/model.hpp"
#include "softhom/fe/tet10_element.hpp"

using namespace softhom;
using namespace softhom::fe;

namespace {

/// A distorted tetrahedron with curved edges (mid-edge nodes moved off the straight midpoints).
Tet10Coords curved_tet() {
  Tet10Coords X;
  X.row(0) << 0, 0, 0;
  X.row(1) << 1.1, 0.1, 0;
  X.row(2) << 0.2, 0.9, 0.05;
  X.row(3) << 0.1, 0.2, 1.0;
  for (int e = 0; e < 6; ++e) X.row(4 + e) = 0.5 * (X.row(kTet10Edges[e][0]) + X.row(kTet10Edges[e][1]));
  X.row(4) += Eigen::RowVector3d(0.0, -0.05, 0.02);
  X.row(8) += Eigen::RowVector3d(0.04, 0.03, 0.0);
  X.row(6) += Eigen::RowVector3d(-0.03, 0.0, 0.03);
  return X;
}

MaterialPtr anisotropic_gent_of_bulk(double K = 0.34) {
  // K/G = 20 by default: tangent entries of similar size, a sharper finite-difference check.
  return std::make_shared<test_support::LocalGentHGO>(0.017, 14.0, K, std::vector<Vec3>{Vec3(1, 1, 0.3)}, 0.8, 18.0);
}

Tet10Coords displacement_from(const Tet10Coords& X, const Mat3& F, double noise, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> d(-noise, noise);
  Tet10Coords u;
  for (int a = 0; a < 10; ++a) {
    const Vec3 x = F * X.row(a).transpose();
    for (int i = 0; i < 3; ++i) u(a, i) = x[i] - X(a, i) + d(rng);
  }
  return u;
}

/// Max |K − K_fd| / max |K| at displacement u. Mixed (θ, p held fixed as within one iteration): the
/// returned tangent is K_rest + V p H + V U''(θ) d dᵀ, the u-row derivative of the three-field
/// residual r_u = r_rest + V p d (= r − shift_u d) plus the condensation term, so compare
/// K − V U''(θ) d dᵀ with the differences of r_u.
double tangent_error(const Tet10Geometry& g, const Tet10Coords& u, const Material& m, Formulation f,
                     const Tet10MixedVolume* mixed = nullptr) {
  Vec30 r;
  Mat30 K;
  Tet10MixedVolume mv;
  if (mixed) mv = *mixed;
  EXPECT_EQ(tet10_internal_force(g, u, m, nullptr, nullptr, 0.0, f, r, &K, nullptr, mixed ? &mv : nullptr),
            MaterialStatus::ok);
  if (mixed) K -= g.volume * volumetric_d2U(mv.bulk, mv.theta) * mv.d * mv.d.transpose();
  auto residual = [&](const Tet10Coords& v) {
    Vec30 rv;
    Tet10MixedVolume mc = mv;
    tet10_internal_force(g, v, m, nullptr, nullptr, 0.0, f, rv, nullptr, nullptr, mixed ? &mc : nullptr);
    return mixed ? Vec30(rv - mc.shift_u * mc.d) : rv;
  };
  Mat30 Kfd;
  const double h = 1e-6;
  for (int c = 0; c < 30; ++c) {
    Tet10Coords up = u, um = u;
    up(c / 3, c % 3) += h;
    um(c / 3, c % 3) -= h;
    Kfd.col(c) = (residual(up) - residual(um)) / (2 * h);
  }
  return (K - Kfd).cwiseAbs().maxCoeff() / K.cwiseAbs().maxCoeff();
}

}  // namespace

TEST(Tet10Element, GeometryOfCurvedElementIsValid) {
  const Tet10Geometry g = tet10_geometry(curved_tet());
  ASSERT_TRUE(g.valid);
  // Straight-sided element: the volume is exact (det J constant) and equals |det|/6.
  Tet10Coords X = curved_tet();
  for (int e = 0; e < 6; ++e) X.row(4 + e) = 0.5 * (X.row(kTet10Edges[e][0]) + X.row(kTet10Edges[e][1]));
  Mat3 E;
  for (int k = 0; k < 3; ++k) E.col(k) = (X.row(k + 1) - X.row(0)).transpose();
  EXPECT_NEAR(tet10_geometry(X).volume, E.determinant() / 6.0, 1e-15);
}

TEST(Tet10Element, TangentMatchesFiniteDifferences) {
  const Tet10Geometry g = tet10_geometry(curved_tet());
  const MaterialPtr m = anisotropic_gent_of_bulk();
  Mat3 F;
  F << 1.25, 0.15, 0.05, -0.1, 0.9, 0.12, 0.04, 0.08, 1.1;  // fibers in tension, finite shear
  const Tet10Coords u = displacement_from(curved_tet(), F, 0.03, 7);
  // Central differences with h = 1e-6: truncation ~h² K''' and round-off ~1e-16 |r|/h, both ≲ 1e-8
  // relative here; 1e-6 leaves margin while a wrong term (O(1) relative) fails.
  EXPECT_LT(tangent_error(g, u, *m, Formulation::standard), 1e-6);
  EXPECT_LT(tangent_error(g, u, *m, Formulation::fbar), 1e-6);
  // Three-field iteration with θ, p away from their consistent values (mid-iteration state).
  Tet10MixedVolume mv;
  mv.bulk = 0.34;
  mv.theta = 1.05;
  mv.p = 0.02;
  EXPECT_LT(tangent_error(g, u, *m, Formulation::fbar, &mv), 1e-6);
}

TEST(Tet10Element, NearlyIncompressibleMixedTangentMatchesFiniteDifferences) {
  // K/G = 1e5: the condensed tangent is dominated by V U''(θ) d dᵀ; relative error still ≤ 1e-6.
  const Tet10Geometry g = tet10_geometry(curved_tet());
  const MaterialPtr m = anisotropic_gent_of_bulk(1700.0);
  Mat3 F;
  F << 1.2, 0.1, 0.0, 0.0, 0.95, 0.1, 0.0, 0.05, 0.88;
  const Tet10Coords u = displacement_from(curved_tet(), F, 0.01, 11);
  Tet10MixedVolume mv;
  mv.bulk = 1700.0;
  mv.theta = 1.0;
  mv.p = 0.0;
  EXPECT_LT(tangent_error(g, u, *m, Formulation::fbar, &mv), 1e-6);
}

TEST(Tet10Element, RigidRotationGivesZeroForce) {
  const Tet10Coords X = curved_tet();
  const Tet10Geometry g = tet10_geometry(X);
  const MaterialPtr m = anisotropic_gent_of_bulk();
  const Mat3 Q = Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()).toRotationMatrix();
  const Tet10Coords u = displacement_from(X, Q, 0.0, 1);
  Vec30 r;
  ASSERT_EQ(tet10_internal_force(g, u, *m, nullptr, nullptr, 0.0, Formulation::fbar, r, nullptr), MaterialStatus::ok);
  // Stress-free: round-off of P(Q) ~ 1e-16 G.
  EXPECT_LT(r.cwiseAbs().maxCoeff(), 1e-14);
}

TEST(Tri6Pressure, LoadStiffnessMatchesFiniteDifferencesAndSurfaceIsClosed) {
  const Tet10Coords X = curved_tet();
  const Vec3 mask(1, 1, 1);
  Vec3 sum_a = Vec3::Zero();
  double flux_total = 0.0;
  for (int f = 0; f < 4; ++f) {
    Mat63 x;
    for (int k = 0; k < 6; ++k) x.row(k) = X.row(kTet10Faces[f][k]);
    Vec18 a;
    Mat18 da;
    double flux = 0.0;
    tri6_pressure(x, mask, a, &da, flux);
    flux_total += flux;
    for (int k = 0; k < 6; ++k) sum_a += a.segment<3>(3 * k);
    // a(x) is a polynomial of degree 2 in x: central differences are exact up to round-off.
    Mat18 dfd;
    const double h = 1e-5;
    for (int c = 0; c < 18; ++c) {
      Mat63 xp = x, xm = x;
      xp(c / 3, c % 3) += h;
      xm(c / 3, c % 3) -= h;
      Vec18 ap, am;
      double fl;
      tri6_pressure(xp, mask, ap, nullptr, fl);
      tri6_pressure(xm, mask, am, nullptr, fl);
      dfd.col(c) = (ap - am) / (2 * h);
    }
    EXPECT_LT((da - dfd).cwiseAbs().maxCoeff(), 1e-9) << "face " << f;
  }
  // ∮ n da = 0 over the closed (curved) boundary: exact integration of each face.
  EXPECT_LT(sum_a.norm(), 1e-14);
  // ∮ x·n da = 3 V (divergence theorem) with the volume integrated exactly: det J is cubic for curved
  // elements, so compare with a straight-sided element where the 4-point rule is exact.
  Tet10Coords S = X;
  for (int e = 0; e < 6; ++e) S.row(4 + e) = 0.5 * (S.row(kTet10Edges[e][0]) + S.row(kTet10Edges[e][1]));
  double flux_straight = 0.0;
  for (int f = 0; f < 4; ++f) {
    Mat63 x;
    for (int k = 0; k < 6; ++k) x.row(k) = S.row(kTet10Faces[f][k]);
    Vec18 a;
    double flux = 0.0;
    tri6_pressure(x, mask, a, nullptr, flux);
    flux_straight += flux;
  }
  EXPECT_NEAR(flux_straight / 3.0, tet10_geometry(S).volume, 1e-14);
  EXPECT_GT(flux_total, 0.0);  // outward normals
}

TEST(Tet10Mesh, HexSplitIsConformingWithNamedSurfaces) {
  // 2 × 2 × 2 unit box of hexes → 48 tets; boundary: 6 faces × 4 quads × 2 triangles = 48.
  Mesh hm;
  auto id = [](int i, int j, int k) { return i + 3 * (j + 3 * k); };
  for (int k = 0; k <= 2; ++k)
    for (int j = 0; j <= 2; ++j)
      for (int i = 0; i <= 2; ++i) hm.nodes.push_back(0.5 * Vec3(i, j, k));
  for (int k = 0; k < 2; ++k)
    for (int j = 0; j < 2; ++j)
      for (int i = 0; i < 2; ++i)
        hm.hexes.push_back({id(i, j, k), id(i + 1, j, k), id(i + 1, j + 1, k), id(i, j + 1, k), id(i, j, k + 1),
                            id(i + 1, j, k + 1), id(i + 1, j + 1, k + 1), id(i, j + 1, k + 1)});
  name_boundary_faces(hm, [](const Vec3& c, const Vec3&) { return c[0] < 1e-9 ? "xmin" : ""; });
  const Mesh tm = hex_to_tet10(hm);
  EXPECT_EQ(tm.tets.size(), 48u);
  EXPECT_EQ(tm.num_nodes(), 125);  // the 5³ nodes of the quadratic grid
  EXPECT_EQ(boundary_tri_faces(tm).size(), 48u);
  ASSERT_EQ(tm.tri_surface("xmin").size(), 8u);
  EXPECT_EQ(surface_nodes(tm, "xmin").size(), 25u);
  EXPECT_NEAR(min_scaled_jacobian(tm), 1.0, 1e-12);
  // Enclosed volume through the boundary flux (outward orientation): the unit box.
  EXPECT_NEAR(-cavity_volume(tm.nodes, {}, Vec3(1, 1, 1), boundary_tri_faces(tm)), 1.0, 1e-13);
}
