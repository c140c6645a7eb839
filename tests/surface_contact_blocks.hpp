#pragma once
// Two stacked unit blocks in one mesh and their contact patch test, shared by the tests of
// fe::SurfaceContact on one process (tests/fe) and on two ranks (tests/mpi_macro).
#include <gtest/gtest.h>

#include <cstdio>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "softhom/fe/solver.hpp"
#include "softhom/fe/surface_contact.hpp"
#include "softhom/materials/laws.hpp"

namespace softhom::test {

using namespace softhom::fe;

/// Appends the box [0, 1]² × [z0, z0 + 1] of n × n × 1 hex8 to m.
inline void add_block(Mesh& m, int n, double z0, const Vec3& shift = Vec3::Zero()) {
  const int base = m.num_nodes();
  auto id = [&](int i, int j, int k) { return base + i + (n + 1) * (j + (n + 1) * k); };
  for (int k = 0; k <= 1; ++k)
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) m.nodes.push_back(Vec3(double(i) / n, double(j) / n, z0 + k) + shift);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i)
      m.hexes.push_back({id(i, j, 0), id(i + 1, j, 0), id(i + 1, j + 1, 0), id(i, j + 1, 0), id(i, j, 1),
                         id(i + 1, j, 1), id(i + 1, j + 1, 1), id(i, j + 1, 1)});
}

/// A lower block of nl × nl cells on z ∈ [0, 1] and an upper one of nu × nu on [1 + gap, 2 + gap]:
/// surfaces base (z = 0), lower_top, upper_bottom, press (the upper block's top), xmin, ymin.
inline Mesh two_blocks(int nl, int nu, double gap, bool tet10, const Vec3& shift = Vec3::Zero()) {
  Mesh m;
  add_block(m, nl, 0.0);
  add_block(m, nu, 1.0 + gap, shift);
  name_boundary_faces(m, [&](const Vec3& c, const Vec3& n) -> std::string {
    if (n[2] < -0.9) return c[2] < 0.5 ? "base" : "upper_bottom";
    if (n[2] > 0.9) return c[2] < 1.5 ? "lower_top" : "press";
    if (n[0] < -0.9) return "xmin";
    if (n[1] < -0.9) return "ymin";
    return "";
  });
  return tet10 ? hex_to_tet10(m) : m;
}

inline ContactSurface surface(const Mesh& m, const std::string& name) {
  ContactSurface s;
  if (m.surfaces.count(name)) s.quads = m.surfaces.at(name);
  s.tris = m.tri_surface(name);
  s.name = name;
  return s;
}

/// Holds component `comp` of the nodes of surface `name` on the path v.
inline void hold_surface(FeModel& model, const std::string& name, int comp, PiecewiseLinear v) {
  DirichletGroup g;
  for (int n : surface_nodes(model.mesh, name)) g.dofs.push_back(3 * n + comp);
  g.value = std::move(v);
  model.dirichlet.push_back(g);
}

struct Stack {
  std::vector<double> pressure;  ///< Cauchy contact pressure per slave face
  double applied = 0.0;          ///< −R_z / current area of the press face
  double normal_force = 0.0, reaction = 0.0, max_penetration = 0.0;
  int rebuilds = 0;
  double rebuild_time = 0.0;
};

/// Two stacked unit blocks (neo-Hookean G = 1, K = 20) on symmetry planes x = 0, y = 0 and a held base,
/// the upper block's top pushed down by 0.05 in 3 steps: a uniform uniaxial state whose traction
/// the contact must transmit. `self`: the two facing surfaces as one self-contact surface.
inline Stack stack(int n_lower, int n_upper, bool tet10, bool upper_is_slave, bool two_pass, bool self = false,
            SolverKind solver = SolverKind::cholmod,
            SurfaceContact::Options::Integration integration = SurfaceContact::Options::Integration::segments) {
  const Mesh m = two_blocks(n_lower, n_upper, 0.0, tet10);
  FeModel model;
  model.mesh = m;
  model.element_material.assign(m.num_elements(), make_material(make_neo_hookean({1.0, 20.0})));
  auto fix = [&](const std::string& name, int comp, PiecewiseLinear v) { hold_surface(model, name, comp, std::move(v)); };
  fix("xmin", 0, PiecewiseLinear::constant(0.0));
  fix("ymin", 1, PiecewiseLinear::constant(0.0));
  fix("base", 2, PiecewiseLinear::constant(0.0));
  fix("press", 2, PiecewiseLinear{{0.0, 1.0}, {0.0, -0.05}});
  SurfaceContact::Options o;
  o.shear_modulus = 1.0;
  o.field = "contact.pairs[0]";
  o.two_pass = two_pass;
  o.integration = integration;
  std::shared_ptr<SurfaceContact> c;
  if (self) {
    ContactSurface both = surface(m, "upper_bottom"), lower = surface(m, "lower_top");
    both.quads.insert(both.quads.end(), lower.quads.begin(), lower.quads.end());
    both.tris.insert(both.tris.end(), lower.tris.begin(), lower.tris.end());
    c = std::make_shared<SurfaceContact>(m, both, o);
  } else {
    const ContactSurface up = surface(m, "upper_bottom"), low = surface(m, "lower_top");
    c = std::make_shared<SurfaceContact>(m, upper_is_slave ? up : low, upper_is_slave ? low : up, o);
  }
  model.add(c);
  NewtonOptions newton;
  newton.solver = solver;
  newton.petsc_options = "-pc_type lu -pc_factor_mat_solver_type mumps";
  Simulation sim(model, newton);
  for (int s = 1; s <= 3; ++s) EXPECT_TRUE(sim.advance_to(s / 3.0).reached());
  Stack out;
  std::vector<int> top_z;
  for (int n : surface_nodes(m, "press")) top_z.push_back(3 * n + 2);
  out.reaction = sim.reaction(top_z);
  const std::vector<double>& u = sim.displacement();
  for (int n = 0; n < m.num_nodes(); ++n)
    if ((m.nodes[n] - Vec3(1, 1, 2)).norm() < 1e-12) out.applied = -out.reaction / ((1 + u[3 * n]) * (1 + u[3 * n + 1]));
  ContributionReport report;
  sim.report(report);
  for (const auto& [name, value] : report.probes) {
    if (name == "pair_normal_force [N]") out.normal_force = value;
    if (name == "pair_max_penetration [mm]") out.max_penetration = value;
  }
  for (const ReportField& f : report.fields)
    for (const ReportArray& a : f.arrays)
      if (a.name == "contact_pressure") out.pressure.insert(out.pressure.end(), a.values.begin(), a.values.end());
  out.rebuilds = sim.stats().pattern_rebuilds;
  out.rebuild_time = sim.stats().pattern_rebuild_time + sim.stats().linear.analysis;
  return out;
}

}  // namespace softhom::test
