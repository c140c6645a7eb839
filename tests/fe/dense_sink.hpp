#pragma once
// Everything a contribution adds through the AssemblySink, dense over the mesh's dofs (tests of
// contributions against central differences).
#include <vector>

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include "softhom/fe/contribution.hpp"

namespace softhom::test {

class DenseSink final : public fe::AssemblySink {
 public:
  DenseSink(int ndof, bool tangent)
      : AssemblySink(tangent), R(Eigen::VectorXd::Zero(ndof)), K(Eigen::MatrixXd::Zero(ndof, ndof)),
        a(Eigen::VectorXd::Zero(ndof)), g(Eigen::VectorXd::Zero(ndof)) {}
  void add_residual(int n, const int* dofs, const double* r) override {
    for (int i = 0; i < n; ++i) R[dofs[i]] += r[i];
  }
  void add_tangent(int nr, const int* rows, int nc, const int* cols, const double* k) override {
    for (int j = 0; j < nc; ++j)
      for (int i = 0; i < nr; ++i) K(rows[i], cols[j]) += k[i + nr * j];
  }
  void add_border(int n, const int* dofs, const double* dR, const double* dc) override {
    for (int i = 0; i < n; ++i) {
      a[dofs[i]] += dR[i];
      g[dofs[i]] += dc[i];
    }
  }
  void add_constraint_value(double v) override { c += v; }
  Eigen::VectorXd R;
  Eigen::MatrixXd K;
  Eigen::VectorXd a, g;
  double c = 0.0;
};

/// A contribution's residual (and with `tangent` its tangent) at displacement u, t = 0.
inline DenseSink evaluate_dense(const fe::Contribution& c, const fe::Mesh& mesh, const std::vector<double>& u, bool tangent) {
  DenseSink sink(mesh.num_dofs(), tangent);
  fe::Iterate it;
  it.u = &u;
  EXPECT_EQ(c.assemble(mesh, it, sink), MaterialStatus::ok);
  return sink;
}

/// ∂R/∂u by central differences of evaluate_dense's residual (step h).
inline Eigen::MatrixXd central_difference_tangent(const fe::Contribution& c, const fe::Mesh& mesh,
                                                  const std::vector<double>& u, double h) {
  Eigen::MatrixXd fd(mesh.num_dofs(), mesh.num_dofs());
  for (int j = 0; j < mesh.num_dofs(); ++j) {
    std::vector<double> up = u, um = u;
    up[j] += h;
    um[j] -= h;
    fd.col(j) = (evaluate_dense(c, mesh, up, false).R - evaluate_dense(c, mesh, um, false).R) / (2 * h);
  }
  return fd;
}

}  // namespace softhom::test
