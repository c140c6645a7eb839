// Compact linearization of the isotropic laws (compact_linearization.hpp) against the full tangent of
// evaluate() and against central differences of P; the batched float kernel against the double one.
#include <gtest/gtest.h>

#include <random>

#include "fd_check.hpp"
#include "softhom/materials/compact_linearization.hpp"
#include "softhom/materials/laws.hpp"

namespace softhom {
namespace {

// Deformations: moderate random F (|F − I| ≲ 0.3, with rotation) and a near-incompressible stretch.
std::vector<Mat3> test_deformations() {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.3, 0.3);
  std::vector<Mat3> Fs;
  for (int n = 0; n < 6; ++n) {
    Mat3 H;
    for (int c = 0; c < 9; ++c) H(c / 3, c % 3) = u(rng);
    Fs.push_back(test::random_rotation(rng) * (Mat3::Identity() + H));
  }
  Mat3 s = Mat3::Identity();
  s(0, 0) = 1.5;
  s(1, 1) = s(2, 2) = 1.0 / std::sqrt(1.5) * 1.0001;
  Fs.push_back(s);
  return Fs;
}

struct NamedLaw {
  std::string name;
  ElasticLawPtr law;
};
std::vector<NamedLaw> compact_laws() {
  NeoHookeanParams lame{0.4, 50.0, NeoHookeanForm::lame_log};
  return {{"neo-Hookean", make_neo_hookean({0.4, 50.0})},
          {"neo-Hookean lame-log", make_neo_hookean(lame)},
          {"Yeoh", make_yeoh({0.2, -0.01, 0.003, 100.0})},
          {"Gent (ecoflex-like, K/G = 1.2e5)", make_gent_hgo({0.017, 14.0, 2040.0, {}, FiberInvariant::full, true})}};
}

// The compact form is the same tensor as the law's tangent written differently: agreement to round-off
// of the larger entries (K/G = 1.2e5 for the Gent case: cancellations of O(ε K) against G, ≈ 1e-11
// relative to ‖A‖). Against central differences the FD error bound of fd_check.hpp (1e-6).
TEST(CompactLinearization, EqualsTheFullTangentAndFiniteDifferences) {
  for (const auto& nl : compact_laws()) {
    const auto m = make_material(nl.law);
    ASSERT_TRUE(m->has_compact_linearization()) << nl.name;
    for (const Mat3& F : test_deformations()) {
      Mat3 P;
      Mat9 A;
      ASSERT_EQ(m->evaluate(F, nullptr, nullptr, 0.0, P, &A), MaterialStatus::ok) << nl.name;
      CompactLinearization L;
      ASSERT_TRUE(m->compact_linearization(F, L));
      const Mat9 Ac = compact_tangent_matrix(F, L);
      EXPECT_TRUE(test::matrices_close(Ac, A, 1e-11, nl.name + " compact vs full, " + test::matrix_string(F)));
      bool ok = true;
      const Mat9 Afd = test::fd_tangent(*m, F, nullptr, 0.0, ok);
      ASSERT_TRUE(ok);
      EXPECT_TRUE(test::matrices_close(Ac, Afd, 1e-6, nl.name + " compact vs FD, " + test::matrix_string(F)));
      // major symmetry (CG needs a symmetric operator): exact up to round-off
      EXPECT_LE((Ac - Ac.transpose()).norm(), 1e-13 * Ac.norm()) << nl.name;
    }
  }
}

// q ∂cof/∂F added through add_pressure_stiffness equals the finite difference of q cof F.
TEST(CompactLinearization, PressureStiffnessIsTheDerivativeOfQCof) {
  const double q = 3.7;
  for (const Mat3& F : test_deformations()) {
    CompactLinearization L;
    add_pressure_stiffness(L, q, F.determinant());
    const auto stress = [&](const Mat3& G, Mat3& P) {
      P = q * G.determinant() * G.inverse().transpose();
      return true;
    };
    bool ok = true;
    const Mat9 Afd = test::fd_tangent(stress, F, test::fd_step(F), ok);
    EXPECT_TRUE(test::matrices_close(compact_tangent_matrix(F, L), Afd, 1e-7, "q dcof/dF, " + test::matrix_string(F)));
  }
}

// Anisotropic, viscoelastic and non-invariant laws keep the full tangent.
TEST(CompactLinearization, OtherLawsDeclineIt) {
  GentHGOParams hgo{0.017, 14.0, 2040.0, {{Vec3(1.0, 0.0, 0.0), 0.5, 2.0, 0.0}}, FiberInvariant::full, true};
  EXPECT_FALSE(make_material(make_gent_hgo(hgo))->has_compact_linearization());
  CompactLinearization L;
  EXPECT_FALSE(make_material(make_gent_hgo(hgo))->compact_linearization(Mat3::Identity(), L));
  EXPECT_FALSE(make_material(make_ogden({{0.1}, {2.0}, 50.0}))->has_compact_linearization());
  EXPECT_FALSE(make_material(make_neo_hookean({0.4, 50.0}), PronySeries{0.5, {{0.5, 2.0}}})->has_compact_linearization());
}

// The batched float kernel = the double product with F and the scalars rounded to float: the only
// difference is the double arithmetic order (≤ 1e-14 relative to ‖δP‖); against the unrounded record
// the float rounding (≈ 6e-8 relative, amplified by the K-dominated terms: bound 1e-6).
TEST(CompactLinearization, BatchKernelEqualsThePointProduct) {
  const auto m = make_material(compact_laws().back().law);
  const std::vector<Mat3> Fs = test_deformations();
  alignas(64) float rec[kCompactValues * 8] = {};
  alignas(64) double dF[9 * 8], dP[9 * 8];
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Mat3 Fr[8], dFm[8];
  CompactLinearization Lr[8];
  for (int l = 0; l < 8; ++l) {
    const Mat3 F = Fs[std::size_t(l) % Fs.size()];
    Mat3 P;
    ASSERT_EQ(m->evaluate(F, nullptr, nullptr, 0.0, P, nullptr), MaterialStatus::ok);
    CompactLinearization L;
    m->compact_linearization(F, L);
    add_pressure_stiffness(L, 0.01 * l, F.determinant());
    store_compact_record(rec, l, F, L);
    for (int c = 0; c < 9; ++c) {
      Fr[l](c / 3, c % 3) = double(rec[8 * c + l]);
      dFm[l](c / 3, c % 3) = dF[8 * c + l] = u(rng);
    }
    const double s[5] = {rec[72 + l], rec[80 + l], rec[88 + l], rec[96 + l], rec[104 + l]};
    Lr[l] = {s[0], s[1], s[2], s[3], s[4]};
    (void)L;
  }
  compact_product_batch(rec, dF, dP);
  for (int l = 0; l < 8; ++l) {
    const Mat3 ref = compact_product(Fr[l], Lr[l], dFm[l]);
    Mat3 got;
    for (int c = 0; c < 9; ++c) got(c / 3, c % 3) = dP[8 * c + l];
    EXPECT_LE((got - ref).norm(), 1e-12 * ref.norm()) << "lane " << l;
  }
}

}  // namespace
}  // namespace softhom
