// The FE plate cell (make_plate: periodic along y1, the faces y2 = 0, L2 traction-free): a homogeneous
// plate is the law in plane stress (closed form of the incompressible neo-Hookean law), a sandwich of
// layers parallel to the faces is the plane-stress laminate (exact), the mean P̄_i3 vanishes (the
// divergence theorem on free faces), the homogenized stress converges under mesh refinement, and
// controls or sections a plate cannot take are refused.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "rve/rve_test_helpers.hpp"
#include "softhom/materials/driver.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/rve/fe_solver.hpp"

using namespace softhom;
using namespace softhom::rve;
using softhom::rve::testing::circle_spec;
using softhom::rve::testing::expect_steps_match_point;
using softhom::rve::testing::neo_hookean;
using softhom::rve::testing::preset;
using softhom::rve::testing::rel;

namespace {

/// A membrane control of the plate (load frame, normal e3): the in-plane F_ab (a, b ≤ 2) prescribed
/// to `F_end` (ramped from I) or free with P_ab = 0 where `free_ab`; F13, F23, F33 free with P = 0 (the
/// faces are traction-free), F31 = F32 = 0 (no tilt of the plate).
MixedControl plate_test_control(const Eigen::Matrix2d& F_end, const std::array<bool, 4>& free_ab, int steps) {
  MixedControl c;
  c.name = "plate membrane";
  for (int k = 0; k < 9; ++k) {
    const int i = k / 3, j = k % 3;
    const double start = i == j ? 1.0 : 0.0;
    const bool in_plane = i < 2 && j < 2;
    const bool stress = j == 2 || (in_plane && free_ab[2 * i + j]);
    c.kind[k] = stress ? ControlKind::stress : ControlKind::deformation;
    const double end = in_plane ? F_end(i, j) : start;
    c.value[k] = stress ? PiecewiseLinear::constant(0.0) : PiecewiseLinear{{0.0, 1.0}, {start, end}};
  }
  for (int s = 1; s <= steps; ++s) c.times.push_back(double(s) / steps);
  return c;
}

/// Uniaxial membrane tension along e1: F11 = λ, F12 = 0, F21 and F22 free.
MixedControl plate_test_uniaxial(double lambda, int steps) {
  Eigen::Matrix2d F;
  F << lambda, 0.0, 0.0, 1.0;
  return plate_test_control(F, {false, false, true, true}, steps);
}

SectionMesh plate_test_mesh(const Section& s, double mesh_size, double interface_size) {
  SectionMeshOptions o;
  o.mesh_size = mesh_size;
  o.interface_size = interface_size;
  SectionMesh m = mesh_section(s, o);
  make_plate(m);
  return m;
}

double normal_column_norm(const Mat3& P) { return P.col(2).norm(); }

}  // namespace

// Only the edges y1 = 0, L1 are paired: nodes on y2 = L2 keep their own degrees of freedom and the
// corner (L1, L2) maps to (0, L2); the pairing is exact (coordinates copied by the mesher).
TEST(FePlate, MeshPairsTheY1EdgesOnly) {
  const Section s = generate_section(circle_spec(0.23));
  SectionMesh m = plate_test_mesh(s, s.L1 / 6, s.L1 / 12);
  EXPECT_FALSE(m.periodic_y2);
  EXPECT_LT(verify_periodic_pairing(m), 1e-12);
  const double tol = 1e-9 * s.L1;
  int top = 0, right = 0;
  for (int i = 0; i < m.num_nodes(); ++i) {
    const Eigen::Vector2d p = m.nodes[i];
    const Eigen::Vector2d q = m.nodes[m.master[i]];
    if (std::abs(p.y() - s.L2) < tol && p.x() < s.L1 - tol) {
      EXPECT_EQ(m.master[i], i);
      ++top;
    }
    if (std::abs(p.x() - s.L1) < tol) {
      EXPECT_NEAR(q.x(), 0.0, tol);
      EXPECT_NEAR(q.y(), p.y(), tol);  // also at the corners: (L1, L2) → (0, L2)
      ++right;
    }
  }
  EXPECT_GT(top, 2);
  EXPECT_GT(right, 2);
}

// Fiber = matrix = a nearly incompressible neo-Hookean law (μ = 0.017, K = 2000: K/μ = 1.2e5, the mixed
// pressure path), α = 30° (grid and load frames differ). The plate is then the law in plane stress: the
// material point under the same control to the Newton tolerance (1e-10 → 1e-8 relative), and the
// incompressible closed form P11 = μ(λ − λ⁻²), F22 = F33 = λ^(−1/2) to O(μ/K) (measured 2e-6 on
// P11: 1e-4 allows 50x). F33 here is the section mean of F (the fluctuation carries it); P̄_i3 = 0.
TEST(FePlate, HomogeneousPlateIsThePlaneStressLaw) {
  const Section s = generate_section(circle_spec(0.23));
  const double mu = 0.017, lambda = 1.5;
  const MaterialPtr m = neo_hookean(mu, 2000.0);
  const MixedControl control = plate_test_uniaxial(lambda, 4);
  const PointRunResult point = run_material_point(*m, control);
  ASSERT_TRUE(point.completed) << point.error;
  FeSolverOptions o;
  o.tolerance = 1e-10;
  FeRveSolver solver(plate_test_mesh(s, s.L1 / 4, s.L1 / 8), m, m, 30.0, control.frame, o);
  const RveRunResult r = solver.run(control);
  ASSERT_TRUE(r.completed) << r.error;
  expect_steps_match_point(r, point, 1e-8);
  for (std::size_t k = 1; k < r.steps.size(); ++k) {
    EXPECT_LT(normal_column_norm(r.steps[k].P), 1e-8 * r.steps[k].P.norm()) << "step " << k;
  }
  const RveStep& last = r.steps.back();
  EXPECT_NEAR(last.P(0, 0) / (mu * (lambda - 1.0 / (lambda * lambda))), 1.0, 1e-4);
  EXPECT_NEAR(last.F(1, 1), 1.0 / std::sqrt(lambda), 1e-4);
  EXPECT_NEAR(last.F(2, 2), 1.0 / std::sqrt(lambda), 1e-4);
}

// A sandwich through the thickness: a stiff compressible layer (μ = 2, K = 10) between nearly
// incompressible ones (μ = 0.017, K = 2000), interfaces parallel to the free faces, a general in-plane
// F̄ (stretch, shear, rotation). Each layer is homogeneous in plane stress with its own thickness
// stretch (traction continuity across the interfaces and free faces both say P e3 = 0 in each layer),
// so P̄ = φ P_stiff + (1 − φ) P_soft and F̄33 = φ F33_stiff + (1 − φ) F33_soft exactly, with each layer's
// state that of its material point under the same control. P2 elements with edges on the interfaces
// represent it exactly: 1e-8 relative (Newton tolerance 1e-10).
TEST(FePlate, LayersParallelToTheFacesAreThePlaneStressLaminate) {
  Section s;
  s.L1 = 1.0;
  s.L2 = 0.5;
  FiberSection f;
  f.shape = SectionShape::rectangle;
  f.center = Eigen::Vector2d(0.5, 0.25);
  f.width = 1.0;
  f.height = 0.2;
  s.fibers.push_back(f);
  const double phi = 0.2 / 0.5;
  const MaterialPtr stiff = neo_hookean(2.0, 10.0), soft = neo_hookean(0.017, 2000.0);
  Eigen::Matrix2d F;
  F << 1.3, 0.15, -0.1, 0.85;
  const MixedControl control = plate_test_control(F, {false, false, false, false}, 4);
  const PointRunResult ps = run_material_point(*stiff, control), pm = run_material_point(*soft, control);
  ASSERT_TRUE(ps.completed && pm.completed);
  FeSolverOptions o;
  o.tolerance = 1e-10;
  SectionMesh mesh = plate_test_mesh(s, 0.2, 0.1);
  EXPECT_NEAR(mesh.area(1), phi * s.L1 * s.L2, 1e-14);
  FeRveSolver solver(std::move(mesh), soft, stiff, 30.0, control.frame, o);
  const RveRunResult r = solver.run(control);
  ASSERT_TRUE(r.completed) << r.error;
  const Mat3 P_exact = phi * ps.steps.back().P + (1 - phi) * pm.steps.back().P;
  const double F33_exact = phi * ps.steps.back().F(2, 2) + (1 - phi) * pm.steps.back().F(2, 2);
  EXPECT_LT(rel(r.steps.back().P, P_exact), 1e-8);
  EXPECT_NEAR(r.steps.back().F(2, 2), F33_exact, 1e-8);
  EXPECT_LT(rel(r.steps.back().P_fiber, ps.steps.back().P), 1e-8);
  EXPECT_LT(rel(r.steps.back().P_matrix, pm.steps.back().P), 1e-8);
  // The layers thin differently (the soft one nearly isochorically): a check that each has its own.
  EXPECT_GT(std::abs(ps.steps.back().F(2, 2) - pm.steps.back().F(2, 2)), 0.02);  // measured 0.040
}

// The chapter-IV Ecoflex/glass plate (circle, VF 0.23, α = 45°) in uniaxial membrane tension to
// λ = 1.3: P̄_i3 = 0 at convergence (the virtual displacement y2 e_i is in the discrete space, so the
// divergence theorem holds discretely: relative 1e-7 at the default tolerance 1e-8), and three meshes
// h = L/4, L/8, L/16 give an observed order of P̄11 above 2.5 (P2+bubble/P1; measured 3.5, the periodic
// cell's 3.3 in FeRve.MeshRefinementConvergesAtTheExpectedOrder), extrapolated error of the finest
// below 1e-4 (measured 5e-6). The same section with its y2 edges paired (the triply periodic cell under
// the same membrane control) gives the same P̄11 to 4e-6 (measured; required 1e-4): with the fiber at
// the cell's mid-plane the periodic solution is mirror-symmetric about it, so its interlayer shear
// tractions vanish and only a self-equilibrated normal traction along y1 is left to release.
TEST(FePlate, EcoflexPlateConvergesAndIsTractionFree) {
  const Section s = generate_section(circle_spec(0.23));
  const MaterialPtr matrix = preset("ecoflex"), glass = preset("glass");
  const MixedControl control = plate_test_uniaxial(1.3, 1);
  std::vector<double> h, p;
  for (double div : {4.0, 8.0, 16.0}) {
    SectionMesh mesh = plate_test_mesh(s, s.L1 / div, s.L1 / div);
    h.push_back(std::sqrt(s.L1 * s.L2 / mesh.num_elements()));
    FeRveSolver solver(std::move(mesh), matrix, glass, 45.0, control.frame);
    const RveRunResult r = solver.run(control);
    ASSERT_TRUE(r.completed) << r.error;
    EXPECT_LT(normal_column_norm(r.steps.back().P), 1e-7 * r.steps.back().P.norm());
    p.push_back(r.steps.back().P(0, 0));
  }
  const double order = std::log(std::abs(p[1] - p[0]) / std::abs(p[2] - p[1])) / std::log(h[1] / h[2]);
  const double p_inf = p[2] + (p[2] - p[1]) / (std::pow(h[1] / h[2], order) - 1.0);
  std::printf("FE plate refinement: P11 = %.8f %.8f %.8f (h = %.4f %.4f %.4f), order %.2f, extrapolated %.8f\n", p[0],
              p[1], p[2], h[0], h[1], h[2], order, p_inf);
  EXPECT_GT(order, 2.5);
  EXPECT_LT(std::abs(p[2] - p_inf) / p_inf, 1e-4);
  SectionMeshOptions o;
  o.mesh_size = o.interface_size = s.L1 / 8;
  FeRveSolver periodic(mesh_section(s, o), matrix, glass, 45.0, control.frame);
  const RveRunResult rp = periodic.run(control);
  ASSERT_TRUE(rp.completed) << rp.error;
  std::printf("periodic cell, same control: P11 = %.8f (plate / periodic %.4f)\n", rp.steps.back().P(0, 0),
              p[1] / rp.steps.back().P(0, 0));
  EXPECT_NEAR(p[1] / rp.steps.back().P(0, 0), 1.0, 1e-4);
}

// A prescribed normal stretch (the ordinary uniaxial control prescribes F13 = F23 = 0) cannot be
// imposed on free faces: refused naming the load; so is a plate whose fibers cut a face.
TEST(FePlate, RefusesControlsAndSectionsAPlateCannotTake) {
  const Section s = generate_section(circle_spec(0.23));
  const MixedControl uniaxial = softhom::rve::testing::uniaxial_ramp(1.2, 1);
  FeRveSolver solver(plate_test_mesh(s, s.L1 / 3, s.L1 / 3), preset("ecoflex"), preset("glass"), 45.0, uniaxial.frame);
  try {
    solver.run(uniaxial);
    FAIL() << "accepted a prescribed F13 on a plate";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("F13"), std::string::npos) << e.what();
  }
  EXPECT_NO_THROW(check_plate_section(s));
  const Section hex = generate_section(circle_spec(0.23, Arrangement::hexagonal));
  EXPECT_THROW(check_plate_section(hex), InputError);
}

// Stress control of a nearly incompressible cell (μ = 0.017, K = 2000; the closed tube's 2:1 membrane
// stress P22 = 2 P11 to μ/2, F11, F21, F22 free): the step's first Newton direction carries the jump of
// the stress targets and is taken whole, as a prescribed increment's is; cutting it to the Armijo
// condition (K (J − 1) at second order in the increment dominates the merit) stalled every step at
// 0.5 % of the residual per iteration (27 s and a cut-back per step before, 0.7 s now). Periodic cell
// and plate, both the homogeneous law's material point to 1e-8, with no cut-back.
TEST(FePlate, StressControlOfANearlyIncompressibleCellConverges) {
  const Section s = generate_section(circle_spec(0.23));
  const MaterialPtr m = neo_hookean(0.017, 2000.0);
  MixedControl c = plate_test_control(Eigen::Matrix2d::Identity(), {true, false, true, true}, 4);
  c.value[0] = PiecewiseLinear{{0.0, 1.0}, {0.0, 0.00425}};
  c.value[4] = PiecewiseLinear{{0.0, 1.0}, {0.0, 0.0085}};
  const PointRunResult point = run_material_point(*m, c);
  ASSERT_TRUE(point.completed) << point.error;
  for (bool plate : {false, true}) {
    SectionMeshOptions o;
    o.mesh_size = o.interface_size = s.L1 / 3;
    SectionMesh mesh = mesh_section(s, o);
    if (plate) make_plate(mesh);
    FeSolverOptions so;
    so.tolerance = 1e-10;
    FeRveSolver solver(std::move(mesh), m, m, 30.0, c.frame, so);
    const RveRunResult r = solver.run(c);
    ASSERT_TRUE(r.completed) << r.error;
    EXPECT_EQ(r.cutbacks, 0) << (plate ? "plate" : "periodic");
    expect_steps_match_point(r, point, 1e-8);
  }
}
