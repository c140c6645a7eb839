#pragma once
// A capped tube (clamped at z = 0, free cap) with fibers tied to it, inflated by a follower pressure,
// and its middle's measures (away from the clamp and the cap): for tests/macro/test_fiber_tube.cpp
// and bench/fiber_tube.cpp.
#include <cmath>
#include <string>

#include "softhom/macro/structures.hpp"
#include "softhom/materials/laws.hpp"

namespace softhom::test {

struct FiberTubeCase {
  double inner_radius = 5.0, outer_radius = 5.5, length = 40.0, cap = 1.0;
  int radial_cells = 1, circumferential_cells = 24, axial_cells = 16;
  double G = 0.1, K = 100.0;  ///< neo-Hookean matrix [MPa]
  double angle_deg = 40.0;
  macro::FiberGeometry geometry = macro::FiberGeometry::double_helix;
  int count = 12;                           ///< fibers per family
  double fiber_modulus = 1e4, fiber_area = 0.05;  ///< near inextensible: E A / (G H spacing) ~ 4e3
  fe::FiberTie tie = fe::FiberTie::embedded;
  double pressure = 0.01;      ///< the end of the pressure ramp, or with volume_ratio > 0 the
  double volume_ratio = 0.0;   ///< end of the cavity-volume ramp V/V0 (cavity control) instead
  int substeps = 4;
  bool fibers = true;
  bool tet10 = false;
  fe::SolverKind solver = fe::SolverKind::cholmod;
  std::string petsc_options;
};

struct FiberTubeResult {
  bool reached = false;
  double axial_stretch_mid = 1.0;  ///< between the rings at L/4 and 3L/4
  double hoop_stretch_mid = 1.0;   ///< mid-wall radius at L/2 over its reference
  double twist_mid_deg = 0.0;      ///< rotation of the 3L/4 ring relative to the L/4 ring
  double axial_stretch_end = 1.0, twist_end_deg = 0.0;  ///< the structure's probes at the free end
  double pressure = 0.0, volume_ratio = 1.0;            ///< the cavity's at the end
  int fiber_elements = 0, newton_iterations = 0, free_dofs = 0;
  double seconds = 0.0;
};

inline macro::StructureSpec fiber_tube_spec(const FiberTubeCase& c) {
  macro::StructureSpec spec;
  spec.kind = macro::StructureKind::tube;
  spec.tube.inner_radius = c.inner_radius;
  spec.tube.outer_radius = c.outer_radius;
  spec.tube.length = c.length;
  spec.tube.radial_cells = c.radial_cells;
  spec.tube.circumferential_cells = c.circumferential_cells;
  spec.tube.axial_cells = c.axial_cells;
  spec.tube.sweep_deg = 360.0;
  spec.tube.cap_thickness = c.cap;
  spec.tet10 = c.tet10;
  spec.material = make_material(make_neo_hookean({c.G, c.K}));
  spec.control = c.volume_ratio > 0.0 ? macro::LoadControl::volume : macro::LoadControl::pressure;
  spec.load = c.volume_ratio > 0.0 ? PiecewiseLinear{{0.0, 1.0}, {1.0, c.volume_ratio}} : PiecewiseLinear{{0.0, 1.0}, {0.0, c.pressure}};
  if (c.fibers) {
    macro::FiberSpec f;
    f.geometry = c.geometry;
    f.angle_deg = c.angle_deg;
    f.count = c.count;
    f.options.law = {fe::FiberLawKind::linear, c.fiber_modulus, c.fiber_area, false};
    f.options.tie = c.tie;
    spec.fibers.push_back(f);
  }
  return spec;
}

/// Mean current z, radius and angle of the nodes of the ring Z = z (all radii).
struct Ring {
  double z = 0.0, Z = 0.0, r = 0.0, R = 0.0, turn = 0.0;
};
inline Ring ring(const fe::Mesh& mesh, const std::vector<Vec3>& x, double Z) {
  Ring out;
  int n = 0;
  for (int k = 0; k < mesh.num_nodes(); ++k) {
    const Vec3& X = mesh.nodes[k];
    const double R = std::hypot(X[0], X[1]);
    if (std::abs(X[2] - Z) > 1e-9 || R < 1e-9) continue;
    out.z += x[k][2];
    out.Z += X[2];
    out.r += std::hypot(x[k][0], x[k][1]);
    out.R += R;
    out.turn += std::remainder(std::atan2(x[k][1], x[k][0]) - std::atan2(X[1], X[0]), 2 * M_PI);
    ++n;
  }
  out.z /= n;
  out.Z /= n;
  out.r /= n;
  out.R /= n;
  out.turn /= n;
  return out;
}

inline FiberTubeResult inflate_fiber_tube(const FiberTubeCase& c) {
  const macro::Structure s = macro::build_structure(fiber_tube_spec(c));
  fe::NewtonOptions o;
  o.initial_substeps = c.substeps;
  o.solver = c.solver;
  o.petsc_options = c.petsc_options;
  fe::Simulation sim(s.model, o);
  FiberTubeResult r;
  r.free_dofs = sim.num_free_dofs();
  for (const auto& f : s.fibers) r.fiber_elements += f->num_elements();
  r.reached = sim.advance_to(1.0).reached();
  r.newton_iterations = sim.stats().newton_iterations;
  r.seconds = sim.stats().assembly_time + sim.stats().linear.factorization + sim.stats().linear.solve;
  const auto x = sim.current_positions();
  const Ring a = ring(s.model.mesh, x, 0.25 * c.length), m = ring(s.model.mesh, x, 0.5 * c.length),
             b = ring(s.model.mesh, x, 0.75 * c.length);
  r.axial_stretch_mid = (b.z - a.z) / (b.Z - a.Z);
  r.hoop_stretch_mid = m.r / m.R;
  r.twist_mid_deg = (b.turn - a.turn) * 180.0 / M_PI;
  const auto probes = macro::probe_values(s, sim);  // time, pressure, volume, inner_radius, stretch, axial_stretch, twist_deg
  r.pressure = probes[1];
  const fe::FeModel& model = s.model;  // the capped tube's cavity: mask (1, 1, 1)
  const double V0 = model.cavity ? fe::cavity_volume(model.mesh.nodes, model.cavity->faces, model.cavity->mask, model.cavity->tris)
                                 : fe::cavity_volume(model.mesh.nodes, model.pressures[0].faces, Vec3(1, 1, 1), model.pressures[0].tris);
  r.volume_ratio = probes[2] / V0;
  r.axial_stretch_end = probes[5];
  r.twist_end_deg = probes[6];
  return r;
}

}  // namespace softhom::test
