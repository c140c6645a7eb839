// Verification of the QLV wrapper (spec §4): algorithmic tangent against central differences at random
// non-zero history and Δt = 0 / small / large, exactness of the exponential integrator at fixed F,
// the elastic limits (g∞ = 1, Δt = 0 from rest), state handling.
//
// Tolerances: 1e-6 relative for analytic vs finite differences (FD accuracy ~1e-9, see fd_check.hpp);
// 1e-12 relative for identities that hold in exact arithmetic (a handful of roundings on numbers of
// the size of the stress).
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <random>

#include "fd_check.hpp"
#include "softhom/materials/laws.hpp"

using namespace softhom;
using namespace softhom::test;

namespace {

constexpr double kQlvFdTol = 1e-6;
constexpr double kQlvExactTol = 1e-12;

GentHGOParams aniso(double K) {
  GentHGOParams p;
  p.G = 0.017;
  p.Jm = 14.0;
  p.K = K;
  p.fibers = {{Vec3(1.0, 1.0, 0.0), 0.8, 18.0}, {Vec3(1.0, -1.0, 0.2), 0.8, 18.0}};
  return p;
}

PronySeries three_terms() { return {0.4, {{0.3, 1.0}, {0.2, 10.0}, {0.1, 100.0}}}; }

Mat3 random_sym(std::mt19937& rng, double scale) {
  std::uniform_real_distribution<double> u(-scale, scale);
  Mat3 A;
  for (int i = 0; i < 3; ++i)
    for (int j = i; j < 3; ++j) A(i, j) = A(j, i) = u(rng);
  return A;
}

void store(const Mat3& A, double* s) {
  s[0] = A(0, 0), s[1] = A(1, 1), s[2] = A(2, 2), s[3] = A(1, 2), s[4] = A(0, 2), s[5] = A(0, 1);
}
Mat3 load(const double* s) {
  Mat3 A;
  A << s[0], s[5], s[4], s[5], s[1], s[3], s[4], s[3], s[2];
  return A;
}

// Elastic split at F: S^e, S_H^e, S_D^e.
void elastic_split(const ElasticLaw& law, const Mat3& F, Mat3& Se, Mat3& SH, Mat3& SD) {
  const Mat3 C = F.transpose() * F;
  ASSERT_EQ(law.second_piola(F, C, F.determinant(), Se, nullptr), MaterialStatus::ok);
  SH = ddot(Se, C) / 3.0 * C.inverse();
  SD = Se - SH;
}

}  // namespace

TEST(QLV, StateSizeAndInitialState) {
  const auto law = make_gent_hgo(aniso(2000.0));
  EXPECT_EQ(make_material(law)->state_size(), 0);
  const auto m = make_material(law, three_terms());
  EXPECT_EQ(m->state_size(), 6 * 4);  // S_D^e + one symmetric h_k per term
  std::vector<double> s(m->state_size(), 3.0);
  m->init_state(s.data());
  for (const double v : s) EXPECT_EQ(v, 0.0);
  EXPECT_NE(m->describe().find("QLV"), std::string::npos) << m->describe();
  EXPECT_NE(m->describe().find("tau=10"), std::string::npos) << m->describe();
  EXPECT_NE(m->describe().find("Gent"), std::string::npos) << m->describe();
  EXPECT_EQ(m->initial_shear_modulus(), 0.017);
  EXPECT_EQ(m->initial_bulk_modulus(), 2000.0);
}

TEST(QLV, AlgorithmicTangentMatchesFiniteDifferences) {
  std::mt19937 rng(51);
  double worst = 0.0;
  const std::vector<std::pair<std::string, ElasticLawPtr>> laws = {
      {"Gent+2HGO K=2000", make_gent_hgo(aniso(2000.0))},
      {"Gent+2HGO K=0.1", make_gent_hgo(aniso(0.1))},  // deviatoric part carries the norm
      {"fiber composite K=0.1", make_fiber_composite({aniso(0.1), 0.011, 0.007, 0.9})},
      {"neo-Hookean", make_neo_hookean({0.017, 0.05})},
      {"Ogden", make_ogden({{0.0111, 1.119e-5, 0.0114}, {2.393, 8.123, -2.168}, 0.1})}};
  const std::vector<PronySeries> series = {{0.5, {{0.5, 2.0}}}, three_terms()};
  int count = 0;
  for (const auto& [name, law] : laws)
    for (const auto& prony : series) {
      const auto m = make_material(law, prony);
      const int n = m->state_size();
      for (const double dt : {0.0, 1e-4, 0.5, 30.0, 1e4}) {
        // Random non-zero history of the size of the deviatoric stress at these strains.
        std::vector<double> old(n), fresh(n);
        for (int k = 0; k < n / 6; ++k) store(random_sym(rng, 0.01), old.data() + 6 * k);
        const Mat3 F = random_F(rng, random_J(rng), 0.3);
        SCOPED_TRACE(name + ", dt = " + std::to_string(dt) + ", " + matrix_string(F));
        Mat3 P;
        Mat9 A;
        ASSERT_EQ(m->evaluate(F, old.data(), fresh.data(), dt, P, &A), MaterialStatus::ok);
        bool ok = true;
        const Mat9 A_fd = fd_tangent(*m, F, old.data(), dt, ok);
        ASSERT_TRUE(ok);
        EXPECT_TRUE(matrices_close(A, A_fd, kQlvFdTol, "QLV algorithmic tangent", &worst));
        // Stress-only call: same P.
        Mat3 P2;
        ASSERT_EQ(m->evaluate(F, old.data(), fresh.data(), dt, P2, nullptr), MaterialStatus::ok);
        EXPECT_TRUE(matrices_close(P, P2, kQlvExactTol, "stress-only"));
        // Balance of angular momentum: P Fᵀ symmetric (S is symmetric, history included).
        const Mat3 tau = P * F.transpose();
        EXPECT_LE((tau - tau.transpose()).norm(), kQlvExactTol * tau.norm());
        ++count;
      }
    }
  EXPECT_GE(count, 20);
  std::cout << "[worst FD tangent error] QLV: " << worst << "\n";
}

TEST(QLV, UnitLongTermWeightEqualsTheElasticLaw) {
  // g∞ = 1 and g_k = 0: nothing relaxes; from the initial state P and A equal the elastic law's at any Δt.
  std::mt19937 rng(52);
  const auto law = make_gent_hgo(aniso(2000.0));
  const auto elastic = make_material(law);
  const auto qlv = make_material(law, PronySeries{1.0, {{0.0, 5.0}}});
  ASSERT_EQ(qlv->state_size(), 12);
  for (int n = 0; n < 10; ++n) {
    const Mat3 F = random_F(rng, random_J(rng), 0.3);
    std::vector<double> s0(12), s1(12);
    qlv->init_state(s0.data());
    Mat3 Pe, Pq;
    Mat9 Ae, Aq;
    ASSERT_EQ(elastic->evaluate(F, nullptr, nullptr, 0.0, Pe, &Ae), MaterialStatus::ok);
    ASSERT_EQ(qlv->evaluate(F, s0.data(), s1.data(), 0.3 * n, Pq, &Aq), MaterialStatus::ok);
    EXPECT_TRUE(matrices_close(Pe, Pq, kQlvExactTol, "P with g_inf = 1"));
    EXPECT_TRUE(matrices_close(Ae, Aq, 1e-11, "A with g_inf = 1"));
  }
  // And no terms at all: the plain adapter (no history).
  EXPECT_EQ(make_material(law, PronySeries{1.0, {}})->state_size(), 0);
}

TEST(QLV, InstantaneousResponseFromRestIsElastic) {
  // Δt = 0 from the rest state: φ = 1 and Σ g = 1, so S = S^e (and the tangent is the elastic one).
  std::mt19937 rng(53);
  const auto law = make_gent_hgo(aniso(2000.0));
  const auto qlv = make_material(law, three_terms());
  const auto elastic = make_material(law);
  for (int n = 0; n < 5; ++n) {
    const Mat3 F = random_F(rng, random_J(rng), 0.3);
    std::vector<double> s0(qlv->state_size()), s1(qlv->state_size());
    qlv->init_state(s0.data());
    Mat3 Pe, Pq;
    Mat9 Ae, Aq;
    ASSERT_EQ(elastic->evaluate(F, nullptr, nullptr, 0.0, Pe, &Ae), MaterialStatus::ok);
    ASSERT_EQ(qlv->evaluate(F, s0.data(), s1.data(), 0.0, Pq, &Aq), MaterialStatus::ok);
    EXPECT_TRUE(matrices_close(Pe, Pq, kQlvExactTol, "instantaneous P"));
    EXPECT_TRUE(matrices_close(Ae, Aq, 1e-11, "instantaneous A"));
    EXPECT_TRUE(Pq.allFinite() && Aq.allFinite());
  }
}

TEST(QLV, RelaxationAtFixedDeformationIsTheExactExponential) {
  // Jump to F at t = 0 (Δt = 0), then hold. With S_D^e constant the integrator is exact:
  //   S(t) = S_H^e + [g∞ + Σ g_k exp(−t/τ_k)] S_D^e,
  // for one step of any length and for any subdivision.
  std::mt19937 rng(54);
  const auto law = make_gent_hgo(aniso(2000.0));
  const PronySeries pr = three_terms();
  const auto m = make_material(law, pr);
  const int n = m->state_size();
  const Mat3 F = random_F(rng, 1.05, 0.3);
  Mat3 Se, SH, SD;
  elastic_split(*law, F, Se, SH, SD);
  ASSERT_GT(SD.norm(), 1e-3 * Se.norm()) << "the test needs a deviatoric stress";

  std::vector<double> rest(n), jumped(n);
  m->init_state(rest.data());
  Mat3 P;
  ASSERT_EQ(m->evaluate(F, rest.data(), jumped.data(), 0.0, P, nullptr), MaterialStatus::ok);
  EXPECT_TRUE(matrices_close(Mat3(F * Se), P, kQlvExactTol, "instantaneous"));
  EXPECT_TRUE(matrices_close(SD, load(jumped.data()), kQlvExactTol, "stored S_D^e"));

  const auto expected = [&](double t) {
    double D = pr.g_inf;
    for (const auto& term : pr.terms) D += term.g * std::exp(-t / term.tau);
    return Mat3(F * (SH + D * SD));
  };
  for (const double t : {0.1, 1.0, 10.0, 100.0, 1e4}) {
    // One step of length t.
    std::vector<double> s(n);
    ASSERT_EQ(m->evaluate(F, jumped.data(), s.data(), t, P, nullptr), MaterialStatus::ok);
    EXPECT_TRUE(matrices_close(expected(t), P, kQlvExactTol, "one step, t = " + std::to_string(t)));
    // Ten steps of t/10, in place (state_old == state_new).
    std::vector<double> w = jumped;
    for (int k = 0; k < 10; ++k)
      ASSERT_EQ(m->evaluate(F, w.data(), w.data(), t / 10.0, P, nullptr), MaterialStatus::ok);
    EXPECT_TRUE(matrices_close(expected(t), P, 1e-11, "ten steps, t = " + std::to_string(t)));
  }
  // The long-time limit is the g∞-weighted value, strictly between it and the instantaneous one before.
  std::vector<double> s(n);
  ASSERT_EQ(m->evaluate(F, jumped.data(), s.data(), 1e6, P, nullptr), MaterialStatus::ok);
  EXPECT_TRUE(matrices_close(Mat3(F * (SH + pr.g_inf * SD)), P, kQlvExactTol, "t → ∞"));
}

TEST(QLV, ZeroTimeStepWithHistoryHasNoDivision) {
  // Δt = 0 with non-zero history: h_k ← h_k + g_k ΔS_D (φ = 1), finite.
  std::mt19937 rng(55);
  const auto law = make_neo_hookean({0.017, 2000.0});
  const PronySeries pr{0.5, {{0.3, 1.0}, {0.2, 10.0}}};
  const auto m = make_material(law, pr);
  std::vector<double> old(m->state_size()), fresh(m->state_size());
  for (int k = 0; k < 3; ++k) store(random_sym(rng, 0.01), old.data() + 6 * k);
  const Mat3 F = random_F(rng, 1.1, 0.3);
  Mat3 P;
  Mat9 A;
  ASSERT_EQ(m->evaluate(F, old.data(), fresh.data(), 0.0, P, &A), MaterialStatus::ok);
  EXPECT_TRUE(P.allFinite() && A.allFinite());
  Mat3 Se, SH, SD;
  elastic_split(*law, F, Se, SH, SD);
  const Mat3 dSD = SD - load(old.data());
  Mat3 S = SH + pr.g_inf * SD;
  for (int k = 0; k < 2; ++k) {
    const Mat3 h = load(old.data() + 6 * (k + 1)) + pr.terms[k].g * dSD;
    S += h;
    // Relative to |S^e|: S_D^e is a difference of numbers of size K (J − 1), its rounding is ε |S^e|.
    EXPECT_TRUE(matrices_close(h, load(fresh.data() + 6 * (k + 1)), kQlvExactTol, "h_k", nullptr, Se.norm()));
  }
  EXPECT_TRUE(matrices_close(Mat3(F * S), P, kQlvExactTol, "P at Δt = 0"));
  // A tiny positive step agrees with Δt = 0 to first order in Δt/τ.
  Mat3 P_small;
  ASSERT_EQ(m->evaluate(F, old.data(), fresh.data(), 1e-12, P_small, nullptr), MaterialStatus::ok);
  EXPECT_TRUE(matrices_close(P, P_small, 1e-10, "Δt → 0"));
}

TEST(QLV, FailuresLeaveTheStateUntouched) {
  const auto m = make_material(make_gent_hgo(aniso(2000.0)), three_terms());
  std::vector<double> old(m->state_size(), 0.001), fresh(m->state_size(), 42.0);
  Mat3 P;
  Mat9 A;
  EXPECT_EQ(m->evaluate(Vec3(-1.0, 1.0, 1.0).asDiagonal(), old.data(), fresh.data(), 1.0, P, &A),
            MaterialStatus::inverted);
  // Gent locking: isochoric uniaxial stretch 5 has Ī1 − 3 ≈ 22.4 > Jm = 14.
  EXPECT_EQ(m->evaluate(Vec3(5.0, 1.0 / std::sqrt(5.0), 1.0 / std::sqrt(5.0)).asDiagonal(), old.data(),
                        fresh.data(), 1.0, P, &A),
            MaterialStatus::locking);
  EXPECT_EQ(m->evaluate(Mat3::Identity(), old.data(), fresh.data(), -1.0, P, &A), MaterialStatus::not_finite);
  EXPECT_EQ(m->evaluate(Mat3::Identity(), old.data(), fresh.data(), NAN, P, &A), MaterialStatus::not_finite);
  for (const double v : fresh) EXPECT_EQ(v, 42.0);
}

TEST(QLV, ObjectivityAndRotation) {
  std::mt19937 rng(56);
  const auto law = make_gent_hgo(aniso(2000.0));
  const auto m = make_material(law, three_terms());
  std::vector<double> old(m->state_size()), s1(m->state_size()), s2(m->state_size());
  for (int k = 0; k < 4; ++k) store(random_sym(rng, 0.01), old.data() + 6 * k);
  const Mat3 F = random_F(rng, 1.2, 0.3), Q = random_rotation(rng);
  Mat3 P, PQ;
  ASSERT_EQ(m->evaluate(F, old.data(), s1.data(), 0.7, P, nullptr), MaterialStatus::ok);
  ASSERT_EQ(m->evaluate(Q * F, old.data(), s2.data(), 0.7, PQ, nullptr), MaterialStatus::ok);
  EXPECT_TRUE(matrices_close(Mat3(Q * P), PQ, kQlvExactTol, "P(QF) = Q P(F)"));
  // The material history (S_D^e, h_k) is unaffected by a superposed rotation.
  for (int i = 0; i < m->state_size(); ++i) EXPECT_NEAR(s1[i], s2[i], 1e-12 * (1.0 + std::abs(s1[i])));
  const auto r = m->rotated(Q);
  EXPECT_EQ(r->state_size(), m->state_size());
  ASSERT_EQ(r->fiber_directions().size(), 2u);
  EXPECT_LE((r->fiber_directions()[0] - Q * Vec3(1.0, 1.0, 0.0).normalized()).norm(), 1e-15);
}
