// The embedding facade: material batch evaluation (= the point driver), one RVE cell at a macro F̄
// with its homogenized consistent tangent ∂P̄/∂F̄ (against central finite differences of re-solved
// cells), major symmetry for a hyperelastic cell, mixed control, commit / rollback of the state.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "softhom/materials/batch.hpp"
#include "softhom/materials/driver.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/studies/cell.hpp"

using namespace softhom;
using namespace softhom::studies;

namespace {

// A 2D section cell (n3 = 1, full 3D kinematics): one circular glass fiber (VF 0.23) in an elastic
// Gent matrix with one HGO fiber family, fiber axis at 30°. K/G = 30 keeps the matrix compressible
// enough that the mixed-pressure iteration is off and round-off does not limit the FD quotients.
std::string section_scene(const std::string& matrix_extra = "", int n = 16, double tolerance = 1e-12) {
  return R"(
[microstructure]
shape = "circle"
arrangement = "square"
volume_fraction = 0.23
radius = 0.2
fiber_angle_deg = 30
grid = [)" + std::to_string(n) + ", " + std::to_string(n) + R"(]

[phases.matrix]
law = "gent"
G = 0.65
Jm = 5.0
K = 20.0
fiber_invariant = "full"
)" + matrix_extra + R"(
[phases.fiber]
preset = "glass"

[solver]
discretization = "rotated"
tolerance = )" + format_number(tolerance) + R"(
fftw = "estimate"
)";
}

const std::string kHgoFamily = R"(
[[phases.matrix.fibers]]
direction = [0.0, 1.0, 0.0]
k1 = 0.8
k2 = 2.0
)";
const std::string kQlv = R"(
[phases.matrix.viscoelastic]
g_inf = 0.5
tau = 1.0
)";

Vec9 mat_to_flat(const Mat3& M) {
  Vec9 v;
  for (int c = 0; c < 9; ++c) v[c] = M(c / 3, c % 3);
  return v;
}

/// Central differences of P̄(F̄) at F̄, every solve from the cell's committed state with the same dt.
Mat9 fd_tangent(Cell& cell, const Mat3& F, double dt, double h) {
  Mat9 C;
  for (int b = 0; b < 9; ++b) {
    Mat3 dF = Mat3::Zero();
    dF(b / 3, b % 3) = h;
    const CellResult plus = cell.solve(F + dF, dt, false);
    const CellResult minus = cell.solve(F - dF, dt, false);
    EXPECT_TRUE(plus.converged && minus.converged) << plus.error << minus.error;
    C.col(b) = (mat_to_flat(plus.P) - mat_to_flat(minus.P)) / (2.0 * h);
  }
  return C;
}

// A stretched and sheared macro state: fibers (matrix family along e2 and glass at 30°) in tension,
// away from the HGO tension-only switch at I4 = 1.
/// The FD comparisons resolve 1e-8 |C̄|: tangent solves to 1e-10 (the default 1e-6 gives ≈ 1e-7).
CellOptions tight() {
  CellOptions o;
  o.tangent_tolerance = 1e-10;
  return o;
}

Mat3 test_F() {
  Mat3 F;
  F << 1.12, 0.05, 0.02,
       0.03, 1.06, -0.01,
       0.00, 0.02, 0.95;
  return F;
}

}  // namespace

// ---------------------------------------------------------------------------------------------------
// Material batch evaluation.

// The batch of a QLV Gent-HGO law equals the material-point driver along a fully prescribed path
// (same law from the same TOML, same steps): the driver's only work is then the law's update, so P
// agrees to round-off (1e-12 relative), and the batch tangent is the law's own (FD of the batch P at
// h = 1e-6: truncation O(h² P''') ≈ 1e-11, round-off ε |P| / h ≈ 1e-10 relative → 1e-6).
TEST(MaterialBatch, EqualsPointDriverAlongQlvPath) {
  const std::string toml = R"(
[material]
preset = "ecoflex-anisotropic"
fiber_invariant = "full"
[[material.fibers]]
angle_deg = 30.0
[material.viscoelastic]
g_inf = 0.4
tau = 2.0
)";
  const MaterialBatch batch = MaterialBatch::from_toml(toml);
  ASSERT_GT(batch.state_size(), 0);
  Mat3 F_end;
  F_end << 1.6, 0.1, 0.0, 0.05, 0.9, 0.02, 0.0, -0.03, 0.8;
  const int steps = 8;
  MixedControl control;
  for (int c = 0; c < 9; ++c) {
    control.kind[c] = ControlKind::deformation;
    control.value[c] = PiecewiseLinear{{0.0, 4.0}, {c % 4 == 0 ? 1.0 : 0.0, F_end(c / 3, c % 3)}};
  }
  for (int s = 1; s <= steps; ++s) control.times.push_back(4.0 * s / steps);
  const PointRunResult point = run_material_point(batch.material(), control);
  ASSERT_TRUE(point.completed) << point.error;
  ASSERT_EQ(point.steps.size(), std::size_t(steps + 1));

  // Three points per call (the same F at each, so every point must give the driver's answer).
  const std::size_t n = 3;
  std::vector<double> state = batch.initial_state(n), state_new, P, A;
  for (int s = 1; s <= steps; ++s) {
    const Mat3& F = point.steps[s].F;
    std::vector<double> Fv(9 * n);
    for (std::size_t k = 0; k < n; ++k)
      for (int c = 0; c < 9; ++c) Fv[9 * k + c] = F(c / 3, c % 3);
    const BatchStatus st = batch.evaluate(Fv, state, 4.0 / steps, P, &A, state_new);
    ASSERT_TRUE(st.ok());
    for (std::size_t k = 0; k < n; ++k) {
      Mat3 Pk;
      for (int c = 0; c < 9; ++c) Pk(c / 3, c % 3) = P[9 * k + c];
      EXPECT_LT((Pk - point.steps[s].P).norm(), 1e-12 * point.steps[s].P.norm()) << "step " << s << " point " << k;
    }
    if (s == steps / 2) {  // tangent of the batch = FD of the batch (same state_old, same dt)
      const double h = 1e-6;
      std::vector<double> Pp, Pm, sn;
      Mat9 fd;
      for (int b = 0; b < 9; ++b) {
        std::vector<double> Fp(Fv.begin(), Fv.begin() + 9), Fm = Fp, s1(state.begin(), state.begin() + batch.state_size());
        Fp[b] += h;
        Fm[b] -= h;
        batch.evaluate(Fp, s1, 4.0 / steps, Pp, nullptr, sn);
        batch.evaluate(Fm, s1, 4.0 / steps, Pm, nullptr, sn);
        for (int a = 0; a < 9; ++a) fd(a, b) = (Pp[a] - Pm[a]) / (2 * h);
      }
      const Mat9 An = Eigen::Map<const Eigen::Matrix<double, 9, 9, Eigen::RowMajor>>(A.data());
      EXPECT_LT((An - fd).norm(), 1e-6 * An.norm());
    }
    state.swap(state_new);  // commit
  }
}

// A failed point is reported (index, status) and zeroed; its state is left as it was.
TEST(MaterialBatch, ReportsFailedPoints) {
  const MaterialBatch batch = MaterialBatch::from_toml("law = \"gent\"\nG = 0.1\nJm = 1.0\nK = 10.0\n", "");
  std::vector<double> F = {1, 0, 0, 0, 1, 0, 0, 0, 1,  3.0, 0, 0, 0, 1, 0, 0, 0, 1,  1, 0, 0, 0, 1, 0, 0, 0, -1};
  std::vector<double> P, A, s0, s1;
  const BatchStatus st = batch.evaluate(F, s0, 0.0, P, &A, s1);
  EXPECT_EQ(st.failed_points, 2u);
  EXPECT_EQ(st.first_failed_point, 1);
  EXPECT_EQ(st.first_status, MaterialStatus::locking);
  for (int c = 0; c < 9; ++c) EXPECT_EQ(P[9 + c], 0.0);
}

// The scene's declarations and their refusals: the error names the field as a scene file would.
TEST(MaterialBatch, BadInputNamesTheField) {
  try {
    MaterialBatch::from_toml("[phases.matrix]\nlaw = \"gent\"\nG = -1.0\nJm = 5.0\nK = 10.0\n", "phases.matrix");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "phases.matrix.G") << e.what();
  }
  EXPECT_THROW(MaterialBatch::from_toml("[material]\nlaw = \"gent\"\nG = 1.0\nJm = 5.0\nK = 10.0\nbogus = 1\n"), InputError);
  EXPECT_THROW(MaterialBatch::from_toml("preset = \"ecoflex\"\n"), InputError);  // no [material]
  EXPECT_THROW(MaterialBatch::from_toml("[material\n"), InputError);             // TOML syntax
}

// ---------------------------------------------------------------------------------------------------
// One RVE cell.

// The homogenized tangent of a hyperelastic section cell (Gent-HGO matrix + glass fiber, composite
// voxels on the laminate rule) against central differences of re-solved cells, and its major
// symmetry (C̄ = ∂²W̄/∂F̄∂F̄ of the averaged energy).
// Tolerances (relative to the Frobenius norm |C̄| ≈ 53 MPa, dominated by the bulk entries): the Newton
// tolerance 1e-12 (relative to |P̄| ≈ 2 MPa) bounds the P̄ error by ≈ 2e-12 MPa, ≈ 2e-12 / h = 2e-8 MPa
// = 4e-10 |C̄| in a quotient at h = 1e-4; the FD truncation h² |P̄'''| / 6 dominates: measured 9.0e-9
// |C̄| at h = 1e-4 and 3.6e-8 at h = 2e-4 (the factor 4 of O(h²)); each tangent solve to 1e-10 adds
// ≲ 1e-10 |C̄|. 2e-7 |C̄| is 20× the measured difference and still 10³ below a 1 % error in a shear
// entry (≈ 0.8 MPa).
// Symmetry: the tangent's asymmetry is that of its linear solves (measured 1e-12); the FD quotients'
// asymmetry is their error (measured 6e-10).
TEST(RveCell, TangentMatchesFiniteDifferencesAndIsSymmetric) {
  Cell cell(section_scene(kHgoFamily), "cell", tight());
  EXPECT_FALSE(cell.has_history());
  const Mat3 F = test_F();
  const CellResult r = cell.solve(F, 0.0, true);
  ASSERT_TRUE(r.converged) << r.error;
  EXPECT_GT(r.tangent_krylov_iterations, 0);
  const Mat9 fd = fd_tangent(cell, F, 0.0, 1e-4);
  const double scale = r.tangent.norm();
  EXPECT_LT((r.tangent - fd).norm(), 2e-7 * scale) << "tangent\n" << r.tangent << "\nFD\n" << fd;
  // Major symmetry of the solver's tangent (linear solves to 1e-10) and of the FD quotients (their
  // error above).
  EXPECT_LT((r.tangent - r.tangent.transpose()).norm(), 1e-8 * scale);
  EXPECT_LT((fd - fd.transpose()).norm(), 2e-8 * scale);
}

// Nearly incompressible matrix (pdms preset, K/G = 3000): the Newton iteration is the mixed (u, p) one,
// whose stored tangents carry the linearized-pressure correction (p − W_V′(J)) ∂cof/∂F; at convergence
// it vanishes and C̄ must still be the derivative of P̄. Isochoric macro state (J̄ = 1). Round-off: the
// Newton floor 64 ε K / |P̄| ≈ 3e-11 bounds P̄ errors by ≈ 1e-10 MPa, 1e-6 MPa in a quotient at h = 1e-4,
// against |C̄| ≈ 5e3 MPa (bulk entries): the truncation error dominates again; asserted 2e-7 |C̄|.
TEST(RveCell, NearlyIncompressibleMatrixTangentMatchesFiniteDifferences) {
  std::string scene = section_scene("", 12);
  scene.replace(scene.find("law = \"gent\""), std::string("law = \"gent\"\nG = 0.65\nJm = 5.0\nK = 20.0").size(),
                "preset = \"pdms\"");
  Cell cell(scene, "cell", tight());
  Mat3 F = Mat3::Identity();
  F(0, 0) = 1.1;
  F(1, 1) = F(2, 2) = 1.0 / std::sqrt(1.1);
  F(0, 1) = 0.02;
  const CellResult r = cell.solve(F, 0.0, true);
  ASSERT_TRUE(r.converged) << r.error;
  const Mat9 fd = fd_tangent(cell, F, 0.0, 1e-4);
  EXPECT_LT((r.tangent - fd).norm(), 2e-7 * r.tangent.norm()) << "tangent\n" << r.tangent << "\nFD\n" << fd;
  // The shear block (not dominated by K) on its own scale.
  const double shear = std::abs(r.tangent(1, 1));
  EXPECT_NEAR(r.tangent(1, 1), fd(1, 1), 1e-5 * shear);
  EXPECT_NEAR(r.tangent(1, 3), fd(1, 3), 1e-5 * shear);
}

// QLV matrix: the tangent of the time-discrete cell map at a given dt, after a committed first step
// (so the history is non-trivial), against central differences re-solved from the committed state
// with the same dt. Same tolerance argument as the elastic cell (measured difference 4.3e-9 |C̄|).
TEST(RveCell, QlvTangentAtGivenDtMatchesFiniteDifferences) {
  Cell cell(section_scene(kQlv), "cell", tight());
  ASSERT_TRUE(cell.has_history());
  Mat3 F1 = Mat3::Identity();
  F1(0, 0) = 1.08;
  F1(0, 1) = 0.03;
  const CellResult r1 = cell.solve(F1, 0.5, false);
  ASSERT_TRUE(r1.converged) << r1.error;
  cell.commit();
  const Mat3 F2 = test_F();
  const double dt = 0.25;
  const CellResult r2 = cell.solve(F2, dt, true);
  ASSERT_TRUE(r2.converged) << r2.error;
  const Mat9 fd = fd_tangent(cell, F2, dt, 1e-4);
  EXPECT_LT((r2.tangent - fd).norm(), 2e-7 * r2.tangent.norm()) << "tangent\n" << r2.tangent << "\nFD\n" << fd;
  // The step's tangent is stiffer than the relaxed one: at a longer dt the same F gives a softer cell.
  const CellResult slow = cell.solve(F2, 50.0, true);
  ASSERT_TRUE(slow.converged) << slow.error;
  EXPECT_LT(slow.tangent(0, 0), r2.tangent(0, 0));
}

// Mixed control (uniaxial: F̄11 prescribed, the transverse stresses zero): the prescribed stresses are
// met to the Newton tolerance, a fully prescribed solve at the resulting F̄ gives the same P̄, and the
// mixed-control modulus dP̄11/dF̄11 from the static condensation of C̄ matches a central difference
// of mixed solves (measured relative difference 1.8e-8 at h = 1e-4, truncation O(h²); 2e-7 asserted).
TEST(RveCell, MixedControlSolveAndCondensedTangent) {
  Cell cell(section_scene(kHgoFamily), "cell", tight());
  const std::array<bool, 9> stress = {false, false, false, true, true, false, true, true, true};
  Mat3 Ft = Mat3::Identity();
  Ft(0, 0) = 1.1;
  const CellResult r = cell.solve_mixed(Ft, Mat3::Zero(), stress, 0.0, true);
  ASSERT_TRUE(r.converged) << r.error;
  const double Ps = r.P.norm();
  for (int c = 0; c < 9; ++c)
    if (stress[c]) {
      EXPECT_LT(std::abs(r.P(c / 3, c % 3)), 1e-10 * Ps) << c;
    }
  EXPECT_DOUBLE_EQ(r.F(0, 0), 1.1);
  EXPECT_GT(r.F(0, 0) - r.F(1, 1), 0.02);  // lateral contraction
  const CellResult full = cell.solve(r.F, 0.0, false);
  ASSERT_TRUE(full.converged) << full.error;
  EXPECT_LT((full.P - r.P).norm(), 1e-9 * Ps);

  // Condensation: prescribed set p (F), free set f (stress): dP_p = (C_pp − C_pf C_ff⁻¹ C_fp) dF_p.
  std::vector<int> p_idx, f_idx;
  for (int c = 0; c < 9; ++c) (stress[c] ? f_idx : p_idx).push_back(c);
  Eigen::MatrixXd Cff(f_idx.size(), f_idx.size()), Cfp(f_idx.size(), p_idx.size()), Cpf(p_idx.size(), f_idx.size()),
      Cpp(p_idx.size(), p_idx.size());
  for (std::size_t a = 0; a < f_idx.size(); ++a)
    for (std::size_t b = 0; b < f_idx.size(); ++b) Cff(a, b) = r.tangent(f_idx[a], f_idx[b]);
  for (std::size_t a = 0; a < f_idx.size(); ++a)
    for (std::size_t b = 0; b < p_idx.size(); ++b) {
      Cfp(a, b) = r.tangent(f_idx[a], p_idx[b]);
      Cpf(b, a) = r.tangent(p_idx[b], f_idx[a]);
    }
  for (std::size_t a = 0; a < p_idx.size(); ++a)
    for (std::size_t b = 0; b < p_idx.size(); ++b) Cpp(a, b) = r.tangent(p_idx[a], p_idx[b]);
  const Eigen::MatrixXd Cmixed = Cpp - Cpf * Cff.inverse() * Cfp;
  const double E_condensed = Cmixed(0, 0);  // p_idx[0] = 0: component 11
  const double h = 1e-4;
  Mat3 Fp = Ft, Fm = Ft;
  Fp(0, 0) += h;
  Fm(0, 0) -= h;
  const CellResult rp = cell.solve_mixed(Fp, Mat3::Zero(), stress, 0.0, false);
  const CellResult rm = cell.solve_mixed(Fm, Mat3::Zero(), stress, 0.0, false);
  ASSERT_TRUE(rp.converged && rm.converged);
  const double E_fd = (rp.P(0, 0) - rm.P(0, 0)) / (2 * h);
  EXPECT_NEAR(E_condensed, E_fd, 2e-7 * std::abs(E_fd));
  // Refused: both F̄12 and F̄21 free (a rigid rotation).
  std::array<bool, 9> rot{};
  rot[1] = rot[3] = true;
  EXPECT_THROW(cell.solve_mixed(Ft, Mat3::Zero(), rot, 0.0, false), InputError);
}

// Commit / rollback: solve() never moves the committed state; commit() does; restore() rolls back, and
// the same solve from the same state gives the same answer to the Newton tolerance.
TEST(RveCell, CommitAndRestoreState) {
  Cell cell(section_scene(kQlv, 12, 1e-10));
  Mat3 F1 = Mat3::Identity();
  F1(0, 0) = 1.1;
  const CellResult a = cell.solve(F1, 0.5, false);
  ASSERT_TRUE(a.converged) << a.error;
  EXPECT_TRUE(cell.state().solver.F.isIdentity());  // not committed
  const CellResult a2 = cell.solve(F1, 0.5, false);  // again from the committed state
  ASSERT_TRUE(a2.converged);
  EXPECT_LT((a2.P - a.P).norm(), 1e-8 * a.P.norm());
  cell.commit();
  EXPECT_THROW(cell.commit(), std::logic_error);
  EXPECT_EQ(cell.state().solver.F, a2.F);
  const CellState after_first = cell.state();
  // Hold: the stress relaxes at fixed F (QLV), from the committed history.
  const CellResult hold = cell.solve(F1, 1.0, false);
  ASSERT_TRUE(hold.converged);
  EXPECT_LT(hold.P(0, 0), a2.P(0, 0));
  // Roll back to the undeformed state and repeat the first step.
  cell.restore(cell.initial_state());
  const CellResult b = cell.solve(F1, 0.5, false);
  ASSERT_TRUE(b.converged);
  EXPECT_LT((b.P - a.P).norm(), 1e-8 * a.P.norm());
  // A state copied out and restored later continues identically.
  cell.restore(after_first);
  const CellResult hold2 = cell.solve(F1, 1.0, false);
  ASSERT_TRUE(hold2.converged);
  EXPECT_LT((hold2.P - hold.P).norm(), 1e-8 * hold.P.norm());
  // A state of another cell is refused by name.
  Cell other(section_scene(kQlv, 8, 1e-10));
  EXPECT_THROW(cell.restore(other.state()), InputError);
  EXPECT_THROW(cell.solve(F1, 0.0, false), InputError);  // history needs dt > 0
}

TEST(RveCell, BadSceneNamesTheField) {
  std::string scene = section_scene();
  scene.replace(scene.find("G = 0.65"), 8, "G = -0.65");
  try {
    Cell c(scene);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "phases.matrix.G") << e.what();
  }
  try {
    Cell c(section_scene() + "engine = \"fe\"\n");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "solver.engine") << e.what();
  }
  try {
    Cell c(section_scene() + "scheme = \"moulinec-suquet\"\n");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "solver.scheme") << e.what();
  }
  Cell ok(section_scene("", 8));
  Mat3 bad = Mat3::Identity();
  bad(2, 2) = -1.0;
  EXPECT_THROW(ok.solve(bad, 0.0), InputError);
}
