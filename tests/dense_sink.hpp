#pragma once
// A contribution's residual, tangent and border, dense over the mesh's dofs (the tests of
// contributions against central differences).
#include <Eigen/Dense>

#include "softhom/fe/contribution.hpp"

namespace softhom::test {

/// Everything a contribution adds, dense over the mesh's dofs.
class DenseSink final : public fe::AssemblySink {
 public:
  DenseSink(int ndof, bool tangent)
      : fe::AssemblySink(tangent), R(Eigen::VectorXd::Zero(ndof)), K(Eigen::MatrixXd::Zero(ndof, ndof)),
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

}  // namespace softhom::test
