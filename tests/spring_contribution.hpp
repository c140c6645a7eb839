#pragma once
// A contribution written outside fe's driver, for the tests of the contribution seam: a linear spring
// of stiffness k between two nodes (all three components), r_a = k (u_a − u_b) = −r_b, as an interface.
// And the model it is tested on: two unit hex8 cubes held at every node, two further nodes in no element
// (free), the spring chain held node — n1 — n2 with stiffnesses k1, k2, and a force F along x on n2,
// so u_x(n1) = F / k1 and u_x(n2) = F / k1 + F / k2 in the first Newton step (the springs are linear).
#include <array>
#include <memory>
#include <string>

#include "softhom/fe/model.hpp"
#include "softhom/materials/laws.hpp"

namespace softhom::test {

class Spring final : public fe::Contribution {
 public:
  /// `declare`: whether it declares its couplings (without, its tangent has no place in the pattern).
  Spring(int a, int b, double k, bool declare = true) : nodes_{a, b}, k_(k), declare_(declare) {}
  Kind kind() const override { return Kind::interface; }
  std::string name() const override { return "spring"; }
  void declare_couplings(fe::Couplings& c) const override {
    if (declare_) c.add(nodes_.data(), 2);
  }
  MaterialStatus assemble(const fe::Mesh&, const fe::Iterate& it, fe::AssemblySink& sink) const override {
    std::array<int, 6> dofs;
    std::array<double, 6> r;
    for (int i = 0; i < 3; ++i) {
      dofs[i] = 3 * nodes_[0] + i;
      dofs[3 + i] = 3 * nodes_[1] + i;
      r[i] = k_ * ((*it.u)[dofs[i]] - (*it.u)[dofs[3 + i]]);
      r[3 + i] = -r[i];
    }
    sink.add_residual(6, dofs.data(), r.data());
    if (!sink.tangent()) return MaterialStatus::ok;
    std::array<double, 36> K{};  // column-major 6 × 6: [k I, −k I; −k I, k I]
    for (int i = 0; i < 3; ++i) {
      K[i + 6 * i] = K[(3 + i) + 6 * (3 + i)] = k_;
      K[(3 + i) + 6 * i] = K[i + 6 * (3 + i)] = -k_;
    }
    sink.add_tangent(6, dofs.data(), 6, dofs.data(), K.data());
    return MaterialStatus::ok;
  }
  /// Its tension k (u_b − u_a)·x as a probe "spring_<a>_<b>_force [N]" and a field on one segment.
  void report(const fe::Mesh& mesh, const fe::Iterate& it, fe::ContributionReport& out) const override {
    const std::string id = "spring_" + std::to_string(nodes_[0]) + "_" + std::to_string(nodes_[1]);
    const double force = k_ * ((*it.u)[3 * nodes_[1]] - (*it.u)[3 * nodes_[0]]);
    out.probes.emplace_back(id + "_force [N]", force);
    fe::ReportField f;
    f.cells = {id, fe::ReportCells::Type::line2, {mesh.nodes[nodes_[0]], mesh.nodes[nodes_[1]]}, {0, 1}};
    f.arrays.push_back({"force", "N", 1, true, {force}});
    out.fields.push_back(std::move(f));
  }

 private:
  std::array<int, 2> nodes_;
  double k_;
  bool declare_;
};

struct SpringChain {
  double k1 = 2.0, k2 = 0.5, force = 0.3;
  int n1 = 12, n2 = 13;
  fe::FeModel model;
  /// The closed-form x-displacements of n1 and n2 (springs in series from a held node).
  double u1() const { return force / k1; }
  double u2() const { return u1() + force / k2; }
};

inline SpringChain spring_chain(bool declare = true) {
  SpringChain c;
  fe::FeModel& m = c.model;
  for (int z = 0; z < 2; ++z)
    for (int y = 0; y < 2; ++y)
      for (int x = 0; x < 3; ++x) m.mesh.nodes.emplace_back(x, y, z);  // node x + 3 y + 6 z
  auto node = [](int x, int y, int z) { return x + 3 * y + 6 * z; };
  for (int x = 0; x < 2; ++x)
    m.mesh.hexes.push_back({node(x, 0, 0), node(x + 1, 0, 0), node(x + 1, 1, 0), node(x, 1, 0), node(x, 0, 1),
                            node(x + 1, 0, 1), node(x + 1, 1, 1), node(x, 1, 1)});
  m.mesh.nodes.emplace_back(3.0, 0.0, 0.0);  // n1, in no element
  m.mesh.nodes.emplace_back(4.0, 0.0, 0.0);  // n2
  m.element_material.assign(2, make_material(make_neo_hookean({1.0, 10.0})));
  fe::DirichletGroup held;
  for (int d = 0; d < 36; ++d) held.dofs.push_back(d);
  m.dirichlet.push_back(held);
  m.add(std::make_shared<Spring>(node(2, 0, 0), c.n1, c.k1, declare));
  m.add(std::make_shared<Spring>(c.n1, c.n2, c.k2, declare));
  m.nodal_loads.emplace_back(std::vector<int>{3 * c.n2}, std::vector<double>{c.force}, PiecewiseLinear{{0.0, 1.0}, {0.0, 1.0}});
  return c;
}

}  // namespace softhom::test
