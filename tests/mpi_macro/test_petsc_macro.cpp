// The petsc linear solver of the macro engine against the CHOLMOD path, on 1 and 2 MPI ranks (the suite
// runs under `mpirun -n 1` and `mpirun -n 2`; every rank runs the same Newton iteration, assembles
// its own elements into the shared distributed PETSc system and sums the residuals with the others). With a tight Krylov tolerance (-ksp_rtol 1e-10)
// the converged states agree with the direct solves to the Newton tolerance: relative 1e-6 on the
// responses (the Newton tolerance is 1e-8 of the force scale; the condition numbers of these small
// meshes bring that to ~1e-7 in displacement at most).
#include <gtest/gtest.h>
#include <mpi.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <string>

#include "relative_difference.hpp"
#include "softhom/fe/petsc.hpp"
#include "softhom/fe/solver.hpp"
#include "softhom/core/mpi.hpp"
#include "softhom/io/scene.hpp"
#include "softhom/macro/benchmark_problems.hpp"
#include "softhom/macro/geometry.hpp"
#include "softhom/macro/scene.hpp"
#include "softhom/macro/structures.hpp"
#include "softhom/materials/laws.hpp"

using namespace softhom;
using namespace softhom::fe;
using softhom::test::rank_spread;
using softhom::test::relative_difference;

namespace {

/// PETSc ends before MPI (tests/mpi_main.cpp finalises MPI after RUN_ALL_TESTS).
struct PetscTeardown : ::testing::Environment {
  void TearDown() override { petsc_finalize(); }
};
const auto* const kTeardown = ::testing::AddGlobalTestEnvironment(new PetscTeardown);

// The default preconditioner (field split: augmented displacement block with BoomerAMG, Jacobi on the
// Schur diagonal) with a tight
// tolerance; the scene comparisons below use PETSc's distributed LU (MUMPS) as the preconditioner of
// the same GMRES, which keeps them fast and tests the distributed system itself (matrix, bordered
// cavity row, unsymmetric follower tangent, gathering) rather than the multigrid's iteration counts.
const char* const kTight = std::getenv("PM_OPTS") ? std::getenv("PM_OPTS") : "-ksp_rtol 1e-10";
constexpr const char* kDistributedLu = "-ksp_rtol 1e-10 -pc_type lu -pc_factor_mat_solver_type mumps";

/// Cook's membrane (tests/macro/test_cook.cpp) with n × n hex8 in plane strain and K/G = kg.
FeModel cook(int n, double kg) { return macro::make_cook_membrane_problem(n, 83.3, kg, 5.0); }

struct RunResult {
  std::vector<double> u;
  RunStats stats;
  bool reached = false;
};

RunResult run(const FeModel& m, SolverKind kind, double t_end, int substeps = 1, const std::string& petsc = kTight) {
  NewtonOptions o;
  o.solver = kind;
  o.petsc_options = petsc;
  o.initial_substeps = substeps;
  if (std::getenv("PM_NOMIX")) o.mixed = false;
  o.verbose = std::getenv("SOFTHOM_VERBOSE") != nullptr;
  Simulation sim(m, o);
  RunResult r;
  r.reached = sim.advance_to(t_end).reached();
  r.u = sim.displacement();
  r.stats = sim.stats();
  return r;
}

macro::Structure scene_structure(const std::string& name, int steps, fe::NewtonOptions& newton, double& t_end) {
  const std::string file = std::string(SOFTHOM_SOURCE_DIR) + "/studies/scenes/" + name + ".toml";
  const macro::MacroScene ms = macro::parse_macro_scene(io::load_scene(file), file);
  newton = ms.newton;
  t_end = ms.times.at(std::min<std::size_t>(steps, ms.times.size()) - 1);
  return macro::build_structure(ms.spec);
}

/// A scene's probe responses after `steps` output steps with the given solver.
std::vector<double> scene_response(const macro::Structure& s, fe::NewtonOptions o, SolverKind kind,
                                   const std::vector<double>& times, const char* petsc_options = kDistributedLu) {
  o.solver = kind;
  o.petsc_options = petsc_options;
  o.verbose = std::getenv("SOFTHOM_VERBOSE") != nullptr;
  fe::Simulation sim(s.model, o);
  std::vector<double> out;
  for (double t : times) {
    EXPECT_TRUE(sim.advance_to(t).reached()) << "t = " << t;
    for (double v : macro::probe_values(s, sim)) out.push_back(v);
  }
  return out;
}

std::vector<double> scene_times(const std::string& name, int steps) {
  const std::string file = std::string(SOFTHOM_SOURCE_DIR) + "/studies/scenes/" + name + ".toml";
  const macro::MacroScene ms = macro::parse_macro_scene(io::load_scene(file), file);
  return std::vector<double>(ms.times.begin(), ms.times.begin() + std::min<std::size_t>(steps, ms.times.size()));
}

/// bench_macro_petsc's helix tube (macro::make_helix_tube_spec), κ/G = kg, about `dofs` free dofs.
macro::Structure helix_tube(double dofs, double kg) { return macro::build_structure(macro::make_helix_tube_spec(dofs, kg)); }

}  // namespace

TEST(PetscMacro, CookMembraneEqualsCholmodAndKrylovCountsStayFlat) {
  // Krylov iterations per linear solve (= per Newton step here) on two meshes × two K/G at rtol 1e-10.
  // Measured means with the default split (1 rank): 6×6: 43.0 at K/G 1e2, 60.7 at 1e4; 12×12: 48.3 and
  // 47.7 (mesh ratio 1.12 / 0.79, K/G ratio 1.41 / 0.99). The plain split (diagonal Schur of A alone,
  // upper factorization) measured 52 / 53 and 62 / 72: mesh ratio 1.19 / 1.36, and it grows further on
  // finer meshes (BENCHMARKS.md). Bounds: mesh ratio < 1.25 (the plain split fails it at K/G 1e4; 10 %
  // above the measured worst for the other rank count), K/G ratio < 1.6, fewer than 80 per solve.
  double mean[2][2];
  const int meshes[2] = {6, 12};
  const double ratios[2] = {1e2, 1e4};
  for (int a = 0; a < 2; ++a)
    for (int c = 0; c < 2; ++c) {
      const int n = meshes[a];
      const double kg = ratios[c];
      const FeModel m = cook(n, kg);
      const RunResult direct = run(m, SolverKind::cholmod, 1.0);
      const RunResult petsc = run(m, SolverKind::petsc, 1.0);
      ASSERT_TRUE(direct.reached && petsc.reached) << n << " " << kg;
      const double tip_d = direct.u[macro::cook_tip_dof(n)], tip_p = petsc.u[macro::cook_tip_dof(n)];
      EXPECT_NEAR(tip_p / tip_d, 1.0, 1e-6) << "n = " << n << ", K/G = " << kg;
      EXPECT_LT(relative_difference(petsc.u, direct.u), 1e-6);
      EXPECT_LT(rank_spread(petsc.u), 1e-12);  // the gathered solution is one vector on every rank
      mean[a][c] = double(petsc.stats.krylov_iterations) / std::max(1, petsc.stats.linear.solves);
      if (mpi::world_rank() == 0)
        std::cerr << "cook " << n << "x" << n << " K/G " << kg << ": tip " << tip_p << " (cholmod " << tip_d << "), "
                  << petsc.stats.krylov_iterations << " Krylov its in " << petsc.stats.linear.solves << " solves, "
                  << petsc.stats.newton_iterations << " Newton\n";
    }
  for (int a = 0; a < 2; ++a) {
    EXPECT_LT(mean[a][1], 1.6 * mean[a][0]) << "K/G growth, mesh " << meshes[a];
    for (int c = 0; c < 2; ++c) {
      EXPECT_LT(mean[a][c], 80.0);
      EXPECT_GT(mean[a][c], 1.0);  // an iterative solve, not a direct one
    }
  }
  for (int c = 0; c < 2; ++c) EXPECT_LT(mean[1][c], 1.25 * mean[0][c]) << "mesh growth, K/G " << ratios[c];
}

TEST(PetscMacro, PlaneStrainTubeUnderVolumeControlEqualsCholmod) {
  // The bordered cavity row (two solves per Newton iteration) and the follower-pressure tangent.
  const std::string name = "macro_tube_plane_strain";
  fe::NewtonOptions o;
  double t_end = 0.0;
  const macro::Structure s = scene_structure(name, 3, o, t_end);
  const std::vector<double> times = scene_times(name, 3);
  const std::vector<double> a = scene_response(s, o, SolverKind::cholmod, times);
  const std::vector<double> b = scene_response(s, o, SolverKind::petsc, times);
  ASSERT_EQ(a.size(), b.size());
  EXPECT_LT(relative_difference(b, a), 1e-6);
  EXPECT_LT(rank_spread(b), 1e-12);
}

TEST(PetscMacro, QlvPlateRelaxationEqualsCholmod) {
  // QLV history: a Gent plate (8 × 8 × 1 hex8) stretched to 1.3 in 60 s, then held for 300 s (τ = 120 s):
  // the force relaxes, and the history of every Gauss point must follow the same path on both solvers.
  const std::string text = R"(
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
path = [[0.0, 1.0], [60.0, 1.3], [360.0, 1.3]]
steps = 6
)";
  const macro::MacroScene ms = macro::parse_macro_scene(io::parse_scene(text, "<qlv plate>"));
  const macro::Structure s = macro::build_structure(ms.spec);
  const std::vector<double> a = scene_response(s, ms.newton, SolverKind::cholmod, ms.times);
  const std::vector<double> b = scene_response(s, ms.newton, SolverKind::petsc, ms.times);
  EXPECT_LT(relative_difference(b, a), 1e-6);
  EXPECT_LT(rank_spread(b), 1e-12);
  if (mpi::world_rank() == 0) std::cerr << "qlv plate: " << a.size() << " response values compared\n";
}

TEST(PetscMacro, BalloonThroughItsPressureMaximumEqualsCholmod) {
  // Volume control past the limit point of the Gent sphere (macro_balloon.toml), all 30 steps to hoop
  // stretch 2.5 with the petsc path's default under cavity control (MUMPS's LU preconditioning GMRES;
  // only the tolerance is set): the pressure maximum lies near hoop stretch 1.45 (output steps 4–5 of
  // 30, CHOLMOD run of the scene); the last pressure is well below it (columns: time, pressure,
  // stretch, volume, inner_radius). On more ranks the first 8 steps (past the maximum, 2.7 % below
  // it at step 8): the distributed system through the limit point at a quarter of the cost.
  const std::string name = "macro_balloon";
  const int kSteps = mpi::world_size() == 1 ? 30 : 8;
  fe::NewtonOptions o;
  double t_end = 0.0;
  const macro::Structure s = scene_structure(name, kSteps, o, t_end);
  const std::vector<double> times = scene_times(name, kSteps);
  const std::vector<double> a = scene_response(s, o, SolverKind::cholmod, times);
  const std::vector<double> b = scene_response(s, o, SolverKind::petsc, times, kTight);
  ASSERT_EQ(b.size(), std::size_t(kSteps) * 5u);
  double p_max = 0.0;
  for (int k = 0; k < kSteps; ++k) p_max = std::max(p_max, b[5 * k + 1]);
  EXPECT_LT(b[5 * (kSteps - 1) + 1], 0.99 * p_max) << "the limit point is passed";
  EXPECT_LT(relative_difference(b, a), 1e-6);
  EXPECT_LT(rank_spread(b), 1e-12);
}

TEST(PetscMacro, HelixTubeWithTheDefaultPreconditionerEqualsCholmod) {
  // The 3D tube (2118 free dofs, κ/G = 1.2e5, follower pressure, degenerate hexes in the caps) to
  // pressure 45 of 180 in two steps, with the default field split at rtol 1e-10. Before the pressure
  // couplings of the degenerate hexes were summed, even an exact LU of the PETSc system gave another
  // tangent (condensed residual 600 × |b|) and the first step was cut back until the run gave up.
  const macro::Structure s = helix_tube(1e3, 2000.0 / 0.017);
  RunResult r[2];
  for (int k = 0; k < 2; ++k) {
    NewtonOptions o;
    o.solver = k == 0 ? SolverKind::cholmod : SolverKind::petsc;
    o.petsc_options = kTight;
    o.verbose = std::getenv("SOFTHOM_VERBOSE") != nullptr;
    Simulation sim(s.model, o);
    r[k].reached = sim.advance_to(22.5).reached() && sim.advance_to(45.0).reached();
    r[k].u = sim.displacement();
    r[k].stats = sim.stats();
  }
  ASSERT_TRUE(r[0].reached && r[1].reached);
  EXPECT_LT(relative_difference(r[1].u, r[0].u), 1e-6);
  EXPECT_LT(rank_spread(r[1].u), 1e-12);
  const double per_solve = double(r[1].stats.krylov_iterations) / std::max(1, r[1].stats.linear.solves);
  if (mpi::world_rank() == 0)
    std::cerr << "helix tube: " << r[1].stats.newton_iterations << " Newton (cholmod " << r[0].stats.newton_iterations
              << "), " << per_solve << " Krylov per solve\n";
  // Measured 130 per solve on 1 rank, 149 on 2 (92 / 85 with BoomerAMG's own settings, whose V-cycle
  // costs 2.4–3× more); the bound leaves 14 % above the worst (BoomerAMG's coarsening depends on the
  // partition).
  EXPECT_LT(per_solve, 170.0);
}

TEST(PetscMacro, HelixTubeKrylovCountsOverMeshAndBulkModulus) {
  // The first load step of the helix tube (pressure 45 of 180) with the default split and the default
  // Newton forcing terms, as `bench_macro_petsc --tube-table` runs it (BENCHMARKS.md, "Macro solver on
  // PETSc"): mean GMRES iterations per solve on 2 118 and 7 785 free dofs × K/G 1e2 and 1e5.
  // Measured (1 rank): 2 118 dofs 39.3 / 48.4 at K/G 1e2 / 1e5, 7 785 dofs 44.4 / 67.0: mesh ratio
  // (h / 1.54) 1.13 / 1.38, K/G ratio 1.23 / 1.51. Bounds: mesh ratio < 1.6 and K/G ratio < 2.0 (the
  // measured worst + 15–30 %), fewer than 100 per solve. The
  // plain split (A alone in the displacement block) measured 53.3 / 120.1 on 2 118 dofs (K/G ratio
  // 2.25, above 100 per solve) and failed the 7 785-dof K/G 1e5 step: it fails all three bounds.
  // One rank only (four tube runs, the 2-rank suite's time limit): the distributed split's counts are
  // bounded by the Cook and 2 118-dof tube tests on both rank counts.
  if (mpi::world_size() > 1) GTEST_SKIP() << "one-rank check";
  double mean[2][2];
  const double meshes[2] = {1e3, 4e3};
  const double ratios[2] = {1e2, 1e5};
  for (int a = 0; a < 2; ++a)
    for (int c = 0; c < 2; ++c) {
      const macro::Structure s = helix_tube(meshes[a], ratios[c]);
      NewtonOptions o;
      o.solver = SolverKind::petsc;
      o.verbose = std::getenv("SOFTHOM_VERBOSE") != nullptr;
      Simulation sim(s.model, o);
      ASSERT_TRUE(sim.advance_to(45.0).reached()) << meshes[a] << " " << ratios[c];
      const RunStats st = sim.stats();
      mean[a][c] = double(st.krylov_iterations) / std::max(1, st.linear.solves);
      if (mpi::world_rank() == 0)
        std::cerr << "helix tube " << sim.num_free_dofs() << " dofs, K/G " << ratios[c] << ": " << mean[a][c]
                  << " Krylov per solve, " << st.newton_iterations << " Newton\n";
    }
  for (int a = 0; a < 2; ++a) {
    EXPECT_LT(mean[a][1], 2.0 * mean[a][0]) << "K/G growth, mesh " << meshes[a];
    for (int c = 0; c < 2; ++c) {
      EXPECT_LT(mean[a][c], 100.0);
      EXPECT_GT(mean[a][c], 1.0);
    }
  }
  for (int c = 0; c < 2; ++c) EXPECT_LT(mean[1][c], 1.6 * mean[0][c]) << "mesh growth, K/G " << ratios[c];
}

TEST(PetscMacro, LaggedDirectPreconditionerSavesFactorizationsAndKeepsTheAnswer) {
  // MUMPS's LU as GMRES's preconditioner on the helix tube (2 118 free dofs, κ/G = 1.2e5, follower
  // pressure), four load steps to pressure 90 at the default Newton forcing terms: with
  // `reuse_preconditioner` the factor of an earlier tangent preconditions the later ones while its extra
  // GMRES iterations cost less than a new factorization (the direct path's lagged-factor rules). A
  // factorization here costs tens of triangular solves, so most Newton iterations keep the factor: the
  // answer is the same to the Newton tolerance, with well under the factorizations of a new factor per
  // tangent (measured 1 rank: see the printed counts; the bound 0.75 leaves room for the timing-based
  // refresh rules on a loaded machine, where one factorization per tangent is the outcome to catch).
  const macro::Structure s = helix_tube(1e3, 2000.0 / 0.017);
  RunResult r[2];
  for (int k = 0; k < 2; ++k) {
    NewtonOptions o;
    o.solver = SolverKind::petsc;
    o.petsc_options = "-pc_type lu -pc_factor_mat_solver_type mumps";
    o.reuse_preconditioner = k == 1;
    o.verbose = std::getenv("SOFTHOM_VERBOSE") != nullptr;
    Simulation sim(s.model, o);
    r[k].reached = true;
    for (int step = 1; step <= 4 && r[k].reached; ++step) r[k].reached = sim.advance_to(22.5 * step).reached();
    r[k].u = sim.displacement();
    r[k].stats = sim.stats();
  }
  ASSERT_TRUE(r[0].reached && r[1].reached);
  const int fresh = r[0].stats.linear.factorizations, lagged = r[1].stats.linear.factorizations;
  if (mpi::world_rank() == 0)
    std::cerr << "helix tube, MUMPS: " << fresh << " factorizations / " << r[0].stats.krylov_iterations
              << " Krylov without reuse, " << lagged << " / " << r[1].stats.krylov_iterations << " with ("
              << r[0].stats.newton_iterations << " / " << r[1].stats.newton_iterations << " Newton)\n";
  EXPECT_EQ(fresh, r[0].stats.tangent_assemblies) << "a new factor for every tangent without reuse";
  EXPECT_LT(lagged, 0.75 * fresh);
  EXPECT_LT(relative_difference(r[1].u, r[0].u), 1e-6);
  EXPECT_LT(rank_spread(r[1].u), 1e-12);
}

// The petsc path with BDDC ([solver] petsc_preconditioner = "bddc": one subdomain per rank, the
// condensed displacement system as a MATIS) against the CHOLMOD path. On one rank the single subdomain
// is factorized whole (a direct solve); on two the interface problem is what GMRES iterates on, and its
// counts must not grow with the mesh or with K/G.
namespace {

struct Outcome {
  std::vector<double> u;
  RunStats stats;
  bool reached = false;
  double per_solve() const { return double(stats.krylov_iterations) / std::max(1, stats.linear.solves); }
};

/// `model` to each of `times` with the direct path (kind cholmod) or BDDC at GMRES rtol 1e-10 (and
/// `options`).
Outcome run_bddc(const FeModel& model, SolverKind kind, const std::vector<double>& times, const std::string& options = "",
                 bool flux = true) {
  NewtonOptions o;
  o.solver = kind;
  o.petsc_preconditioner = PetscPreconditioner::bddc;
  o.bddc_flux = flux;
  o.petsc_options = "-ksp_rtol 1e-10 " + options;
  o.verbose = std::getenv("SOFTHOM_VERBOSE") != nullptr;
  Simulation sim(model, o);
  Outcome r;
  r.reached = true;
  for (double t : times) r.reached = r.reached && sim.advance_to(t).reached();
  r.u = sim.displacement();
  r.stats = sim.stats();
  return r;
}

}  // namespace

TEST(Bddc, CookMembraneEqualsCholmodAndKrylovCountsStayFlat) {
  // Cook's membrane in hex8 (Q1 with one pressure per element, plane strain), 8 × 8 and 32 × 32 (16×
  // the dofs) at K/G 1e2 and 1e5, one load step, GMRES rtol 1e-10, with the default constraints (the
  // rigid-body modes and the volume flux on each face, all components together) and with PETSc's
  // per-component ones (-pc_bddc_monolithic 0, [solver] bddc_flux = false).
  // - Default: two subdomains share one face, and the deluxe average over a whole face of two
  //   subdomains is the exact interface solve, up to round-off: measured 1.7 / 2.7 (8², K/G 1e2 / 1e5),
  //   2.0 / 3.0 (32²) GMRES iterations per solve on 2 ranks to rtol 1e-10. Bound: at most 4 (more
  //   subdomains: at most 20).
  // - Per component the face splits into three deluxe sets, which are not exact: measured 12.3 / 12.0
  //   (8², K/G 1e2 / 1e5), 15.7 / 15.0 (32²) on 2 ranks: K/G ratio 0.96–0.97, mesh ratio 1.25–1.27 for
  //   two halvings of h at a fixed two subdomains (BDDC's bound grows like (1 + log(H/h))²; the field
  //   split grows 1.2–1.75× per halving at K/G ≥ 1e3, BENCHMARKS.md). Bounds: K/G ratio < 1.15, mesh
  //   ratio < 1.4 (1.18 per halving), at most 20 per solve.
  const int meshes[2] = {8, 32};
  const double ratios[2] = {1e2, 1e5};
  const std::string per_component = "-pc_bddc_monolithic 0";  // and bddc_flux = false
  double mean[2][2][2];  // [constraints: default, per component][mesh][K/G]
  for (int a = 0; a < 2; ++a)
    for (int c = 0; c < 2; ++c) {
      const int n = meshes[a];
      const FeModel m = macro::make_cook_membrane_problem(n, 83.3, ratios[c], 5.0);
      const Outcome direct = run_bddc(m, SolverKind::cholmod, {1.0});
      for (int k = 0; k < 2; ++k) {
        const Outcome bddc = run_bddc(m, SolverKind::petsc, {1.0}, k == 0 ? "" : per_component, /*flux=*/k == 0);
        ASSERT_TRUE(direct.reached && bddc.reached) << n << " " << ratios[c] << " " << k;
        const double tip_d = direct.u[macro::cook_tip_dof(n)], tip_b = bddc.u[macro::cook_tip_dof(n)];
        EXPECT_NEAR(tip_b / tip_d, 1.0, 1e-6) << "n = " << n << ", K/G = " << ratios[c];
        EXPECT_LT(relative_difference(bddc.u, direct.u), 1e-6);
        EXPECT_LT(rank_spread(bddc.u), 1e-12);
        mean[k][a][c] = bddc.per_solve();
        if (mpi::world_rank() == 0)
          std::cerr << "bddc cook " << n << "x" << n << " K/G " << ratios[c] << (k ? " per component" : "") << " on "
                    << mpi::world_size() << " rank(s): " << mean[k][a][c] << " GMRES per solve, "
                    << bddc.stats.newton_iterations << " Newton (cholmod " << direct.stats.newton_iterations << ")\n";
      }
    }
  // One subdomain is a direct solve: nothing to bound but the answer.
  if (mpi::world_size() == 1) return;
  for (int a = 0; a < 2; ++a)
    for (int c = 0; c < 2; ++c) EXPECT_LE(mean[0][a][c], mpi::world_size() == 2 ? 4.0 : 20.0);
  for (int a = 0; a < 2; ++a) {
    EXPECT_LT(std::max(mean[1][a][0], mean[1][a][1]), 1.15 * std::min(mean[1][a][0], mean[1][a][1])) << "K/G, mesh " << meshes[a];
    for (int c = 0; c < 2; ++c) EXPECT_LE(mean[1][a][c], 20.0);
  }
  for (int c = 0; c < 2; ++c)
    EXPECT_LT(mean[1][1][c], 1.4 * mean[1][0][c]) << "mesh, K/G " << ratios[c];
}

TEST(Bddc, HelixTubeWithFollowerPressureEqualsCholmod) {
  // The 3D Gent–HGO tube (2 118 free dofs, κ/G = 1.2e5): follower pressure on the inner face, whose
  // couplings the subdomain holding both nodes takes (Subdomains::adds_coupling), and degenerate hexes
  // (a node repeated within an element) in the caps; to pressure 45 of 180 in two steps.
  const macro::Structure s = macro::build_structure(macro::make_helix_tube_spec(1e3, 2000.0 / 0.017));
  const Outcome direct = run_bddc(s.model, SolverKind::cholmod, {22.5, 45.0});
  const Outcome bddc = run_bddc(s.model, SolverKind::petsc, {22.5, 45.0});
  ASSERT_TRUE(direct.reached && bddc.reached);
  EXPECT_LT(relative_difference(bddc.u, direct.u), 1e-6);
  EXPECT_LT(rank_spread(bddc.u), 1e-12);
  if (mpi::world_rank() == 0)
    std::cerr << "bddc helix tube on " << mpi::world_size() << " rank(s): " << bddc.per_solve() << " GMRES per solve, "
              << bddc.stats.newton_iterations << " Newton (cholmod " << direct.stats.newton_iterations << ")\n";
  if (mpi::world_size() > 1) {
    EXPECT_LE(bddc.per_solve(), 40.0);
  }
}
