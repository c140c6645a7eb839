// Element-level checks of the hex8 kernels: consistent tangent against central differences of the
// element residual (the FEBio FETangentDiagnostic idea), patch tests, pressure load stiffness.
#include <gtest/gtest.h>

#include <random>

#include "softhom/fe/hex8.hpp"
#include "softhom/fe/model.hpp"
#include "fe/local_law.hpp"

using namespace softhom;
using namespace softhom::fe;

namespace {

Mat83 distorted_hex_coords() {
  Mat83 X;
  X << 0, 0, 0, 1, 0, 0, 1.1, 0.9, 0, 0, 1, 0.1, 0, 0.05, 1, 1, 0, 1.2, 1, 1, 1, -0.1, 1, 0.9;
  return X;
}

MaterialPtr anisotropic_gent() {
  // K/G = 20: tangent entries of similar size, a sharper finite-difference check.
  return std::make_shared<test_support::LocalGentHGO>(0.017, 14.0, 0.34, std::vector<Vec3>{Vec3(1, 1, 0.3)}, 0.8, 18.0);
}

/// Max |K − K_fd| / max |K| for the element at displacement u.
double tangent_error(const Hex8Geometry& g, const Mat83& u, const Material& m, Formulation f) {
  Vec24 r;
  Mat24 K;
  EXPECT_EQ(hex8_internal_force(g, u, m, nullptr, nullptr, 0.0, f, r, &K), MaterialStatus::ok);
  Mat24 Kfd;
  const double h = 1e-6;
  for (int c = 0; c < 24; ++c) {
    Mat83 up = u, um = u;
    up(c / 3, c % 3) += h;
    um(c / 3, c % 3) -= h;
    Vec24 rp, rm;
    hex8_internal_force(g, up, m, nullptr, nullptr, 0.0, f, rp, nullptr);
    hex8_internal_force(g, um, m, nullptr, nullptr, 0.0, f, rm, nullptr);
    Kfd.col(c) = (rp - rm) / (2 * h);
  }
  const double err = (K - Kfd).cwiseAbs().maxCoeff() / K.cwiseAbs().maxCoeff();
  if (err > 1e-6) std::cerr << "K =\n" << K.topLeftCorner(6, 6) << "\nK_fd =\n" << Kfd.topLeftCorner(6, 6) << "\n";
  return err;
}

Mat83 displacement_from(const Mat83& X, const Mat3& F, double noise, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> d(-noise, noise);
  Mat83 u;
  for (int a = 0; a < 8; ++a) {
    const Vec3 x = F * X.row(a).transpose();
    for (int i = 0; i < 3; ++i) u(a, i) = x[i] - X(a, i) + d(rng);
  }
  return u;
}

}  // namespace

TEST(Hex8, TangentMatchesFiniteDifferencesUniaxialShearRandom) {
  const Hex8Geometry g = hex8_geometry(distorted_hex_coords());
  ASSERT_TRUE(g.valid);
  const auto m = anisotropic_gent();
  Mat3 uni = Vec3(1.3, 0.9, 0.88).asDiagonal();
  Mat3 shear = Mat3::Identity();
  shear(0, 1) = 0.4;
  for (Formulation f : {Formulation::standard, Formulation::fbar}) {
    // Central differences with h = 1e-6 have truncation O(h²)·|K'''| and round-off O(ε|r|/h) ≈ 1e-10
    // relative: 1e-6 leaves a wide margin yet catches any missing term (those are O(1) relative).
    EXPECT_LT(tangent_error(g, displacement_from(distorted_hex_coords(), uni, 0.0, 1), *m, f), 1e-6);
    EXPECT_LT(tangent_error(g, displacement_from(distorted_hex_coords(), shear, 0.0, 2), *m, f), 1e-6);
    EXPECT_LT(tangent_error(g, displacement_from(distorted_hex_coords(), uni * shear, 0.08, 3), *m, f), 1e-6);
  }
}

TEST(Hex8, FbarTangentIsSymmetricForHyperelasticLaw) {
  // The F-bar residual is the exact gradient of Σ w W(F̄): its Hessian must be symmetric.
  const Hex8Geometry g = hex8_geometry(distorted_hex_coords());
  const auto m = anisotropic_gent();
  Mat3 F = Vec3(1.2, 0.95, 0.9).asDiagonal();
  F(0, 2) = 0.2;
  Vec24 r;
  Mat24 K;
  ASSERT_EQ(hex8_internal_force(g, displacement_from(distorted_hex_coords(), F, 0.05, 7), *m, nullptr, nullptr, 0.0,
                                Formulation::fbar, r, &K),
            MaterialStatus::ok);
  EXPECT_LT((K - K.transpose()).cwiseAbs().maxCoeff() / K.cwiseAbs().maxCoeff(), 1e-12);
}

TEST(Hex8, HomogeneousDeformationReproducesMaterialStress) {
  // Patch test on one distorted element: a homogeneous F gives F̄ = F at every Gauss point and nodal
  // forces equal to ∫ P ∇N dV, whose sum over nodes vanishes.
  const Mat83 X = distorted_hex_coords();
  const Hex8Geometry g = hex8_geometry(X);
  const auto m = anisotropic_gent();
  Mat3 F = Vec3(1.4, 0.85, 0.9).asDiagonal();
  F(1, 0) = 0.1;
  const Mat83 u = displacement_from(X, F, 0.0, 0);
  const Hex8Kinematics k = hex8_kinematics(g, u, Formulation::fbar);
  ASSERT_TRUE(k.ok);
  for (const Mat3& Fq : k.F) EXPECT_LT((Fq - F).norm(), 1e-13);
  Vec24 r;
  Mat3 sigma;
  ASSERT_EQ(hex8_internal_force(g, u, *m, nullptr, nullptr, 0.0, Formulation::fbar, r, nullptr, &sigma),
            MaterialStatus::ok);
  Mat3 P;
  m->evaluate(F, nullptr, nullptr, 0.0, P, nullptr);
  EXPECT_LT((sigma - cauchy_from_piola(F, P)).norm() / P.norm(), 1e-12);
  Vec3 total = Vec3::Zero();
  for (int a = 0; a < 8; ++a) total += r.segment<3>(3 * a);
  EXPECT_LT(total.norm(), 1e-13 * r.norm());
}

TEST(Hex8, InvertedElementIsReported) {
  const Hex8Geometry g = hex8_geometry(distorted_hex_coords());
  Mat83 u = Mat83::Zero();
  u(6, 0) = -3.0;  // drag one corner through the element
  Vec24 r;
  EXPECT_NE(hex8_internal_force(g, u, *anisotropic_gent(), nullptr, nullptr, 0.0, Formulation::fbar, r, nullptr),
            MaterialStatus::ok);
}

TEST(Quad4, PressureStiffnessMatchesFiniteDifferences) {
  Mat43 x;
  x << 0, 0, 0.1, 1.2, 0, 0, 1, 1.1, 0.3, -0.1, 0.9, 0;
  Vec12 a;
  Mat12 da;
  double flux;
  quad4_pressure(x, Vec3::Ones(), a, &da, flux);
  Mat12 fd;
  const double h = 1e-6;
  for (int c = 0; c < 12; ++c) {
    Mat43 xp = x, xm = x;
    xp(c / 3, c % 3) += h;
    xm(c / 3, c % 3) -= h;
    Vec12 ap, am;
    double f2;
    quad4_pressure(xp, Vec3::Ones(), ap, nullptr, f2);
    quad4_pressure(xm, Vec3::Ones(), am, nullptr, f2);
    fd.col(c) = (ap - am) / (2 * h);
  }
  // a is quadratic in x: central differences are exact up to round-off.
  EXPECT_LT((da - fd).cwiseAbs().maxCoeff(), 1e-8);
}

TEST(Quad4, EnclosedVolumeOfADistortedHexIsExact) {
  // The six faces of a hex (inward = cavity seen from outside is the negative): −(1/3)∮ x·n = −V.
  const Mat83 X = distorted_hex_coords();
  const Hex8Geometry g = hex8_geometry(X);
  std::vector<Vec3> nodes;
  for (int a = 0; a < 8; ++a) nodes.push_back(X.row(a).transpose());
  std::vector<Quad> faces;
  for (const auto& f : kHexFaces) faces.push_back({f[0], f[1], f[2], f[3]});
  // Outward normals of the solid: the cavity formula gives minus the solid's volume.
  EXPECT_NEAR(cavity_volume(nodes, faces, Vec3::Ones()), -g.volume, 1e-13);
}
