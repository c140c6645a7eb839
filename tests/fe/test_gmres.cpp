// softhom::krylov::gmres on small dense systems: exact convergence within n iterations, restarts,
// the preconditioner, the projected residual and the early stop of the monitor.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include <Eigen/Dense>

#include "softhom/core/krylov.hpp"

using namespace softhom;
using Vector = std::vector<double>;

namespace {

/// A nonsymmetric, well-conditioned test matrix: diagonally dominant with a skew part.
Eigen::MatrixXd test_matrix(int n) {
  Eigen::MatrixXd A(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) A(i, j) = (i == j ? 4.0 + i : 0.0) + 0.3 * std::sin(1.0 + i + 2.0 * j) + (j == i + 1 ? 1.0 : 0.0);
  return A;
}

Vector apply(const Eigen::MatrixXd& A, const Vector& x) {
  Vector y(A.rows(), 0.0);
  for (int i = 0; i < A.rows(); ++i)
    for (int j = 0; j < A.cols(); ++j) y[i] += A(i, j) * x[j];
  return y;
}

double residual(const Eigen::MatrixXd& A, const Vector& x, const Vector& b) {
  const Vector Ax = apply(A, x);
  double s = 0.0;
  for (std::size_t i = 0; i < b.size(); ++i) s += (b[i] - Ax[i]) * (b[i] - Ax[i]);
  return std::sqrt(s);
}

}  // namespace

TEST(Gmres, UnpreconditionedReachesTheToleranceWithoutRestart) {
  const int n = 12;
  const Eigen::MatrixXd A = test_matrix(n);
  Vector b(n);
  for (int i = 0; i < n; ++i) b[i] = 1.0 + 0.1 * i;
  Vector x;
  krylov::GmresWorkspace<Vector> ws;
  krylov::GmresOptions o;
  o.restart = n;
  o.max_iterations = n;
  o.tolerance = 1e-12;
  const double bn = krylov::GmresStdOps::norm(b);
  const auto r = krylov::gmres(b, bn, x, [&](const Vector& in, Vector& out) { out = apply(A, in); },
                               [](const Vector& in, Vector& out) { out = in; }, o, ws);
  ASSERT_TRUE(r.converged);
  EXPECT_LE(r.iterations, n) << "GMRES is exact after n iterations in exact arithmetic";
  // The reported residual is the true one (recomputed at the end of the cycle); 1e-12 relative asked.
  EXPECT_NEAR(r.residual, residual(A, x, b), 1e-13 * bn);
  EXPECT_LE(residual(A, x, b), 1.01e-12 * bn);
}

TEST(Gmres, RestartsAndAnExactPreconditionerConvergeInOneIteration) {
  const int n = 20;
  const Eigen::MatrixXd A = test_matrix(n);
  const Eigen::PartialPivLU<Eigen::MatrixXd> lu(A);
  Vector b(n, 1.0), x;
  krylov::GmresWorkspace<Vector> ws;
  krylov::GmresOptions o;
  o.tolerance = 1e-10;
  o.restart = 3;  // restarted GMRES(3) on a 20 × 20 system: several cycles
  o.max_iterations = 200;
  const double bn = krylov::GmresStdOps::norm(b);
  auto A_op = [&](const Vector& in, Vector& out) { out = apply(A, in); };
  const auto restarted = krylov::gmres(b, bn, x, A_op, [](const Vector& in, Vector& out) { out = in; }, o, ws);
  ASSERT_TRUE(restarted.converged);
  EXPECT_GT(restarted.iterations, 3) << "needs more than one cycle";
  EXPECT_LE(residual(A, x, b), 1.01e-10 * bn);
  // M = A: the preconditioned operator is the identity, one iteration solves it (to round-off).
  auto exact = [&](const Vector& in, Vector& out) {
    const Eigen::VectorXd z = lu.solve(Eigen::Map<const Eigen::VectorXd>(in.data(), n));
    out.assign(z.data(), z.data() + n);
  };
  const auto one = krylov::gmres(b, bn, x, A_op, exact, o, ws);
  ASSERT_TRUE(one.converged);
  EXPECT_EQ(one.iterations, 1);
  EXPECT_LE(residual(A, x, b), 1e-12 * bn);
}

TEST(Gmres, ProjectedResidualAndMonitorStop) {
  const int n = 10;
  const Eigen::MatrixXd A = test_matrix(n);
  Vector b(n, 1.0), x;
  krylov::GmresWorkspace<Vector> ws;
  krylov::GmresOptions o;
  o.tolerance = 1e-10;
  o.restart = n;
  o.max_iterations = n;
  const double bn = krylov::GmresStdOps::norm(b);
  auto A_op = [&](const Vector& in, Vector& out) { out = apply(A, in); };
  auto identity = [](const Vector& in, Vector& out) { out = in; };
  // P = 2 I: the projected least squares has the same minimizer, and ‖P r‖ = 2 ‖r‖ is what is reported.
  const auto p = krylov::gmres(b, 2.0 * bn, x, A_op, identity, o, ws, krylov::gmres_projection([](const Vector& in, Vector& out) {
                                 out = in;
                                 for (double& v : out) v *= 2.0;
                               }));
  ASSERT_TRUE(p.converged);
  EXPECT_NEAR(p.residual, 2.0 * residual(A, x, b), 1e-12 * bn);
  // A monitor that refuses to go on after 2 iterations ends the run there, unconverged.
  const auto stopped = krylov::gmres(b, bn, x, A_op, identity, o, ws, krylov::GmresNoProjection{},
                                     [](int its, double) { return its < 2; });
  EXPECT_FALSE(stopped.converged);
  EXPECT_EQ(stopped.iterations, 2);
}
