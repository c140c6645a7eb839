// The fiber-composite law (materials/src/fiber_composite.cpp): Gent + HGO plus a fiber–matrix shear
// term (GL/2)(I5 − I4²), a transverse shear term GT (τ − 1) and a stretch-linear fiber (Ef/2)(√I4 − 1)²
// per family.
//
// Tolerances:
//  - 1e-7 relative (Frobenius norm of the whole 9x9 or 3x3) for analytic against central differences:
//    the differences are accurate to ~1e-9 (fd_check.hpp), so a wrong term of relative size 1e-7 fails.
//    K = 0.05 (comparable to G and GL) so that the shear terms carry the norm, not the volumetric part.
//  - 1e-13 relative (1e-12 where a fiber stress is added) for equalities that hold in exact arithmetic with O(10) roundings (the reduction to
//    Gent + HGO, the closed forms in shear, the stress in a stretch along the fibers).
#include <gtest/gtest.h>

#include <random>

#include "fd_check.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/materials/laws.hpp"
#include "softhom/materials/scene_keys.hpp"

using namespace softhom;
using namespace softhom::test;

namespace {

constexpr double kCompositeFdTol = 1e-7;     // see the file comment
constexpr double kCompositeExactTol = 1e-13;  // see the file comment

// The Ecoflex cells' scale: G of the matrix, k1 of the calibrated HGO family.
GentHGOParams composite_base(double K, std::vector<Vec3> dirs, bool tension_only = false) {
  GentHGOParams p{0.017, 14.0, K, {}, FiberInvariant::full, tension_only};
  for (const auto& d : dirs) p.fibers.push_back({d, 0.24, 2.0});
  return p;
}

Mat3 composite_stress(const ElasticLawPtr& law, const Mat3& F, Mat9* A = nullptr) {
  Mat3 P;
  EXPECT_EQ(HyperelasticMaterial(law).evaluate(F, nullptr, nullptr, 0.0, P, A), MaterialStatus::ok);
  return P;
}

}  // namespace

TEST(FiberComposite, TangentAndStressMatchFiniteDifferences) {
  std::mt19937 rng(71);
  const Vec3 d1 = Vec3(1.0, 2.0, 0.5).normalized(), d2 = Vec3(-1.0, 0.3, 2.0).normalized();
  for (const double K : {0.05, 2000.0}) {
    for (const auto& dirs : {std::vector<Vec3>{d1}, std::vector<Vec3>{d1, d2}}) {
      const ElasticLawPtr law = make_fiber_composite({composite_base(K, dirs), 0.011, 0.007, 0.9});
      const HyperelasticMaterial m(law);
      for (int n = 0; n < 6; ++n) {
        const Mat3 F = random_F(rng, random_J(rng), 0.35);
        SCOPED_TRACE(matrix_string(F));
        Mat9 A;
        const Mat3 P = composite_stress(law, F, &A);
        bool ok = true;
        const Mat9 A_fd = fd_tangent(m, F, nullptr, 0.0, ok);
        ASSERT_TRUE(ok);
        EXPECT_TRUE(matrices_close(A, A_fd, kCompositeFdTol, "dP/dF vs finite differences"));
        EXPECT_TRUE(matrices_close(P, fd_energy_gradient(*law, F), kCompositeFdTol, "P vs dW/dF", nullptr, 0.017));
        const Mat3 tau = P * F.transpose();  // balance of angular momentum
        EXPECT_LE((tau - tau.transpose()).norm(), kCompositeExactTol * 1e2 * tau.norm());
      }
    }
  }
}

TEST(FiberComposite, ZeroShearModuliIsGentHGO) {
  std::mt19937 rng(72);
  const Vec3 d = Vec3(0.3, 1.0, -0.2).normalized();
  for (const bool tension_only : {true, false}) {
    const GentHGOParams base = composite_base(2000.0, {d}, tension_only);
    const ElasticLawPtr composite = make_fiber_composite({base, 0.0, 0.0}), gent = make_gent_hgo(base);
    for (int n = 0; n < 4; ++n) {
      const Mat3 F = random_F(rng, random_J(rng), 0.3);
      Mat9 A1, A2;
      const Mat3 P1 = composite_stress(composite, F, &A1), P2 = composite_stress(gent, F, &A2);
      EXPECT_TRUE(matrices_close(P1, P2, kCompositeExactTol, "P", nullptr, 0.017));
      EXPECT_TRUE(matrices_close(A1, A2, kCompositeExactTol, "A"));
      const Mat3 C = F.transpose() * F;
      EXPECT_NEAR(composite->energy(C, F.determinant()), gent->energy(C, F.determinant()), 1e-12);
    }
  }
}

TEST(FiberComposite, SimpleShearAlongAndAcrossTheFibersGivesTheAddedModuli) {
  // Fibers along e1, isochoric shears (J = 1, so K does not enter):
  //  along, F = I + γ e1⊗e2: Ī1 − 3 = γ², I4 = 1 (HGO idle), I5 − I4² = γ², τ = 1:
  //    P12 = dW/dγ = G γ / (1 − γ²/Jm) + GL γ;
  //  across, F = I + γ e2⊗e3: I4 = I5 = 1, τ = 1 + γ²/2:  P23 = G γ / (1 − γ²/Jm) + GT γ.
  const double G = 0.017, Jm = 14.0, GL = 0.011, GT = 0.007;
  const ElasticLawPtr law = make_fiber_composite({composite_base(2000.0, {Vec3::UnitX()}), GL, GT});
  for (const double g : {0.01, 0.3, 1.0}) {
    const double gent = G * g / (1.0 - g * g / Jm);
    Mat3 F = Mat3::Identity();
    F(0, 1) = g;
    EXPECT_NEAR(composite_stress(law, F)(0, 1), gent + GL * g, kCompositeExactTol * 1e2 * (gent + GL * g)) << "along, γ = " << g;
    F = Mat3::Identity();
    F(1, 2) = g;
    EXPECT_NEAR(composite_stress(law, F)(1, 2), gent + GT * g, kCompositeExactTol * 1e2 * (gent + GT * g)) << "across, γ = " << g;
  }
}

TEST(FiberComposite, StretchAlongTheFibersAddsOnlyTheLinearFiber) {
  // A stretch λ along the fibers (e2) with equal lateral stretches leaves a0 principal and the cross
  // plane dilated: the shear terms sit at their minimum 0 (no stress), and the fiber term
  // (Ef/2)(λ − 1)² adds P22 = Ef (λ − 1) to Gent + HGO's stress, in tension and in compression.
  const GentHGOParams base = composite_base(2000.0, {Vec3::UnitY()});
  const double Ef = 0.9;
  const ElasticLawPtr composite = make_fiber_composite({base, 0.05, 0.05, Ef}), gent = make_gent_hgo(base);
  for (const double l : {0.9, 1.1, 1.4}) {
    const Mat3 F = Vec3(0.97 / std::sqrt(l), l, 0.97 / std::sqrt(l)).asDiagonal();
    Mat3 expected = composite_stress(gent, F);
    expected(1, 1) += Ef * (l - 1.0);
    EXPECT_TRUE(matrices_close(composite_stress(composite, F), expected, kCompositeExactTol * 10, "P", nullptr, 0.017))
        << "λ = " << l;
  }
}

TEST(FiberComposite, SceneTableReadsTheLawAndRefusesBadModuliNamingTheKey) {
  const auto table = [](const std::string& extra) {
    return toml::parse("law = \"fiber-composite\"\nG = 0.017\nJm = 14\nK = 2000\nk1 = 0.2\nk2 = 1\n"
                       "fiber_invariant = \"full\"\n" + extra);
  };
  const MaterialSpec s = parse_material(table("GL = 0.01\nGT = 0.02\n[[fibers]]\nangle_deg = 45\n"), "material");
  EXPECT_EQ(s.law, LawKind::fiber_composite);
  EXPECT_DOUBLE_EQ(s.fiber_shear.GL, 0.01);
  EXPECT_DOUBLE_EQ(s.fiber_shear.GT, 0.02);
  ASSERT_EQ(s.gent.fibers.size(), 1u);
  const auto refusal = [&](const std::string& extra) {
    try {
      parse_material(table(extra), "material");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(refusal("GL = -0.01\n[[fibers]]\nangle_deg = 45\n").find("material.GL"), std::string::npos);
  EXPECT_NE(refusal("GT = nan\n[[fibers]]\nangle_deg = 45\n").find("material.GT"), std::string::npos);
  EXPECT_NE(refusal("Ef = -1\n[[fibers]]\nangle_deg = 45\n").find("material.Ef"), std::string::npos);
  EXPECT_NE(refusal("GL = 0.01\n").find("material.fibers"), std::string::npos);
  // GL belongs to this law only: a Gent table refuses it naming the key.
  try {
    parse_material(toml::parse("law = \"gent\"\nG = 0.017\nJm = 14\nK = 2000\nGL = 0.01\n"), "material");
    ADD_FAILURE() << "GL accepted by law = \"gent\"";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("material.GL"), std::string::npos) << e.what();
  }
}
