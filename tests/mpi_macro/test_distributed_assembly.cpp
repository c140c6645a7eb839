// The distributed assembly of the petsc path (fe/src/distributed_assembly.cpp): the elements are split
// over the ranks (each rank evaluates its share only), and what rank 0 writes after a step — the
// element stresses of every element, summed from their owners — equals the CHOLMOD path's.
#include <gtest/gtest.h>
#include <mpi.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "softhom/fe/solver.hpp"
#include "softhom/core/mpi.hpp"
#include "softhom/io/scene.hpp"
#include "softhom/macro/scene.hpp"
#include "softhom/macro/structures.hpp"

using namespace softhom;

namespace {

// A QLV Gent plate (8 × 8 × 1 hex8, the history of every Gauss point matters) stretched in 60 s and held.
constexpr const char* kPlate = R"(
[geometry]
type = "plate"
size = [10.0, 10.0, 1.0]
cells = [8, 8, 1]
[material]
law = "gent"
G = 0.017
Jm = 14.0
K = 20.0
[material.viscoelastic]
g_inf = 0.4
terms = [{ g = 0.6, tau = 120.0 }]
[load]
control = "stretch"
path = [[0.0, 1.0], [60.0, 1.3], [180.0, 1.3]]
steps = 3
)";

struct PlateRun {
  fe::ElementFields fields;
  fe::RunStats stats;
  int elements = 0;
};

PlateRun run_plate(fe::SolverKind kind) {
  const macro::MacroScene ms = macro::parse_macro_scene(io::parse_scene(kPlate, "<qlv plate>"));
  const macro::Structure s = macro::build_structure(ms.spec);
  fe::NewtonOptions o = ms.newton;
  o.solver = kind;
  o.petsc_options = "-ksp_rtol 1e-10 -pc_type lu -pc_factor_mat_solver_type mumps";
  fe::Simulation sim(s.model, o);
  for (double t : ms.times) EXPECT_TRUE(sim.advance_to(t).reached()) << "t = " << t;
  return {sim.element_fields(), sim.stats(), s.model.mesh.num_elements()};
}

}  // namespace

TEST(DistributedAssembly, EveryRankEvaluatesItsShareOfTheElements) {
  const PlateRun petsc = run_plate(fe::SolverKind::petsc);
  const int ranks = mpi::world_size();
  int mine = petsc.stats.assembled_elements, total = mine, least = mine, most = mine;
  MPI_Allreduce(&mine, &total, 1, MPI_INT, MPI_SUM, MPI_COMM_WORLD);
  MPI_Allreduce(&mine, &least, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
  MPI_Allreduce(&mine, &most, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  EXPECT_EQ(total, petsc.elements);  // each element on exactly one rank
  EXPECT_LE(most - least, 1);        // the bisection's equal counts
  EXPECT_LE(most, (petsc.elements + ranks - 1) / ranks);
  // The CHOLMOD path stays replicated: every rank evaluates every element.
  EXPECT_EQ(run_plate(fe::SolverKind::cholmod).stats.assembled_elements, petsc.elements);
}

TEST(DistributedAssembly, ElementStressesOfAllElementsEqualCholmodOnEveryRank) {
  // The stresses come from each element's owner (its history lives there alone); after a commit every
  // rank holds all of them. The tolerance is the solver comparison's (test_petsc_macro.cpp): relative
  // 1e-6 of the largest stress component.
  const PlateRun a = run_plate(fe::SolverKind::cholmod);
  const PlateRun b = run_plate(fe::SolverKind::petsc);
  ASSERT_EQ(a.fields.cauchy.size(), b.fields.cauchy.size());
  double d = 0.0, m = 0.0;
  for (std::size_t k = 0; k < a.fields.cauchy.size(); ++k) {
    d = std::max(d, std::abs(a.fields.cauchy[k] - b.fields.cauchy[k]));
    m = std::max(m, std::abs(a.fields.cauchy[k]));
  }
  ASSERT_GT(m, 0.0);
  EXPECT_LT(d / m, 1e-6);
  double vm = 0.0;
  for (std::size_t e = 0; e < a.fields.von_mises.size(); ++e) vm = std::max(vm, std::abs(a.fields.von_mises[e] - b.fields.von_mises[e]));
  EXPECT_LT(vm / m, 1e-6);
  // The volume ratio of every element, from the reference geometry a rank keeps for its own elements
  // and recomputes for the others' (Simulation::Impl::build_geometry).
  ASSERT_EQ(a.fields.J.size(), b.fields.J.size());
  double dJ = 0.0, stretch = 0.0;
  for (std::size_t e = 0; e < a.fields.J.size(); ++e) {
    dJ = std::max(dJ, std::abs(a.fields.J[e] - b.fields.J[e]));
    stretch = std::max(stretch, std::abs(a.fields.J[e] - 1.0));
  }
  EXPECT_GT(stretch, 1e-5);  // J moved (K/G ~ 1e3): the comparison has something to compare
  EXPECT_LT(dJ, 1e-5 * stretch);  // the solver comparison's 1e-6 of the stresses, with a decade's margin
}

TEST(DistributedAssembly, Tet10PlaneStrainTubeUnderVolumeControlEqualsCholmod) {
  // The quadratic tetrahedra (30 dofs per element, one dilatation each) through the same distributed
  // fill: the shipped plane-strain tube split into tet10, 3 volume-control steps, PETSc (MUMPS as the
  // preconditioner of GMRES at rtol 1e-10) against CHOLMOD to the solver comparison's 1e-6.
  const std::string file = std::string(SOFTHOM_SOURCE_DIR) + "/studies/scenes/macro_tube_plane_strain.toml";
  macro::MacroScene ms = macro::parse_macro_scene(io::load_scene(file), file);
  ms.spec.tet10 = true;
  ms.spec.tube.radial_cells = 4;
  ms.spec.tube.circumferential_cells = 16;
  const macro::Structure s = macro::build_structure(ms.spec);
  ASSERT_FALSE(s.model.mesh.tets.empty());
  std::vector<double> response[2], u[2];
  int assembled = 0;
  for (int k = 0; k < 2; ++k) {
    fe::NewtonOptions o = ms.newton;
    o.solver = k == 0 ? fe::SolverKind::cholmod : fe::SolverKind::petsc;
    o.petsc_options = "-ksp_rtol 1e-10 -pc_type lu -pc_factor_mat_solver_type mumps";
    fe::Simulation sim(s.model, o);
    for (int step = 0; step < 3; ++step) {
      EXPECT_TRUE(sim.advance_to(ms.times[step]).reached()) << "t = " << ms.times[step];
      for (double v : macro::probe_values(s, sim)) response[k].push_back(v);
    }
    u[k] = sim.displacement();
    assembled = sim.stats().assembled_elements;
  }
  auto relative = [](const std::vector<double>& a, const std::vector<double>& b) {  // max |a − b| / max |a|
    double d = 0.0, m = 0.0;
    for (std::size_t i = 0; i < a.size(); ++i) {
      d = std::max(d, std::abs(a[i] - b[i]));
      m = std::max(m, std::abs(a[i]));
    }
    return d / std::max(m, 1e-300);
  };
  ASSERT_EQ(response[0].size(), response[1].size());
  EXPECT_LT(relative(response[0], response[1]), 1e-6);  // pressure, volume, radius, probes
  EXPECT_LT(relative(u[0], u[1]), 1e-6);
  if (mpi::world_size() > 1) {
    EXPECT_LT(assembled, s.model.mesh.num_elements());
  }
}
