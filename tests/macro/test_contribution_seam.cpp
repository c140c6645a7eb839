// A contribution added from outside fe's driver (tests/spring_contribution.hpp: springs between two
// nodes, as an interface) reaches the Newton iteration through the contribution seam alone: its declared
// couplings enter the stiffness pattern (nodes in no element get their equations from them), its
// residual and tangent the assembly, on the CHOLMOD path and on the petsc path (one process here; two
// ranks in tests/mpi_macro/test_contribution_seam_mpi.cpp).
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "softhom/fe/solver.hpp"
#include "spring_contribution.hpp"

using namespace softhom;

namespace {

/// The displacements of the chain's free nodes after one load step on `kind`.
std::vector<double> solve_chain(const test::SpringChain& c, fe::SolverKind kind) {
  fe::NewtonOptions o;
  o.solver = kind;
  o.mixed = false;  // the held cubes need no element pressures
  o.petsc_options = "-pc_type lu -pc_factor_mat_solver_type mumps";
  fe::Simulation sim(c.model, o);
  EXPECT_TRUE(sim.advance_to(1.0).reached());
  const std::vector<double>& u = sim.displacement();
  return {u[3 * c.n1], u[3 * c.n1 + 1], u[3 * c.n1 + 2], u[3 * c.n2], u[3 * c.n2 + 1], u[3 * c.n2 + 2]};
}

void expect_closed_form(const test::SpringChain& c, const std::vector<double>& u) {
  // Linear springs: Newton's first correction is the solution; the convergence test (1e-8 of the force
  // scale) bounds what is left, so 1e-8 relative.
  const double u1 = c.u1(), u2 = c.u2();
  EXPECT_NEAR(u[0], u1, 1e-8 * u2);
  EXPECT_NEAR(u[3], u2, 1e-8 * u2);
  for (int i : {1, 2, 4, 5}) EXPECT_NEAR(u[i], 0.0, 1e-8 * u2);
}

}  // namespace

TEST(ContributionSeam, SpringChainGivesTheClosedFormOnTheCholmodPath) {
  const test::SpringChain c = test::spring_chain();
  expect_closed_form(c, solve_chain(c, fe::SolverKind::cholmod));
}

TEST(ContributionSeam, SpringChainGivesTheClosedFormOnThePetscPath) {
  const test::SpringChain c = test::spring_chain();
  expect_closed_form(c, solve_chain(c, fe::SolverKind::petsc));
}

TEST(ContributionSeam, ATangentOutsideTheDeclaredCouplingsIsRefused) {
  // Without its couplings the springs' nodes have no place in the pattern: the assembly says so
  // instead of writing outside the matrix.
  const test::SpringChain c = test::spring_chain(/*declare=*/false);
  fe::NewtonOptions o;
  o.solver = fe::SolverKind::cholmod;
  o.mixed = false;
  fe::Simulation sim(c.model, o);
  EXPECT_THROW((void)sim.advance_to(1.0), std::logic_error);
}

TEST(ContributionSeam, ContributionsReportTheirProbesAndFieldsAtTheConvergedState) {
  // Springs in series carry the load F each: the probes read it back at the converged state (1e-8
  // relative as the displacements), one field per spring with its segment's reference ends.
  const test::SpringChain c = test::spring_chain();
  fe::NewtonOptions o;
  o.solver = fe::SolverKind::cholmod;
  o.mixed = false;
  fe::Simulation sim(c.model, o);
  fe::ContributionReport before;
  sim.report(before);
  ASSERT_EQ(before.probes.size(), 2u);
  EXPECT_EQ(before.probes[0].second, 0.0);
  ASSERT_TRUE(sim.advance_to(1.0).reached());
  fe::ContributionReport r;
  sim.report(r);
  ASSERT_EQ(r.probes.size(), 2u);
  EXPECT_EQ(r.probes[1].first, "spring_12_13_force [N]");
  for (const auto& [name, force] : r.probes) EXPECT_NEAR(force, c.force, 1e-8 * c.force) << name;
  ASSERT_EQ(r.fields.size(), 2u);
  EXPECT_EQ(r.fields[1].cells.stem, "spring_12_13");
  EXPECT_EQ(r.fields[1].cells.points[1], c.model.mesh.nodes[c.n2]);
  ASSERT_EQ(r.fields[1].arrays.size(), 1u);
  EXPECT_NEAR(r.fields[1].arrays[0].values[0], c.force, 1e-8 * c.force);
}

namespace {

/// A spring from node `from` to a partner that changes with the configuration, as a contact's pairing
/// does: `first` while the converged time is below `switch_time`, `second` from then on. The partner is
/// its history (state_size 1), chosen in pair() and read back in assemble.
class SwitchingSpring final : public fe::Contribution {
 public:
  SwitchingSpring(int from, int first, int second, double k, double switch_time)
      : from_(from), first_(first), second_(second), k_(k), switch_time_(switch_time) {}
  Kind kind() const override { return Kind::interface; }
  std::string name() const override { return "switching spring"; }
  bool couplings_change() const override { return true; }
  int state_size() const override { return 1; }
  void init_state(double* s) const override { s[0] = -1.0; }
  void pair(const fe::Mesh&, const fe::Iterate& converged, fe::Couplings& couplings) const override {
    const int partner = converged.t < switch_time_ ? first_ : second_;
    converged.state_new[0] = partner;
    const int nodes[2] = {from_, partner};
    couplings.add(nodes, 2);
  }
  MaterialStatus assemble(const fe::Mesh& mesh, const fe::Iterate& it, fe::AssemblySink& sink) const override {
    const int partner = int(it.state_old[0]);
    if (it.state_new) it.state_new[0] = partner;
    return test::Spring(from_, partner, k_).assemble(mesh, it, sink);
  }

 private:
  int from_, first_, second_;
  double k_, switch_time_;
};

/// One held cube; free nodes p, q, r each on a spring k to a held corner; a force F t on p; the switching
/// spring ks from p to q until t = 0.5, to r after. Linear: u_p = F t (k + ks) / ((k + ks)² − ks²) and
/// the partner's u = ks u_p / (k + ks), the other free node's 0.
struct Switching {
  double k = 2.0, ks = 1.0, force = 0.3;
  int p = 8, q = 9, r = 10;
  fe::FeModel model;
  double up(double t) const { return force * t * (k + ks) / ((k + ks) * (k + ks) - ks * ks); }
  double partner(double t) const { return ks * up(t) / (k + ks); }
};

Switching switching_model() {
  Switching s;
  fe::FeModel& m = s.model;
  for (int z = 0; z < 2; ++z)
    for (int y = 0; y < 2; ++y)
      for (int x = 0; x < 2; ++x) m.mesh.nodes.emplace_back(x, y, z);
  m.mesh.hexes.push_back({0, 1, 3, 2, 4, 5, 7, 6});
  for (int i = 0; i < 3; ++i) m.mesh.nodes.emplace_back(3.0 + i, 0.0, 0.0);  // p, q, r: in no element
  m.element_material.assign(1, make_material(make_neo_hookean({1.0, 10.0})));
  fe::DirichletGroup held;
  for (int d = 0; d < 24; ++d) held.dofs.push_back(d);
  m.dirichlet.push_back(held);
  for (int n : {s.p, s.q, s.r}) m.add(std::make_shared<test::Spring>(1, n, s.k));
  m.add(std::make_shared<SwitchingSpring>(s.p, s.q, s.r, s.ks, 0.5));
  m.nodal_loads.emplace_back(std::vector<int>{3 * s.p}, std::vector<double>{s.force}, PiecewiseLinear{{0.0, 1.0}, {0.0, 1.0}});
  return s;
}

void expect_switch(fe::SolverKind kind) {
  const Switching s = switching_model();
  fe::NewtonOptions o;
  o.solver = kind;
  o.mixed = false;
  o.petsc_options = "-pc_type lu -pc_factor_mat_solver_type mumps";
  fe::Simulation sim(s.model, o);
  // Linear springs: Newton's first correction is the solution, to the convergence test's 1e-8 of the
  // force scale, so 1e-8 relative. The partner of the steps up to t = 0.5 is q (paired from converged
  // times 0 and 0.25), then r (from 0.5 and 0.75): a coupling (p, r) outside the first pattern, which
  // the assembly would refuse had the pattern not been rebuilt.
  for (double t : {0.25, 0.5}) ASSERT_TRUE(sim.advance_to(t).reached());
  const std::vector<double>& u = sim.displacement();
  EXPECT_NEAR(u[3 * s.p], s.up(0.5), 1e-8 * s.up(0.5));
  EXPECT_NEAR(u[3 * s.q], s.partner(0.5), 1e-8 * s.up(0.5));
  EXPECT_NEAR(u[3 * s.r], 0.0, 1e-8 * s.up(0.5));
  for (double t : {0.75, 1.0}) ASSERT_TRUE(sim.advance_to(t).reached());
  EXPECT_NEAR(u[3 * s.p], s.up(1.0), 1e-8 * s.up(1.0));
  EXPECT_NEAR(u[3 * s.q], 0.0, 1e-8 * s.up(1.0));
  EXPECT_NEAR(u[3 * s.r], s.partner(1.0), 1e-8 * s.up(1.0));
  // The pattern was built for the first pairing and rebuilt once, at the switch.
  EXPECT_EQ(sim.stats().pattern_rebuilds, 2);
}

}  // namespace

TEST(ContributionSeam, CouplingsThatChangeRebuildThePatternOnTheCholmodPath) { expect_switch(fe::SolverKind::cholmod); }

TEST(ContributionSeam, CouplingsThatChangeEnterThePetscMatrix) { expect_switch(fe::SolverKind::petsc); }
