// Verification of the elastic laws (Gent + HGO, neo-Hookean, Yeoh, Ogden): analytic tangents against
// central differences, stresses against the energy, the two tangent routes (fused Piola kernel and
// second_piola + piola_tangent_from_material) against each other, objectivity, symmetry, the reference
// state, small-strain moduli and the failure statuses.
//
// Tolerances:
//  - 1e-6 relative (Frobenius norm over the whole 9x9) for analytic vs finite differences: the central
//    differences themselves are accurate to ~1e-9 (see fd_check.hpp), so a wrong term of relative size
//    > 1e-6 fails while FD noise cannot.
//  - 1e-12 relative for identities that hold in exact arithmetic and are computed with O(10) roundings
//    (route comparison, objectivity, symmetry, moduli at F = I).
//  - With K = 2000 and G = 0.017 the whole-matrix norm is dominated by the volumetric part. P and A are
//    affine in K (W = W_iso + K w(J)), so every FD check is run a second time with a small K (comparable
//    to G): there the isochoric and fiber parts carry the norm and are checked at the same 1e-6.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <cstdlib>
#include <iostream>
#include <map>
#include <random>

#include "fd_check.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/materials/laws.hpp"

using namespace softhom;
using namespace softhom::test;

namespace {

constexpr double kFdTol = 1e-6;     // see the file comment
constexpr double kExactTol = 1e-12;  // see the file comment

// Worst errors per law, printed at the end of the run for the record (BENCHMARKS/report).
std::map<std::string, double>& worst_fd() {
  static std::map<std::string, double> w;
  return w;
}
struct WorstPrinter : ::testing::Environment {
  void TearDown() override {
    for (const auto& [name, e] : worst_fd())
      std::cout << "[worst FD tangent error] " << name << ": " << e << "\n";
  }
};
const auto* const kPrinter = ::testing::AddGlobalTestEnvironment(new WorstPrinter);

GentHGOParams ecoflex(double K = 2000.0) { return {0.017, 14.0, K, {}, FiberInvariant::full, true}; }

GentHGOParams ecoflex_aniso(std::vector<Vec3> dirs, FiberInvariant inv, bool tension_only, double K = 2000.0) {
  GentHGOParams p = ecoflex(K);
  for (const auto& d : dirs) p.fibers.push_back({d, 0.8, 18.0});
  p.invariant = inv;
  p.tension_only = tension_only;
  return p;
}

YeohParams cpasmo_yeoh(double K = 2000.0) { return {0.008, 4e-5, 4e-5, K}; }
OgdenParams cpasmo_ogden(double K = 2000.0) { return {{0.0111, 1.119e-5, 0.0114}, {2.393, 8.123, -2.168}, K}; }

// All checks of one law at one F; returns false (with failures recorded) on any mismatch.
// `h` = 0: the default FD step; near the Gent limit the caller passes a smaller one and asks for
// Richardson extrapolation.
void check_law_at(const ElasticLawPtr& law, const Mat3& F, const std::string& name, double h = 0.0,
                  bool richardson = false) {
  SCOPED_TRACE(name + ", " + matrix_string(F));
  const HyperelasticMaterial m(law);
  Mat3 P;
  Mat9 A;
  ASSERT_EQ(m.evaluate(F, nullptr, nullptr, 0.0, P, &A), MaterialStatus::ok);

  // Stress-only call gives the same stress.
  Mat3 P_only;
  ASSERT_EQ(m.evaluate(F, nullptr, nullptr, 0.0, P_only, nullptr), MaterialStatus::ok);
  EXPECT_TRUE(matrices_close(P, P_only, kExactTol, "stress-only vs stress+tangent"));

  // Route 2: second_piola + piola_tangent_from_material (the generic conversion).
  const Mat3 C = F.transpose() * F;
  Mat3 S;
  Mat9 CC, A2;
  ASSERT_EQ(law->second_piola(F, C, F.determinant(), S, &CC), MaterialStatus::ok);
  piola_tangent_from_material(F, S, CC, A2);
  EXPECT_TRUE(matrices_close(P, Mat3(F * S), kExactTol, "P vs F S"));
  EXPECT_TRUE(matrices_close(A, A2, 1e-11, "fused Piola tangent vs push-forward of CC"));
  // CC has the minor symmetries (CC_IJKL = CC_JIKL = CC_IJLK), as a derivative of a symmetric S by C.
  Mat9 CCt = CC;
  for (int I = 0; I < 3; ++I)
    for (int J2 = 0; J2 < 3; ++J2)
      for (int K = 0; K < 3; ++K)
        for (int L = 0; L < 3; ++L) CCt(voigt9(I, J2), voigt9(K, L)) = CC(voigt9(J2, I), voigt9(L, K));
  EXPECT_TRUE(matrices_close(CC, CCt, kExactTol, "minor symmetry of CC"));

  // Analytic tangent vs central differences of P.
  bool ok = true;
  const Mat9 A_fd = fd_tangent(m, F, nullptr, 0.0, ok, h, richardson);
  ASSERT_TRUE(ok) << "a perturbed evaluation failed";
  EXPECT_TRUE(matrices_close(A, A_fd, kFdTol, "dP/dF vs finite differences", &worst_fd()[name]));
  if (std::getenv("SOFTHOM_TEST_VERBOSE"))  // per-point FD errors, for diagnosing tolerances
    std::cout << name << " FD error " << relative_error(A, A_fd) << " h " << h << " " << matrix_string(F) << "\n";

  // Stress vs central differences of the energy. Floor G: at F ≈ I the stress vanishes and the FD
  // gradient keeps its rounding noise ε W / h ≈ 1e-11 G.
  const Mat3 P_W = fd_energy_gradient(*law, F, h, richardson);
  EXPECT_TRUE(matrices_close(P, P_W, kFdTol, "P vs dW/dF", nullptr, law->initial_shear_modulus()));

  // Balance of angular momentum: P Fᵀ = J σ is symmetric.
  const Mat3 tau = P * F.transpose();
  EXPECT_LE((tau - tau.transpose()).norm(), kExactTol * tau.norm()) << "P Fᵀ not symmetric";
}

double isochoric_uniaxial_stretch_for(double I1bar_minus_3) {
  // λ² + 2/λ − 3 = target, λ > 1 (monotone there): bisection.
  double lo = 1.0, hi = 100.0;
  for (int it = 0; it < 200; ++it) {
    const double mid = 0.5 * (lo + hi);
    (mid * mid + 2.0 / mid - 3.0 < I1bar_minus_3 ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

// F with Ī1 − 3 = target, det F = J, random orientation.
Mat3 F_with_I1bar(std::mt19937& rng, double target, double J) {
  const double l = isochoric_uniaxial_stretch_for(target);
  const Vec3 lambda = Vec3(l, 1.0 / std::sqrt(l), 1.0 / std::sqrt(l)) * std::cbrt(J);
  return random_rotation(rng) * lambda.asDiagonal() * random_rotation(rng);
}

Vec3 random_direction(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  return Vec3(n(rng), n(rng), n(rng)).normalized();
}

}  // namespace

// ---------------------------------------------------------------------------------------------------
// Finite-difference checks

TEST(GentHGO, IsotropicTangentAndStressMatchFiniteDifferences) {
  std::mt19937 rng(11);
  for (const double K : {2000.0, 0.1}) {  // 0.1 ≈ 6 G: the isochoric part carries the norm
    const auto law = make_gent_hgo(ecoflex(K));
    for (int n = 0; n < 25; ++n) check_law_at(law, random_F(rng, random_J(rng), 0.5), "Gent");
  }
}

TEST(GentHGO, NearLockingTangentMatchesFiniteDifferences) {
  std::mt19937 rng(12);
  for (const double K : {2000.0, 0.1})
    for (const double margin : {1e-1, 1e-2, 1e-3}) {
      // verify-iso (Jm = 0.067) and ecoflex (Jm = 14): the gap Jm − (Ī1 − 3) = margin·Jm.
      for (const double Jm : {0.067, 14.0}) {
        GentHGOParams p = ecoflex(K);
        p.G = Jm < 1.0 ? 0.026 : 0.017;
        p.Jm = Jm;
        const auto law = make_gent_hgo(p);
        // FD step: the truncation error of central differences is ≈ (h |∂Ī1/∂F| / gap)² relative
        // (|∂Ī1/∂F| ≈ 2 |F|), O(1e-3) with the default step at the smallest gap. With h = 1e-2 gap / (2|F|)
        // and Richardson extrapolation it is ≈ (1e-2)⁴ = 1e-8; the rounding error grows to
        // ≈ c ε Ī1 / (1e-2 gap) with c ≈ 50 roundings in Ī1: ≈ 2e-8 at the smallest gap 6.7e-5.
        for (int n = 0; n < 3; ++n) {
          const Mat3 F = F_with_I1bar(rng, Jm * (1.0 - margin), random_J(rng));
          const double h = std::min(fd_step(F), 1e-2 * margin * Jm / (2.0 * F.norm()));
          check_law_at(law, F, "Gent near locking", h, true);
        }
      }
    }
}

TEST(GentHGO, FiberFamiliesTangentMatchesFiniteDifferences) {
  std::mt19937 rng(13);
  int in_tension = 0, in_compression = 0;
  for (const double K : {2000.0, 0.1})
    for (const auto inv : {FiberInvariant::full, FiberInvariant::isochoric})
      for (const bool tension_only : {true, false})
        for (const int families : {0, 1, 2, 3}) {
          const std::string name = std::string("Gent+HGO ") +
                                   (inv == FiberInvariant::full ? "full" : "isochoric") +
                                   (tension_only ? " tension-only" : " tension+compression");
          for (int n = 0; n < 6; ++n) {
            std::vector<Vec3> dirs;
            for (int f = 0; f < families; ++f) dirs.push_back(random_direction(rng));
            // Unnormalised direction: the law normalises it.
            if (!dirs.empty()) dirs.front() *= 3.0;
            const auto law = make_gent_hgo(ecoflex_aniso(dirs, inv, tension_only, K));
            // Spread 0.3: fiber stretches up to ≈ 1.35 keep k2 (I4 − 1)² moderate (exp ≤ e^20).
            const Mat3 F = random_F(rng, random_J(rng), 0.3);
            for (const auto& d : dirs) {
              const double I4 = (F * d.normalized()).squaredNorm();
              const double Is = inv == FiberInvariant::full ? I4 : I4 / std::cbrt(std::pow(F.determinant(), 2));
              (Is > 1.0 ? in_tension : in_compression)++;
            }
            check_law_at(law, F, name);
          }
        }
  // The sample must exercise both sides of the tension-only switch.
  EXPECT_GT(in_tension, 20);
  EXPECT_GT(in_compression, 20);
}

TEST(GentHGO, DispersedFiberTangentMatchesFiniteDifferences) {
  // GOH dispersion replaces M by H = κ I + (1 − 3κ) M in every term, including the cross terms
  // H⊗C⁻¹ of the isochoric invariant and the κ F part of the Piola push-forward: checked at the
  // same 1e-6 as the aligned families, on both sides of the tension-only switch.
  std::mt19937 rng(29);
  for (const double K : {2000.0, 0.1})
    for (const auto inv : {FiberInvariant::full, FiberInvariant::isochoric})
      for (const bool tension_only : {true, false})
        for (const double kappa : {0.05, 0.2, 1.0 / 3.0}) {
          const std::string name = std::string("Gent+HGO dispersed κ=") + std::to_string(kappa) +
                                   (inv == FiberInvariant::full ? " full" : " isochoric") +
                                   (tension_only ? " tension-only" : " tension+compression");
          for (int n = 0; n < 4; ++n) {
            GentHGOParams p = ecoflex_aniso({random_direction(rng), random_direction(rng)}, inv, tension_only, K);
            for (auto& f : p.fibers) f.kappa = kappa;
            check_law_at(make_gent_hgo(p), random_F(rng, random_J(rng), 0.3), name);
          }
        }
}

TEST(GentHGO, DispersionClosedFormsIsotropicLimitAndUniaxial) {
  // κ = 1/3: H = I/3, the family is an isotropic function of C — the stress cannot depend on a0.
  std::mt19937 rng(31);
  for (int n = 0; n < 5; ++n) {
    const Mat3 F = random_F(rng, random_J(rng), 0.3);
    Mat3 P1, P2;
    GentHGOParams p1 = ecoflex_aniso({random_direction(rng)}, FiberInvariant::full, false);
    GentHGOParams p2 = ecoflex_aniso({random_direction(rng)}, FiberInvariant::full, false);
    p1.fibers[0].kappa = p2.fibers[0].kappa = 1.0 / 3.0;
    ASSERT_EQ(HyperelasticMaterial(make_gent_hgo(p1)).evaluate(F, nullptr, nullptr, 0, P1, nullptr), MaterialStatus::ok);
    ASSERT_EQ(HyperelasticMaterial(make_gent_hgo(p2)).evaluate(F, nullptr, nullptr, 0, P2, nullptr), MaterialStatus::ok);
    EXPECT_TRUE(matrices_close(P1, P2, 1e-12, "κ = 1/3 independent of a0"));
  }
  // Uniaxial isochoric F = diag(λ, λ^-1/2, λ^-1/2) with a0 = e1: E = κ I1 + (1 − 3κ) λ² − 1 and
  // σ11 − σ22 = μ_eff (λ² − 1/λ) + 2ψ'((1 − 2κ) λ² − κ/λ), ψ' = k1 E exp(k2 E²) (full invariant, J = 1).
  for (const double kappa : {0.1, 0.226}) {
    GentHGOParams p = ecoflex_aniso({Vec3::UnitX()}, FiberInvariant::full, true);
    p.fibers[0].kappa = kappa;
    const auto law = make_gent_hgo(p);
    for (const double l : {1.05, 1.2, 1.5}) {
      const Mat3 F = Vec3(l, 1.0 / std::sqrt(l), 1.0 / std::sqrt(l)).asDiagonal();
      Mat3 P;
      ASSERT_EQ(HyperelasticMaterial(law).evaluate(F, nullptr, nullptr, 0.0, P, nullptr), MaterialStatus::ok);
      const Mat3 sigma = cauchy_from_piola(F, P);
      const double I1 = l * l + 2.0 / l;
      const double E = kappa * I1 + (1.0 - 3.0 * kappa) * l * l - 1.0;
      const double psi1 = 0.8 * E * std::exp(18.0 * E * E);
      const double mu_eff = p.G * p.Jm / (p.Jm - I1 + 3.0);
      const double expected = (l * l - 1.0 / l) * mu_eff + 2.0 * psi1 * ((1.0 - 2.0 * kappa) * l * l - kappa / l);
      EXPECT_NEAR(sigma(0, 0) - sigma(1, 1), expected, 1e-12 * expected) << "κ = " << kappa << ", λ = " << l;
    }
  }
  // Out-of-range κ is refused by the law (the validating front end names the field, test_library).
  GentHGOParams bad = ecoflex_aniso({Vec3::UnitX()}, FiberInvariant::full, true);
  bad.fibers[0].kappa = 0.4;
  EXPECT_THROW(make_gent_hgo(bad), InputError);
}

TEST(NeoHookean, GlassTangentAndStressMatchFiniteDifferences) {
  std::mt19937 rng(14);
  const auto glass = make_neo_hookean(NeoHookeanParams::from_young(10.0, 0.3));
  for (int n = 0; n < 25; ++n) check_law_at(glass, random_F(rng, random_J(rng), 0.5), "neo-Hookean");
  // Nearly incompressible variant (K/μ = 1000) as for the matrix.
  const auto stiff = make_neo_hookean({0.017, 17.0});
  for (int n = 0; n < 10; ++n) check_law_at(stiff, random_F(rng, random_J(rng), 0.5), "neo-Hookean");
}

// The Lamé-log form (NeoHookeanForm::lame_log, FANS's CompressibleNeoHookean): FD tangent and energy
// gradient at finite strain, the closed form S = μ(I − C⁻¹) + λ ln J C⁻¹ written independently here,
// and the same tangent as the isochoric form at F = I (same small-strain moduli, to rounding).
TEST(NeoHookean, LameLogFormMatchesFiniteDifferencesAndItsClosedForm) {
  std::mt19937 rng(41);
  for (const NeoHookeanParams base : {NeoHookeanParams::from_young(10.0, 0.3), NeoHookeanParams{0.017, 17.0}}) {
    NeoHookeanParams p = base;
    p.form = NeoHookeanForm::lame_log;
    const auto law = make_neo_hookean(p);
    for (int n = 0; n < 15; ++n) check_law_at(law, random_F(rng, random_J(rng), 0.5), "neo-Hookean lame-log");
    const double lambda = p.K - 2.0 / 3.0 * p.mu;
    for (int n = 0; n < 5; ++n) {
      const Mat3 F = random_F(rng, random_J(rng), 0.5);
      const Mat3 C = F.transpose() * F, Ci = C.inverse();
      const double J = F.determinant();
      const Mat3 S_ref = p.mu * (Mat3::Identity() - Ci) + lambda * std::log(J) * Ci;
      Mat3 S;
      ASSERT_EQ(law->second_piola(F, C, J, S, nullptr), MaterialStatus::ok);
      EXPECT_TRUE(matrices_close(S, S_ref, kExactTol, "S vs FANS closed form"));
    }
    const HyperelasticMaterial a(law), b(make_neo_hookean(base));
    Mat3 P;
    Mat9 Aa, Ab;
    ASSERT_EQ(a.evaluate(Mat3::Identity(), nullptr, nullptr, 0.0, P, &Aa), MaterialStatus::ok);
    ASSERT_EQ(b.evaluate(Mat3::Identity(), nullptr, nullptr, 0.0, P, &Ab), MaterialStatus::ok);
    EXPECT_TRUE(matrices_close(Aa, Ab, kExactTol, "tangent at F = I, lame-log vs isochoric"));
    EXPECT_DOUBLE_EQ(a.volumetric_modulus(), p.K);
  }
}

TEST(Yeoh, TangentAndStressMatchFiniteDifferences) {
  std::mt19937 rng(15);
  for (const double K : {2000.0, 0.05}) {
    const auto law = make_yeoh(cpasmo_yeoh(K));
    for (int n = 0; n < 25; ++n) check_law_at(law, random_F(rng, random_J(rng), 0.6), "Yeoh");
  }
}

TEST(Ogden, TangentAndStressMatchFiniteDifferences) {
  std::mt19937 rng(16);
  for (const double K : {2000.0, 0.1}) {
    const auto law = make_ogden(cpasmo_ogden(K));
    for (int n = 0; n < 25; ++n) check_law_at(law, random_F(rng, random_J(rng), 0.5), "Ogden");
  }
}

TEST(Ogden, TangentAtCoincidentStretchesMatchesFiniteDifferences) {
  // Exactly coincident principal stretches (double and triple), where the spectral formula has 0/0 and
  // the closed-form limits must be used; and nearly coincident ones, on both sides of the switch.
  std::mt19937 rng(17);
  for (const double K : {2000.0, 0.1}) {
    const auto law = make_ogden(cpasmo_ogden(K));
    const double l = 1.3;
    std::vector<Mat3> Fs = {Mat3::Identity(),
                            Vec3(l, l, 1.0 / (l * l)).asDiagonal(),
                            Vec3(1.0 / (l * l), l, l).asDiagonal(),
                            Vec3(l, 1.0 / std::sqrt(l), 1.0 / std::sqrt(l)).asDiagonal(),
                            1.1 * Mat3::Identity(),
                            0.9 * Mat3::Identity(),
                            Vec3(l, l, l * (1.0 + 1e-9)).asDiagonal(),
                            Vec3(l, l * (1.0 + 1e-7), 1.0).asDiagonal(),
                            Vec3(l, l * (1.0 + 1e-5), 1.0).asDiagonal(),
                            Vec3(l, l * (1.0 + 1e-3), 1.0).asDiagonal()};
    // Rotated versions: the eigenvectors are then not the coordinate axes.
    const std::size_t n0 = Fs.size();
    for (std::size_t i = 0; i < n0; ++i) {
      const Mat3 R = random_rotation(rng);
      Fs.push_back(R * Fs[i] * R.transpose());
      Fs.push_back(random_rotation(rng) * Fs[i]);
    }
    for (const auto& F : Fs) check_law_at(law, F, "Ogden coincident stretches");
  }
}

// ---------------------------------------------------------------------------------------------------
// Properties shared by every law

namespace {
std::vector<std::pair<std::string, ElasticLawPtr>> all_laws() {
  const Vec3 d1 = Vec3(1.0, 2.0, 0.5).normalized(), d2 = Vec3(-1.0, 0.3, 2.0).normalized();
  return {{"Gent", make_gent_hgo(ecoflex())},
          {"Gent+2HGO full", make_gent_hgo(ecoflex_aniso({d1, d2}, FiberInvariant::full, true))},
          {"Gent+2HGO isochoric", make_gent_hgo(ecoflex_aniso({d1, d2}, FiberInvariant::isochoric, false))},
          {"neo-Hookean", make_neo_hookean(NeoHookeanParams::from_young(10.0, 0.3))},
          {"Yeoh", make_yeoh(cpasmo_yeoh())},
          {"Ogden", make_ogden(cpasmo_ogden())},
          {"fiber composite", make_fiber_composite({ecoflex_aniso({d1, d2}, FiberInvariant::full, false), 0.011, 0.007, 0.9})}};
}
}  // namespace

TEST(ElasticLaws, ZeroStressInTheReferenceState) {
  for (const auto& [name, law] : all_laws()) {
    const HyperelasticMaterial m(law);
    Mat3 P;
    Mat9 A;
    ASSERT_EQ(m.evaluate(Mat3::Identity(), nullptr, nullptr, 0.0, P, &A), MaterialStatus::ok) << name;
    // Exact zero up to rounding of O(10) operations on numbers of size K.
    EXPECT_LE(P.norm(), kExactTol * law->initial_bulk_modulus()) << name << "\n" << P;
    EXPECT_NEAR(law->energy(Mat3::Identity(), 1.0), 0.0, 1e-14) << name;
  }
}

TEST(ElasticLaws, Objectivity) {
  // P(QF) = Q P(F) and A(QF)_iJkL = Q_ip Q_kq A(F)_pJqL for rotations Q.
  std::mt19937 rng(21);
  for (const auto& [name, law] : all_laws()) {
    const HyperelasticMaterial m(law);
    for (int n = 0; n < 5; ++n) {
      const Mat3 F = random_F(rng, random_J(rng), 0.3), Q = random_rotation(rng);
      Mat3 P, PQ;
      Mat9 A, AQ;
      ASSERT_EQ(m.evaluate(F, nullptr, nullptr, 0.0, P, &A), MaterialStatus::ok);
      ASSERT_EQ(m.evaluate(Q * F, nullptr, nullptr, 0.0, PQ, &AQ), MaterialStatus::ok);
      EXPECT_TRUE(matrices_close(PQ, Mat3(Q * P), kExactTol, name + ": P(QF) vs Q P(F)"));
      Mat9 QQ = Mat9::Zero();  // Q acting on the first index of a 9-vector
      for (int i = 0; i < 3; ++i)
        for (int J = 0; J < 3; ++J)
          for (int p = 0; p < 3; ++p) QQ(voigt9(i, J), voigt9(p, J)) = Q(i, p);
      EXPECT_TRUE(matrices_close(AQ, Mat9(QQ * A * QQ.transpose()), 1e-11, name + ": A(QF)"));
    }
  }
}

TEST(ElasticLaws, SmallStrainModuliFromTheTangentAtIdentity) {
  // At F = I (S = 0) A = CC = (K − 2G/3) I⊗I + G (δ_ik δ_jl + δ_il δ_jk): the isotropic elasticity
  // tensor with the law's G and K.
  for (const auto& [name, law] : all_laws()) {
    if (!law->fiber_directions().empty()) continue;  // fibers add k1 M⊗M terms, checked below
    const double G = law->initial_shear_modulus(), K = law->initial_bulk_modulus();
    Mat9 iso = Mat9::Zero();
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        for (int k = 0; k < 3; ++k)
          for (int l = 0; l < 3; ++l)
            iso(voigt9(i, j), voigt9(k, l)) = (K - 2.0 * G / 3.0) * (i == j) * (k == l) +
                                              G * ((i == k) * (j == l) + (i == l) * (j == k));
    Mat3 P;
    Mat9 A;
    ASSERT_EQ(HyperelasticMaterial(law).evaluate(Mat3::Identity(), nullptr, nullptr, 0.0, P, &A),
              MaterialStatus::ok);
    EXPECT_TRUE(matrices_close(A, iso, kExactTol, name + ": tangent at F = I"));
  }
  // Expected values of the parameter sets (spec §6).
  EXPECT_DOUBLE_EQ(make_gent_hgo(ecoflex())->initial_shear_modulus(), 0.017);
  EXPECT_DOUBLE_EQ(make_yeoh(cpasmo_yeoh())->initial_shear_modulus(), 0.016);
  EXPECT_NEAR(make_ogden(cpasmo_ogden())->initial_shear_modulus(), 0.0111 + 1.119e-5 + 0.0114, 1e-15);
}

TEST(NeoHookean, FromYoungRecoversYoungsModulusAndPoissonRatio) {
  // Invert the small-strain tangent on symmetric strains (Voigt 6x6) and read E = 1/S_11, ν = −S_12/S_11.
  const auto law = make_neo_hookean(NeoHookeanParams::from_young(10.0, 0.3));
  Mat3 P;
  Mat9 A;
  ASSERT_EQ(HyperelasticMaterial(law).evaluate(Mat3::Identity(), nullptr, nullptr, 0.0, P, &A),
            MaterialStatus::ok);
  const int vi[6] = {0, 1, 2, 1, 0, 0}, vj[6] = {0, 1, 2, 2, 2, 1};
  Eigen::Matrix<double, 6, 6> D;
  for (int a = 0; a < 6; ++a)
    for (int b = 0; b < 6; ++b)  // with engineering shear strains γ_kl = 2 ε_kl, D_ab = A_{ij(a) kl(b)}
      D(a, b) = A(voigt9(vi[a], vj[a]), voigt9(vi[b], vj[b]));
  const Eigen::Matrix<double, 6, 6> Sc = D.inverse();
  EXPECT_NEAR(1.0 / Sc(0, 0), 10.0, 1e-12 * 10.0);
  EXPECT_NEAR(-Sc(0, 1) / Sc(0, 0), 0.3, 1e-12);
  EXPECT_NEAR(law->initial_shear_modulus(), 10.0 / 2.6, 1e-12);
  EXPECT_NEAR(law->initial_bulk_modulus(), 10.0 / 1.2, 1e-12);
}

TEST(GentHGO, FiberTangentAtIdentityWithoutTensionSwitch) {
  // At F = I, I4 = 1: ψ' = 0 and ψ'' = k1, so a family adds exactly 4 k1 (a0⊗a0)⊗(a0⊗a0) to the
  // isotropic tensor (full invariant) — and nothing with the tension-only switch (I4 > 1 is false).
  const Vec3 d = Vec3(1.0, 1.0, 0.0).normalized();
  const auto iso = make_gent_hgo(ecoflex());
  const auto with = make_gent_hgo(ecoflex_aniso({d}, FiberInvariant::full, false));
  const auto tension = make_gent_hgo(ecoflex_aniso({d}, FiberInvariant::full, true));
  Mat3 P;
  Mat9 A0, A1, A2;
  ASSERT_EQ(HyperelasticMaterial(iso).evaluate(Mat3::Identity(), nullptr, nullptr, 0, P, &A0), MaterialStatus::ok);
  ASSERT_EQ(HyperelasticMaterial(with).evaluate(Mat3::Identity(), nullptr, nullptr, 0, P, &A1), MaterialStatus::ok);
  ASSERT_EQ(HyperelasticMaterial(tension).evaluate(Mat3::Identity(), nullptr, nullptr, 0, P, &A2),
            MaterialStatus::ok);
  const Vec9 m = flatten(Mat3(d * d.transpose()));
  EXPECT_TRUE(matrices_close(Mat9(A1 - A0), Mat9(4.0 * 0.8 * m * m.transpose()), 1e-9,
                             "fiber tangent at F = I"));  // difference of numbers of size K: 1e-9
  EXPECT_TRUE(matrices_close(A2, A0, kExactTol, "tension-only fiber at F = I"));
}

TEST(GentHGO, ClosedFormUniaxialWithFiberAlongLoad) {
  // Spec §5 eq. 3.3 in the incompressible limit: σ11 = (λ² − 1/λ) μ_eff + 2 k1 (I4 − 1) e^{k2 (I4−1)²} λ²
  // for an isochoric uniaxial F (λ, λ^(-1/2), λ^(-1/2)) with zero lateral stress. With K = 2000 the
  // lateral stress of the exact isochoric F is not exactly zero; σ11 − σ22 is the K-independent
  // quantity, and equals the closed form exactly (full invariant, J = 1).
  GentHGOParams p = ecoflex_aniso({Vec3::UnitX()}, FiberInvariant::full, true);
  const auto law = make_gent_hgo(p);
  for (const double l : {1.05, 1.2, 1.5}) {
    const Mat3 F = Vec3(l, 1.0 / std::sqrt(l), 1.0 / std::sqrt(l)).asDiagonal();
    Mat3 P;
    ASSERT_EQ(HyperelasticMaterial(law).evaluate(F, nullptr, nullptr, 0.0, P, nullptr), MaterialStatus::ok);
    const Mat3 sigma = cauchy_from_piola(F, P);
    const double I1 = l * l + 2.0 / l, I4 = l * l;
    const double mu_eff = p.G * p.Jm / (p.Jm - I1 + 3.0);
    const double expected = (l * l - 1.0 / l) * mu_eff + 2.0 * 0.8 * (I4 - 1.0) * std::exp(18.0 * (I4 - 1) * (I4 - 1)) * l * l;
    EXPECT_NEAR(sigma(0, 0) - sigma(1, 1), expected, 1e-12 * expected) << "λ = " << l;
  }
}

// ---------------------------------------------------------------------------------------------------
// Failure statuses

TEST(ElasticLaws, InvertedAndNonFiniteDeformations) {
  for (const auto& [name, law] : all_laws()) {
    const HyperelasticMaterial m(law);
    Mat3 P = Mat3::Constant(7.0);
    Mat9 A;
    EXPECT_EQ(m.evaluate(Vec3(-1.0, 1.0, 1.0).asDiagonal(), nullptr, nullptr, 0, P, &A), MaterialStatus::inverted) << name;
    EXPECT_EQ(m.evaluate(Vec3(1.0, 1.0, 0.0).asDiagonal(), nullptr, nullptr, 0, P, &A), MaterialStatus::inverted) << name;
    Mat3 F = Mat3::Identity();
    F(1, 2) = std::nan("");
    EXPECT_EQ(m.evaluate(F, nullptr, nullptr, 0, P, &A), MaterialStatus::not_finite) << name;
    F(1, 2) = INFINITY;
    EXPECT_EQ(m.evaluate(F, nullptr, nullptr, 0, P, &A), MaterialStatus::not_finite) << name;
    EXPECT_EQ(P, Mat3::Constant(7.0)) << name << ": P written on failure";
  }
}

TEST(GentHGO, LockingStatus) {
  std::mt19937 rng(31);
  GentHGOParams p = ecoflex();
  p.G = 0.026;
  p.Jm = 0.067;  // verify-iso: locks near λ ≈ 1.15 in uniaxial tension
  const HyperelasticMaterial m(make_gent_hgo(p));
  Mat3 P;
  Mat9 A;
  for (int n = 0; n < 5; ++n) {
    const double J = random_J(rng);
    EXPECT_EQ(m.evaluate(F_with_I1bar(rng, p.Jm * (1.0 - 1e-6), J), nullptr, nullptr, 0, P, &A), MaterialStatus::ok);
    EXPECT_TRUE(P.allFinite() && A.allFinite());
    EXPECT_EQ(m.evaluate(F_with_I1bar(rng, p.Jm, J), nullptr, nullptr, 0, P, &A), MaterialStatus::locking);
    EXPECT_EQ(m.evaluate(F_with_I1bar(rng, p.Jm * 1.01, J), nullptr, nullptr, 0, P, &A), MaterialStatus::locking);
    EXPECT_EQ(m.evaluate(F_with_I1bar(rng, p.Jm * 10.0, J), nullptr, nullptr, 0, P, nullptr),
              MaterialStatus::locking);
  }
  // The energy is undefined beyond the limit: C = diag(4, 1/4, 1), J = 1 has Ī1 − 3 = 2.25 > Jm.
  EXPECT_TRUE(std::isnan(m.law().energy(Vec3(4.0, 0.25, 1.0).asDiagonal(), 1.0)));
}

TEST(GentHGO, ExponentialOverflowIsNotFinite) {
  const HyperelasticMaterial m(make_gent_hgo(ecoflex_aniso({Vec3::UnitX()}, FiberInvariant::full, true)));
  Mat3 P;
  Mat9 A;
  // λ = 2.5 along the fiber (Ī1 − 3 < Jm): k2 (I4 − 1)² = 18·5.25² ≈ 496, finite.
  EXPECT_EQ(m.evaluate(Vec3(2.5, 0.64, 0.64).asDiagonal(), nullptr, nullptr, 0, P, &A), MaterialStatus::ok);
  EXPECT_TRUE(P.allFinite() && A.allFinite());
  // λ = 3: 18·8² = 1152 > 709: exp overflows.
  EXPECT_EQ(m.evaluate(Vec3(3.0, 0.58, 0.58).asDiagonal(), nullptr, nullptr, 0, P, &A), MaterialStatus::not_finite);
  EXPECT_EQ(m.evaluate(Vec3(3.0, 0.58, 0.58).asDiagonal(), nullptr, nullptr, 0, P, nullptr),
            MaterialStatus::not_finite);
}

// ---------------------------------------------------------------------------------------------------
// rotated(), describe(), factories

TEST(GentHGO, RotatedLawHasRotatedFibersAndRotatedResponse) {
  std::mt19937 rng(41);
  const Vec3 d1 = Vec3(1.0, 0.0, 0.0), d2 = Vec3(0.0, 1.0, 1.0);
  const auto law = make_gent_hgo(ecoflex_aniso({d1, d2}, FiberInvariant::isochoric, true));
  const Mat3 Q = random_rotation(rng);
  const auto rot = law->rotated(Q);
  const auto dirs = rot->fiber_directions();
  ASSERT_EQ(dirs.size(), 2u);
  EXPECT_LE((dirs[0] - Q * d1).norm(), 1e-15);
  EXPECT_LE((dirs[1] - Q * d2.normalized()).norm(), 1e-15);
  // Rotating material and deformation together: P_rot(Q F Qᵀ) = Q P(F) Qᵀ.
  const Mat3 F = random_F(rng, 1.1, 0.3);
  Mat3 P, Pr;
  ASSERT_EQ(HyperelasticMaterial(law).evaluate(F, nullptr, nullptr, 0, P, nullptr), MaterialStatus::ok);
  ASSERT_EQ(HyperelasticMaterial(ElasticLawPtr(law->rotated(Q))).evaluate(Q * F * Q.transpose(), nullptr, nullptr, 0, Pr, nullptr),
            MaterialStatus::ok);
  EXPECT_TRUE(matrices_close(Pr, Mat3(Q * P * Q.transpose()), kExactTol, "rotated law"));
  // The Material-level rotated() too.
  const auto m = make_material(law);
  EXPECT_LE((m->rotated(Q)->fiber_directions()[0] - Q * d1).norm(), 1e-15);
}

TEST(ElasticLaws, DescribeNamesTheLawAndItsParameters) {
  const auto d = make_gent_hgo(ecoflex_aniso({Vec3::UnitX()}, FiberInvariant::full, true))->describe();
  EXPECT_NE(d.find("Gent"), std::string::npos) << d;
  EXPECT_NE(d.find("HGO"), std::string::npos) << d;
  EXPECT_NE(d.find("0.017"), std::string::npos) << d;
  EXPECT_NE(d.find("k2=18"), std::string::npos) << d;
  EXPECT_NE(d.find("full"), std::string::npos) << d;
  EXPECT_NE(make_neo_hookean({1.5, 3.0})->describe().find("neo-Hookean (mu=1.5"), std::string::npos);
  EXPECT_NE(make_yeoh(cpasmo_yeoh())->describe().find("C1=0.008"), std::string::npos);
  EXPECT_NE(make_ogden(cpasmo_ogden())->describe().find("2.393"), std::string::npos);
  EXPECT_STREQ(to_string(MaterialStatus::ok), "ok");
  EXPECT_NE(std::string(to_string(MaterialStatus::locking)).find("locking"), std::string::npos);
}

TEST(ElasticLaws, MakeMaterialWithoutPronyStoresNoHistory) {
  for (const auto& [name, law] : all_laws()) {
    const auto m = make_material(law);
    EXPECT_EQ(m->state_size(), 0) << name;
    EXPECT_NE(dynamic_cast<const HyperelasticMaterial*>(m.get()), nullptr) << name;
    EXPECT_EQ(make_material(law, PronySeries{1.0, {}})->state_size(), 0) << name;
  }
}

// Material::volumetric_modulus() is a contract the FFT solver's mixed (pressure) Newton relies on:
// the law's stress is P_rest(F) + W_V′(J) J F⁻ᵀ with W_V′ = (K/2)(J − 1/J), K = volumetric_modulus(),
// and P_rest independent of K. Checked by differencing two bulk moduli, elastic and QLV (whose
// hydrostatic part stays elastic). Tolerance: 1e-12 of the volumetric stress, rounding of O(10)
// operations on numbers of size K.
TEST(ElasticLaws, VolumetricModulusIsTheAdditiveBulkTerm) {
  const Vec3 d1 = Vec3(1.0, 2.0, 0.5).normalized();
  const double K1 = 2000.0, K2 = 500.0;
  const std::vector<std::pair<std::string, std::function<ElasticLawPtr(double)>>> laws = {
      {"Gent+HGO", [&](double K) { return make_gent_hgo(ecoflex_aniso({d1}, FiberInvariant::full, true, K)); }},
      {"neo-Hookean", [](double K) { return make_neo_hookean({3.8, K}); }},
      {"Yeoh", [](double K) { return make_yeoh(cpasmo_yeoh(K)); }},
      {"Ogden", [](double K) { return make_ogden(cpasmo_ogden(K)); }},
      {"fiber composite",
       [&](double K) { return make_fiber_composite({ecoflex_aniso({d1}, FiberInvariant::full, false, K), 0.011, 0.007, 0.9}); }}};
  const PronySeries prony{0.5, {{0.3, 2.0}, {0.2, 20.0}}};
  std::mt19937 rng(77);
  for (const auto& [name, make] : laws)
    for (bool viscous : {false, true}) {
      const MaterialPtr m1 = viscous ? make_material(make(K1), prony) : make_material(make(K1));
      const MaterialPtr m2 = viscous ? make_material(make(K2), prony) : make_material(make(K2));
      EXPECT_EQ(m1->volumetric_modulus(), K1) << name;
      std::vector<double> s_old(m1->state_size()), s1(m1->state_size()), s2(m1->state_size());
      if (viscous) m1->init_state(s_old.data());
      for (int n = 0; n < 5; ++n) {
        const Mat3 F = random_F(rng, random_J(rng), 0.4);
        Mat3 P1, P2;
        ASSERT_EQ(m1->evaluate(F, s_old.data(), s1.data(), 0.5, P1, nullptr), MaterialStatus::ok) << name;
        ASSERT_EQ(m2->evaluate(F, s_old.data(), s2.data(), 0.5, P2, nullptr), MaterialStatus::ok) << name;
        const double J = F.determinant();
        const Mat3 cof = J * F.inverse().transpose();
        const Mat3 expected = 0.5 * (K1 - K2) * (J - 1.0 / J) * cof;
        EXPECT_LE((P1 - P2 - expected).norm(), 1e-12 * K1 * cof.norm()) << name << (viscous ? " QLV" : "");
      }
    }
}
