// Thin-shell balloons and tubes against their closed forms (shell structures, fe/shell.hpp): an
// incompressible sphere inflated by cavity-volume control through its pressure maximum (neo-Hookean
// and Gent), P(λ) = 2 (H/R) σ(λ)/λ³, and a long cylinder under internal pressure.
#include <gtest/gtest.h>

#include <cmath>

#include "closed_forms.hpp"
#include "softhom/macro/structures.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/materials/laws.hpp"

using namespace softhom;
using namespace softhom::macro;

namespace {

constexpr double kR = 10.0, kH = 0.1, kG = 0.5;

MaterialPtr gent(double Jm) {
  GentHGOParams p;
  p.G = kG;
  p.Jm = Jm;
  p.K = 1000.0 * kG;
  return make_material(make_gent_hgo(p));
}

MaterialPtr neo_hookean() {
  NeoHookeanParams p;
  p.mu = kG;
  p.K = 1000.0 * kG;
  return make_material(make_neo_hookean(p));
}

StructureSpec balloon(MaterialPtr law, int cells, double final_ratio) {
  StructureSpec s;
  s.kind = StructureKind::shell;
  s.shell.shape = ShellShape::sphere_octant;
  s.shell.radius = kR;
  s.shell.cells = cells;
  s.shell.section = std::make_shared<ShellSection>(std::vector<ShellLayer>{{std::move(law), kH, 3}});
  s.control = LoadControl::volume;
  s.load = PiecewiseLinear{{0.0, 1.0}, {1.0, final_ratio}};
  return s;
}

/// Runs the balloon to the end of its volume path in `steps` output steps; the largest relative error
/// of the cavity pressure against `closed_form(λ)`, λ = (V/V0)^(1/3), over the steps, and the stretch
/// of the largest pressure.
struct BalloonRun {
  double max_error = 0.0, lambda_at_peak = 0.0, peak = 0.0;
  bool passed_peak = false;
};

template <class ClosedForm>
BalloonRun run_balloon(const StructureSpec& spec, int steps, ClosedForm closed_form) {
  const Structure s = build_structure(spec);
  fe::Simulation sim(s.model);
  BalloonRun r;
  double last_p = 0.0;
  for (int k = 1; k <= steps; ++k) {
    const fe::AdvanceResult a = sim.advance_to(double(k) / steps);
    EXPECT_TRUE(a.reached()) << a.message;
    if (!a.reached()) break;
    const std::vector<double> probe = probe_values(s, sim);
    const double lambda = std::cbrt(probe[3]), p = sim.cavity_pressure(), exact = closed_form(lambda);
    r.max_error = std::max(r.max_error, std::abs(p - exact) / std::abs(exact));
    if (p > r.peak) {
      r.peak = p;
      r.lambda_at_peak = lambda;
    }
    r.passed_peak |= p < last_p;
    last_p = p;
  }
  return r;
}

}  // namespace

TEST(ShellBalloon, NeoHookeanThroughItsPressureMaximumMatchesTheThinShellClosedForm) {
  // P = 2 (H/R) G (λ² − λ⁻⁴)/λ³ peaks at λ = 7^(1/6) = 1.383; the path to λ = 2 passes it. The
  // octant of 16² triangles is a polyhedron inscribed in the sphere: its area/volume ratio and the
  // uneven strain of its facets put the coarse mesh's pressure 0.27 % from the closed form at most
  // (measured; bench_shell_balloon refines it), bending adds O((H/R)²) = 1e-4: 0.5 % is the bound.
  const auto closed = [](double l) { return 2 * kH / kR * kG * (l * l - std::pow(l, -4)) / (l * l * l); };
  const BalloonRun r = run_balloon(balloon(neo_hookean(), 16, 8.0), 16, closed);
  EXPECT_TRUE(r.passed_peak);
  EXPECT_LT(r.max_error, 0.005);
}

TEST(ShellBalloon, GentThroughItsPressureMaximumMatchesTheThinShellClosedForm) {
  const double Jm = 30.0;
  const auto closed = [&](double l) { return softhom::macro::test_support::thin_balloon_pressure(kG, Jm, kR, kH, l); };
  // Through the maximum (λ ≈ 1.38) and into the stiffening as λ⁴ nears Jm/2: to λ = 3; measured
  // 0.27 % at most on the same octant, bound 0.5 % as above.
  const BalloonRun r = run_balloon(balloon(gent(Jm), 16, 27.0), 18, closed);
  EXPECT_TRUE(r.passed_peak);
  EXPECT_GT(r.lambda_at_peak, 2.9);  // the stiffening end is above the maximum
  EXPECT_LT(r.max_error, 0.005);
}

TEST(ShellBalloon, AViscoelasticWallRelaxesToItsLongTermPressure) {
  // QLV neo-Hookean wall (D(t) = 0.5 + 0.5 e^(−t/τ), τ = 1 s), inflated in 0.01 s to V/V0 = 2 and held
  // 20 τ: the history of every triangle and section point is the shell's own (committed by the driver
  // after each converged step). Held long enough, the pressure is g∞ = 0.5 of the elastic wall's at the
  // same volume (the QLV stress of a strain held constant relaxes to g∞ S_e; e^(−20) is left): 1e-3.
  auto run = [](const std::optional<PronySeries>& prony) {
    NeoHookeanParams p;
    p.mu = kG;
    p.K = 1000.0 * kG;
    StructureSpec s = balloon(make_material(make_neo_hookean(p), prony), 4, 2.0);
    s.load = PiecewiseLinear{{0.0, 0.01, 20.0}, {1.0, 2.0, 2.0}};
    const Structure st = build_structure(s);
    fe::Simulation sim(st.model);
    std::vector<double> p_at;
    for (double t : {0.01, 0.5, 2.0, 5.0, 10.0, 20.0}) {
      EXPECT_TRUE(sim.advance_to(t).reached());
      p_at.push_back(sim.cavity_pressure());
    }
    return p_at;
  };
  const std::vector<double> qlv = run(PronySeries{0.5, {{0.5, 1.0}}});
  const std::vector<double> elastic = run(std::nullopt);
  for (std::size_t k = 1; k < qlv.size(); ++k) EXPECT_LT(qlv[k], qlv[k - 1]);  // relaxing while held
  EXPECT_NEAR(qlv.back() / elastic.back(), 0.5, 1e-3);
  EXPECT_GT(qlv.front() / elastic.front(), 0.98);  // the fast ramp: nearly the instantaneous response
}

TEST(ShellBalloon, ReportGivesTheLargestStressAndTheShellField) {
  // At λ = 2 the equibiaxial Cauchy stress of the thin neo-Hookean wall is G (λ² − λ⁻⁴) = 1.96875 G;
  // the largest over the section points adds the bending of the facets (H/R = 0.01): 2 %.
  const Structure s = build_structure(balloon(neo_hookean(), 8, 8.0));
  fe::Simulation sim(s.model);
  ASSERT_TRUE(sim.advance_to(1.0).reached());
  fe::ContributionReport r;
  sim.report(r);
  ASSERT_EQ(r.probes.size(), 3u);
  EXPECT_EQ(r.probes[0].first, "shell max principal stress [MPa]");
  EXPECT_NEAR(r.probes[0].second, kG * (4.0 - 1.0 / 16.0), 0.02 * kG * 3.9375);
  EXPECT_EQ(r.probes[2].first, "shell max principal stretch [-]");
  EXPECT_NEAR(r.probes[2].second, 2.0, 0.02);  // λ = 2, the facets' stretch within ±1 %
  ASSERT_EQ(r.fields.size(), 1u);
  const fe::ReportField& f = r.fields[0];
  EXPECT_EQ(f.cells.stem, "shell");
  EXPECT_EQ(f.cells.connectivity.size(), 3u * 64u);
  for (const fe::ReportArray& a : f.arrays) {
    const std::size_t count = a.per_cell ? 64u : f.cells.points.size();
    EXPECT_EQ(a.values.size(), count * a.components) << a.name;
    if (a.name == "thickness_stretch") {
      for (double v : a.values) EXPECT_NEAR(v, 0.25, 0.01);  // λ3 = λ⁻² at λ = 2 (facets: ±1 %)
    }
  }
}
