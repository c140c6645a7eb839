// The cholmod route's symmetric indefinite factorization (linear_solver.hpp): where CHOLMOD's LLᵀ finds
// the symmetric part of a (round-off) symmetric tangent indefinite, MUMPS's LDLᵀ of that part replaces
// UMFPACK's LU. A clamped Gent cylinder inflated by a follower pressure into its locking (the aneurysm's
// vessel wall in small: the Newton iterates of its first steps have indefinite tangents) reaches the
// same state as on the LU route.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "softhom/fe/linear_solver.hpp"
#include "softhom/fe/shell.hpp"
#include "softhom/fe/solver.hpp"
#include "softhom/materials/laws.hpp"

using namespace softhom;
using namespace softhom::fe;

namespace {

/// A cylinder of radius 1 and length 2 about z (nθ × nz cells, one diagonal), its ends clamped, a
/// Gent wall (G = 1, Jm = 0.9 as the vessel, H/R = 0.05) under the inner follower pressure p(t) = 0.3 t
/// (p R/(G H) = 6 at t = 1: into the locking; in four steps 24 Newton iterations, 6 of them with an
/// indefinite symmetric part).
FeModel clamped_gent_cylinder(int ntheta, int nz) {
  FeModel m;
  auto node = [&](int i, int j) { return (i % ntheta) + ntheta * j; };
  for (int j = 0; j <= nz; ++j)
    for (int i = 0; i < ntheta; ++i) {
      const double a = 2.0 * M_PI * i / ntheta;
      m.mesh.nodes.push_back(Vec3(std::cos(a), std::sin(a), 2.0 * j / nz));
    }
  ShellSpec spec;
  for (int j = 0; j < nz; ++j)
    for (int i = 0; i < ntheta; ++i) {  // counter-clockwise seen from outside: outward normals
      spec.triangles.push_back({node(i, j), node(i + 1, j), node(i + 1, j + 1)});
      spec.triangles.push_back({node(i, j), node(i + 1, j + 1), node(i, j + 1)});
    }
  DirichletGroup ends;
  for (int j : {0, nz})
    for (int i = 0; i < ntheta; ++i) {
      spec.edges.push_back({{node(i, j), node(i + 1, j)}, ShellEdge::clamped});
      for (int c = 0; c < 3; ++c) ends.dofs.push_back(3 * node(i, j) + c);
    }
  GentHGOParams g;
  g.G = 1.0;
  g.Jm = 0.9;
  g.K = 1000.0;
  spec.section = std::make_shared<ShellSection>(std::vector<ShellLayer>{{make_material(make_gent_hgo(g)), 0.05, 3}});
  const std::vector<Tri3> tris = spec.triangles;
  m.add(std::make_shared<ShellDomain>(m.mesh, std::move(spec)));
  m.dirichlet.push_back(ends);
  m.pressures.push_back(PressureLoad(shell_load_faces(tris), PiecewiseLinear{{0.0, 1.0}, {0.0, 0.3}}));
  return m;
}

struct CylinderRun {
  std::vector<double> u;
  std::string factors;  ///< LinearSolverReport::description
};

CylinderRun inflate_cylinder(SolverKind kind) {
  NewtonOptions o;
  o.solver = kind;
  // Full Newton steps: their iterates overshoot into the locking, off the path, where the tangent's
  // symmetric part is indefinite (with the line search and the step rules every iterate of this path
  // stays positive definite, and the route would not be exercised).
  o.line_search = false;
  Simulation sim(clamped_gent_cylinder(16, 8), o);
  for (int k = 1; k <= 4; ++k) {
    const AdvanceResult r = sim.advance_to(0.25 * k);
    EXPECT_TRUE(r.reached()) << r.message;
  }
  return {sim.displacement(), sim.stats().linear_solver.description};
}

}  // namespace

TEST(SymmetricIndefinite, TheCholmodRouteTakesItByDefault) {
  LinearSystemFacts facts;
  facts.free_dofs = 1000;
  EXPECT_TRUE(choose_linear_solver(NewtonOptions{}, facts).symmetric_indefinite);
  NewtonOptions o;
  o.symmetric_indefinite = false;
  EXPECT_FALSE(choose_linear_solver(o, facts).symmetric_indefinite);
  o = {};
  o.solver = SolverKind::umfpack;  // LU throughout
  EXPECT_FALSE(choose_linear_solver(o, facts).symmetric_indefinite);
  o.solver = SolverKind::petsc;
  EXPECT_FALSE(choose_linear_solver(o, facts).symmetric_indefinite);
}

TEST(SymmetricIndefinite, InflatedGentCylinderMatchesTheLuRoute) {
  const CylinderRun ldlt = inflate_cylinder(SolverKind::cholmod);
  const CylinderRun lu = inflate_cylinder(SolverKind::umfpack);
  // The route was taken: LDLᵀ in the indefinite iterations (Cholesky in the others), LU alone on the
  // umfpack route.
  EXPECT_NE(ldlt.factors.find("mumps-ldlt"), std::string::npos) << ldlt.factors;
  EXPECT_EQ(lu.factors.find("mumps-ldlt"), std::string::npos) << lu.factors;
  // Both converged to ‖R‖ ≤ 1e-8 of the force scale; the tangent of the locked wall (stiffness ~ G·1e2
  // near the Gent limit against the pressure's scale) turns that into displacement differences of a
  // few 1e-8 of the largest displacement: 1e-6 leaves a decade and a half of margin, while a different
  // equilibrium (a wrong solve) would differ at O(1).
  double umax = 0.0, diff = 0.0;
  for (std::size_t d = 0; d < lu.u.size(); ++d) {
    umax = std::max(umax, std::abs(lu.u[d]));
    diff = std::max(diff, std::abs(ldlt.u[d] - lu.u[d]));
  }
  EXPECT_GT(umax, 0.3);  // inflated into the locking (Ī1 − 3 → 0.9: hoop stretch ~1.5)
  EXPECT_LE(diff, 1e-6 * umax) << "max |u_ldlt - u_lu| = " << diff << " of " << umax;
}
