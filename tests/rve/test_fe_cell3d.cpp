// 3D variant of the FE RVE engine: periodic Tet10 cell meshes (CGAL Periodic_3_mesh_3) and the
// solver on them. Periodic node matching checked independently of the mesher, homogeneous cell =
// material point, straight fibers in 3D = the section solution within the discretization error,
// quadratic Newton convergence (consistent tangent, condensed P2/P0 pressure).
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <tuple>

#include "rve/rve_test_helpers.hpp"
#include "softhom/materials/driver.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/materials/library.hpp"
#include "softhom/rve/fe_mesh.hpp"
#include "softhom/rve/fe_solver.hpp"

using namespace softhom;
using namespace softhom::rve;
using softhom::rve::testing::uniaxial_ramp;
using softhom::rve::testing::kPi;
using softhom::rve::testing::preset;
using softhom::rve::testing::rel;

namespace {

Section circle_section_cell(double vf = 0.23, Arrangement arr = Arrangement::square) {
  FiberCellSpec s;
  s.shape = SectionShape::circle;
  s.radius = 0.2;
  s.volume_fraction = vf;
  s.arrangement = arr;
  return generate_section(s);
}

CellMesh cell_mesh_of(const Section& s, double mesh_size, double interface_size) {
  CellMeshOptions o;
  o.mesh_size = mesh_size;
  o.interface_size = interface_size;
  return mesh_cell(s, o);
}

/// Independent pairing check: wrap every node into [0, L)³ and match by coordinates. Nodes at the same
/// wrapped position must have the same master and nodes of different masters must sit at different
/// positions; returns the number of positions shared by ≥ 2 nodes (nodes on the cell faces, edges and
/// corners of the unwrapped elements).
int expect_coordinate_pairing(const CellMesh& m) {
  const double L[3] = {m.L1, m.L2, m.L3};
  const double q = 1e-9 * m.L1;  // round-off of the unwrapping shifts: ~1e-16 L
  std::map<std::tuple<long, long, long>, int> master_at;
  std::map<int, std::tuple<long, long, long>> position_of;
  int shared = 0;
  for (int i = 0; i < m.num_nodes(); ++i) {
    long k[3];
    for (int c = 0; c < 3; ++c) {
      double x = std::fmod(m.nodes[i][c], L[c]);
      if (x < 0.0) x += L[c];
      if (L[c] - x < 0.5 * q) x = 0.0;  // x ≈ L is the image of 0
      k[c] = std::lround(x / q);
    }
    const auto key = std::make_tuple(k[0], k[1], k[2]);
    const auto it = master_at.find(key);
    if (it == master_at.end()) {
      master_at[key] = m.master[i];
      const auto pos = position_of.find(m.master[i]);
      if (pos != position_of.end()) ADD_FAILURE() << "master " << m.master[i] << " at two positions";
      position_of[m.master[i]] = key;
    } else {
      EXPECT_EQ(it->second, m.master[i]) << "two masters at one position (node " << i << ")";
      ++shared;
    }
  }
  EXPECT_EQ(int(master_at.size()), m.num_masters());
  return shared;
}

}  // namespace

// Square cell, one circular fiber (VF 0.23), cube cell: the torus mesh closes (every face shared by two
// elements with opposite orientations, volumes add up to the cell), periodic copies match their
// masters exactly (shifts by whole cell lengths: mismatch ~1e-16 L), and the coordinate matching on the
// cell faces agrees with the mesher's master map. Curved mid-edge nodes: the fiber volume is exact to
// O(h³) (measured 1.6e-4–2.0e-4 with interface size L/6 ≈ 0.6 r; straight chords would give ~1e-2).
// Quality bounds: CGAL's exuder removes slivers, but the mesh itself differs by an element or two
// between CPUs (libm picks FMA or non-FMA code paths at run time, and the mesher's predicates see the
// difference): measured min dihedral angle 4.2°–4.4°, min radius ratio 0.080–0.087 on two machines.
// Required > 2.5° and > 0.04: still an order of magnitude above a sliver (< 0.3° and < 0.005).
TEST(FeMesh3d, PeriodicTetMeshMatchesOppositeFaces) {
  const Section s = circle_section_cell();
  const CellMesh m = cell_mesh_of(s, s.L1 / 3, s.L1 / 6);
  std::printf("3D cell mesh: %d Tet10 elements, %d vertices, %d nodes (%d copies), dihedral %.1f..%.1f deg, "
              "radius ratio min %.3f mean %.3f, fiber volume error %.2e\n",
              m.num_elements(), m.vertices, m.num_nodes(), m.quality.periodic_copies, m.quality.min_dihedral_deg,
              m.quality.max_dihedral_deg, m.quality.min_radius_ratio, m.quality.mean_radius_ratio,
              m.quality.fiber_volume_error);
  EXPECT_LE(verify_periodic_cell_mesh(m), 1e-12 * s.L1);
  EXPECT_GT(m.quality.periodic_copies, 0);
  const int shared = expect_coordinate_pairing(m);
  EXPECT_EQ(shared, m.quality.periodic_copies);  // every copy sits at its master's wrapped position
  EXPECT_NEAR(m.volume(0) + m.volume(1), s.L1 * s.L2 * s.L1, 1e-12 * std::pow(s.L1, 3));
  EXPECT_LT(m.quality.fiber_volume_error, 5e-4);
  EXPECT_GT(m.quality.min_dihedral_deg, 2.5);
  EXPECT_GT(m.quality.min_radius_ratio, 0.04);
  EXPECT_LT(m.quality.max_edge, 1.6 * s.L1 / 3);
  int fiber = 0;
  for (int p : m.phase) fiber += p;
  EXPECT_GT(fiber, 0);
  EXPECT_EQ(m.quality.aspect_stretch, 1.0);
  (void)kPi;
}

// Hexagonal arrangement (L2 = √3 L1, fibers crossing the cell faces), meshed in CGAL's cube and
// mapped affinely: still a closed periodic torus mesh with exact pairing; the stretch is reported.
// The stretched surface triangles approximate the cylinders less well (measured fiber volume error
// 3.9e-3 at interface size L1/5; required < 1e-2).
TEST(FeMesh3d, HexagonalCellIsPeriodicAfterTheAffineMap) {
  const Section s = circle_section_cell(0.3, Arrangement::hexagonal);
  CellMeshOptions o;
  o.mesh_size = s.L1 / 3;
  o.interface_size = s.L1 / 5;
  const CellMesh m = mesh_cell(s, o);
  EXPECT_LE(verify_periodic_cell_mesh(m), 1e-12 * s.L2);
  expect_coordinate_pairing(m);
  EXPECT_NEAR(m.quality.aspect_stretch, std::sqrt(3.0), 1e-9);
  EXPECT_LT(m.quality.fiber_volume_error, 1e-2);
}

// Both phases the same nearly incompressible Gent law (ecoflex, K/G = 1.2e5, the P2/P0 path),
// α = 30°: the 3D fluctuation is exactly zero and the macro Newton solves the material point's mixed
// control. Tolerance 1e-8 (solver tolerance 1e-10, round-off floor ~eps K / |P|). One step to λ = 2 (6
// Newton iterations; four steps took 16 to the same states): the equality is of converged states, the
// step loop is the 2D test's (FeRve.HomogeneousCellEqualsMaterialPoint) and the nonlinearity is the same.
TEST(FeRve3d, HomogeneousCellEqualsMaterialPoint) {
  const Section s = circle_section_cell();
  const MaterialPtr m = preset("ecoflex");
  const MixedControl control = uniaxial_ramp(2.0, 1);
  const PointRunResult point = run_material_point(*m, control);
  ASSERT_TRUE(point.completed) << point.error;
  FeSolverOptions o;
  o.tolerance = 1e-10;
  o.pressure = FePressure::p0;
  FeRveSolver solver(cell_mesh_of(s, s.L1 / 2, s.L1 / 4), m, m, 30.0, control.frame, o);
  EXPECT_TRUE(solver.is_3d());
  const RveRunResult r = solver.run(control);
  ASSERT_TRUE(r.completed) << r.error;
  ASSERT_EQ(r.steps.size(), point.steps.size());
  for (std::size_t k = 1; k < r.steps.size(); ++k) {
    EXPECT_LT(rel(r.steps[k].P, point.steps[k].P), 1e-8) << "step " << k;
    EXPECT_LT(rel(r.steps[k].F, point.steps[k].F), 1e-8) << "step " << k;
    // Phase means sum per-element P0 pressures, each converged only to the round-off floor ~eps K
    // (K/G = 1.2e5) over fewer fiber elements than the cell: measured 1.0–1.1e-8.
    EXPECT_LT(rel(r.steps[k].P_fiber, point.steps[k].P), 5e-8);
  }
  EXPECT_EQ(r.cutbacks, 0);
}

// The 3D pressure option is P2/P0 only: asking for the bubble pair is an input error.
TEST(FeRve3d, RejectsTheSectionOnlyPressureSpace) {
  const Section s = circle_section_cell();
  FeSolverOptions o;
  o.pressure = FePressure::p1_bubble;
  EXPECT_THROW(FeRveSolver(cell_mesh_of(s, s.L1 / 2, s.L1 / 4), preset("ecoflex"), preset("glass"), 45.0,
                           Mat3::Identity(), o),
               InputError);
}

// Straight continuous fibers: the 3D solution (no restriction on ∂ũ/∂y3) must equal the section
// solution up to the discretization errors of both. Cell: PDMS + glass, VF 0.23, α = 45°, uniaxial
// tension λ = 1.3. Reference: section P2+bubble/P1 at L/8 (error ~2e-6, BENCHMARKS.md). The P2/P0
// section element at L/4 is 2.6e-4 off the reference at λ = 1.5 (measured, O(h^1.2–1.7)); the 3D mesh
// has a comparable interface size (L/6 → r/3) but coarser elements elsewhere. Required: 3D within
// 1.5e-3 of the reference, i.e. a few times the section P2/P0 error at that density (measured
// values are printed), and refining the 3D mesh moves it toward the reference. One load step (5 Newton
// iterations against 8 for two; hyperelastic, so the same end state to the Newton tolerance: measured
// 4.61e-4 at L/3 with one step, 4.55e-4 with two).
TEST(FeRve3d, StraightFibersMatchTheSectionSolution) {
  const Section s = circle_section_cell();
  const MaterialPtr matrix = preset("pdms"), glass = preset("glass");
  const MixedControl control = uniaxial_ramp(1.3, 1);
  SectionMeshOptions so;
  so.mesh_size = s.L1 / 8;
  so.interface_size = s.L1 / 24;
  FeRveSolver ref_solver(mesh_section(s, so), matrix, glass, 45.0, control.frame);
  const RveRunResult ref = ref_solver.run(control);
  ASSERT_TRUE(ref.completed) << ref.error;
  const double P_ref = ref.steps.back().P(0, 0);
  std::vector<double> err;
  for (double div : {2.0, 3.0}) {
    FeSolverOptions o;
    o.pressure = FePressure::p0;
    FeRveSolver solver(cell_mesh_of(s, s.L1 / div, s.L1 / (2 * div)), matrix, glass, 45.0, control.frame, o);
    const RveRunResult r = solver.run(control);
    ASSERT_TRUE(r.completed) << r.error;
    err.push_back(std::abs(r.steps.back().P(0, 0) - P_ref) / P_ref);
    std::printf("3D L/%g: %d Tet10, %d equations, P11 %.7f vs section %.7f: rel. difference %.2e; F22 %.6f vs %.6f\n",
                div, solver.num_elements(), solver.num_equations(), r.steps.back().P(0, 0), P_ref, err.back(),
                r.steps.back().F(1, 1), ref.steps.back().F(1, 1));
    // Straight fibers: the fiber angle change and the transverse stretch agree as well.
    EXPECT_NEAR(r.steps.back().F(1, 1), ref.steps.back().F(1, 1), 2e-3 * ref.steps.back().F(1, 1));
  }
  EXPECT_LT(err.back(), 1.5e-3);
  EXPECT_LT(err.back(), err.front() * 1.05);
}

// Newton on the 3D mesh: consistent tangent (material tangent + condensed P2/P0 pressure + macro
// rows), so once the residual is small the error is squared per iteration. Checked on one step of a
// PDMS + glass cell to λ = 1.4 (measured residuals 5.3e1, 2.3, 4.9e-2, 5.1e-6, 3.7e-12: ratio 2.2): some
// iteration pair with r_k ≤ 1e-2 and r_(k+1) above the round-off floor must show
// log r_(k+1) / log r_k ≥ 1.6 (quadratic: 2; a linearly converging modified Newton would give ≈ 1).
TEST(FeRve3d, NewtonConvergesQuadratically) {
  const Section s = circle_section_cell();
  const MixedControl control = uniaxial_ramp(1.4, 1);
  FeSolverOptions o;
  o.pressure = FePressure::p0;
  o.tolerance = 1e-12;
  FeRveSolver solver(cell_mesh_of(s, s.L1 / 2, s.L1 / 4), preset("pdms"), preset("glass"), 45.0, control.frame, o);
  const RveRunResult r = solver.run(control);
  ASSERT_TRUE(r.completed) << r.error;
  const std::vector<double>& res = r.steps.back().residuals;
  ASSERT_GE(res.size(), 3u);
  double best = 0.0;
  for (std::size_t k = 0; k + 1 < res.size(); ++k) {
    std::printf("iteration %zu: residual %.3e\n", k, res[k]);
    if (res[k] <= 1e-2 && res[k + 1] > 1e-13) best = std::max(best, std::log(res[k + 1]) / std::log(res[k]));
  }
  std::printf("iteration %zu: residual %.3e\n", res.size() - 1, res.back());
  EXPECT_GE(best, 1.6);
}

// The 3D quadrature option: the positive 14-point degree-5 rule integrates the cubic Jacobian of a
// curved Tet10 exactly, so the solver's phase volumes (sums of quadrature weights) equal the mesh's
// exact volumes (CellMesh::volume, degree-3 rule) to round-off. The 4-point degree-2 rule is not
// exact for curved elements in general, but measured equal to 1e-12 here (the curved mid-edge nodes
// move by the small sagitta); required within 1e-5. The homogenized P11 moved by 7e-6 (L/3) and
// 1e-5 (L/4) between the rules (PDMS, λ = 1.5), so the quadrature is not what limits the 3D
// accuracy; 4 points stay the default. Other point counts are input errors.
TEST(FeRve3d, DegreeFiveRuleIntegratesCurvedVolumesExactly) {
  const Section s = circle_section_cell();
  const CellMesh m = cell_mesh_of(s, s.L1 / 3, s.L1 / 6);
  const double vf_exact = m.volume(1) / (m.L1 * m.L2 * m.L3);
  FeSolverOptions o;
  o.pressure = FePressure::p0;
  o.tet_quadrature_points = 14;
  FeRveSolver q14(m, preset("pdms"), preset("glass"), 45.0, Mat3::Identity(), o);
  o.tet_quadrature_points = 4;
  FeRveSolver q4(m, preset("pdms"), preset("glass"), 45.0, Mat3::Identity(), o);
  std::printf("VF exact %.12f, 14-point %.12f, 4-point %.12f\n", vf_exact, q14.achieved_volume_fraction(),
              q4.achieved_volume_fraction());
  EXPECT_NEAR(q14.achieved_volume_fraction(), vf_exact, 1e-12);
  EXPECT_NEAR(q4.achieved_volume_fraction(), vf_exact, 1e-5);
  o.tet_quadrature_points = 5;
  EXPECT_THROW(FeRveSolver(m, preset("pdms"), preset("glass"), 45.0, Mat3::Identity(), o), InputError);
}

// Phase volumes of the 3D mesh follow the cylinder. CGAL's labelled-domain mesh
// can bound the fiber by a facet whose vertex is off the surface (L/4, every seed: a vertex 0.27 r
// outside shared by four fiber cells, +1.3e-3 fiber volume, 3D P11 6e-4 too stiff) and labels flat
// surface cells (all four vertices on the cylinder, hence inside it) by their circumcentre as matrix
// (−1e-4 … −6e-4 of the fiber volume). mesh_cell now curves every phase-boundary facet, projects
// far interface vertices and relabels such cells (falling back to CGAL's labels if that folds an
// element); measured fiber volume errors: L/3 2.6e-5 (before: 2.1e-4), L/6 3.9e-6. Required:
// < 1e-4 at both, every interface vertex on the surface to round-off (offset < 1e-9 r).
TEST(FeMesh3d, PhaseVolumesFollowTheCylinder) {
  const Section s = circle_section_cell();
  for (double div : {3.0, 6.0}) {
    const CellMesh m = cell_mesh_of(s, s.L1 / div, s.L1 / (2 * div));
    std::printf("L/%g: %d Tet10, fiber volume error %.2e, max interface offset %.1e r, %d cells relabelled, "
                "min dihedral %.1f deg\n", div, m.num_elements(), m.quality.fiber_volume_error,
                m.quality.max_interface_offset, m.quality.relabeled_cells, m.quality.min_dihedral_deg);
    EXPECT_LT(m.quality.fiber_volume_error, 1e-4);
    EXPECT_LT(m.quality.max_interface_offset, 1e-9);
  }
}

// Some seeds still fold an element after the repairs (measured on this cell:
// L/5 with seeds 1 and 3, L/6 with seed 2); mesh_cell then remakes the mesh with the next seeds
// (CellMeshOptions::seed_retries, default 3) and reports the seed it used. CGAL's output is not
// bit-reproducible between runs, so the test asks for a valid mesh from seed 1 within the retries,
// not for a particular seed.
TEST(FeMesh3d, FoldedMeshIsRemadeWithTheNextSeed) {
  const Section s = circle_section_cell();
  const CellMesh m = cell_mesh_of(s, s.L1 / 5.0, s.L1 / 10.0);
  std::printf("L/5: seed used %u, %d Tet10, fiber volume error %.2e\n", m.quality.seed_used, m.num_elements(),
              m.quality.fiber_volume_error);
  EXPECT_GE(m.quality.seed_used, 1u);
  EXPECT_LE(m.quality.seed_used, 4u);
  EXPECT_LT(m.quality.fiber_volume_error, 1e-4);
  CellMeshOptions bad;
  bad.seed_retries = -1;
  EXPECT_THROW(mesh_cell(s, bad), InputError);
}
