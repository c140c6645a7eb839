#pragma once
// The contact between deformable surfaces (fe::SurfaceContact) evaluated at a given pairing and state,
// and its tangent against central differences: shared by the frictionless and the friction tests.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "dense_sink.hpp"
#include "softhom/fe/surface_contact.hpp"

namespace softhom::test {

using namespace softhom::fe;

inline SurfaceContact::Options contact_options(double penalty, const std::string& field = "contact.pairs[0]") {
  SurfaceContact::Options o;
  o.penalty = penalty;
  o.shear_modulus = 1.0;
  o.field = field;
  return o;
}

/// The contact's history paired at u, every multiplier λ0 (so that the pressure's geometric term,
/// p ∂²g, weighs as much as the penalty's), and every stick anchor moved by (dξ, dη) from the closest
/// point (the step's and the reported anchor alike).
inline std::vector<double> paired_state(const SurfaceContact& c, const Mesh& m, const std::vector<double>& u,
                                        double lambda0, double dxi = 0.0, double deta = 0.0) {
  std::vector<double> s(std::size_t(c.state_size()), 0.0);
  c.init_state(s.data());
  Iterate it;
  it.u = &u;
  it.state_new = s.data();
  it.state_old = s.data();
  Couplings unused;
  c.pair(m, it, unused);
  for (int k = 0; k < c.num_points(); ++k) {
    double* p = s.data() + SurfaceContact::kStateSize * k;
    p[0] = p[1] = lambda0;
    p[SurfaceContact::kNextAnchor] += dxi;
    p[SurfaceContact::kNextAnchor + 1] += deta;
    p[SurfaceContact::kAnchor] = p[SurfaceContact::kNextAnchor];
    p[SurfaceContact::kAnchor + 1] = p[SurfaceContact::kNextAnchor + 1];
  }
  return s;
}

inline DenseSink assemble_contact(const SurfaceContact& c, const Mesh& m, const std::vector<double>& u,
                                  const std::vector<double>& state, bool tangent) {
  DenseSink sink(m.num_dofs(), tangent);
  std::vector<double> scratch(state);
  Iterate it;
  it.u = &u;
  it.state_old = state.data();
  it.state_new = scratch.data();
  EXPECT_EQ(c.assemble(m, it, sink), MaterialStatus::ok);
  return sink;
}

/// max |K − K_fd| / max |K| of the contact at u with the given state (central differences, step 1e-6).
inline double contact_tangent_error(const SurfaceContact& c, const Mesh& m, const std::vector<double>& u,
                                    const std::vector<double>& state, int* active = nullptr) {
  const DenseSink at = assemble_contact(c, m, u, state, true);
  const double h = 1e-6;
  // Only the surfaces' dofs enter the contact: the other columns are zero in both.
  std::vector<char> on_surface(m.num_nodes(), 0);
  for (const SurfaceContact::Face& f : c.faces())
    for (int a = 0; a < f.nodes_count; ++a) on_surface[f.nodes[a]] = 1;
  Eigen::MatrixXd fd = Eigen::MatrixXd::Zero(m.num_dofs(), m.num_dofs());
  for (int j = 0; j < m.num_dofs(); ++j) {
    if (!on_surface[j / 3]) continue;
    std::vector<double> up = u, um = u;
    up[j] += h;
    um[j] -= h;
    fd.col(j) = (assemble_contact(c, m, up, state, false).R - assemble_contact(c, m, um, state, false).R) / (2 * h);
  }
  if (active) *active = int((at.R.array().abs() > 0).count());
  return (at.K - fd).cwiseAbs().maxCoeff() / at.K.cwiseAbs().maxCoeff();
}

/// A displacement that presses the upper block `depth` into the lower one and bends both facing surfaces
/// (curved master faces, rotated normals): random nodal offsets of amplitude 0.01 near z = 1.
inline std::vector<double> pressed_and_wrinkled(const Mesh& m, double gap, double depth = 0.02) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> r(-0.01, 0.01);
  std::vector<double> u(m.num_dofs(), 0.0);
  for (int n = 0; n < m.num_nodes(); ++n) {
    const double z = m.nodes[n][2];
    if (z > 1.0 + 0.5 * gap) u[3 * n + 2] -= gap + depth;
    if (std::abs(z - 1.0) < 0.1 || std::abs(z - 1.0 - gap) < 0.1)
      for (int i = 0; i < 3; ++i) u[3 * n + i] += r(rng);
  }
  return u;
}

}  // namespace softhom::test
