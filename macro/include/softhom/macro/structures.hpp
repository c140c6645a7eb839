#pragma once
// Structure-scale problems assembled from a plain description (no file I/O): the generators of
// geometry.hpp, boundary conditions for each structure kind, fiber frames, loads and the probes
// reported in response.csv.
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "softhom/fe/solver.hpp"
#include "softhom/macro/geometry.hpp"

namespace softhom::macro {

enum class StructureKind {
  plate,     ///< uniaxial tension along x: xmin u_x = 0, xmax u_x = (λ(t) − 1) L_x, rigid modes pinned
  tube,      ///< inflated tube; plane-strain ends (u_z = 0 at both ends) or clamped at z = 0 (capped)
  sphere,    ///< 1/8 sphere with symmetry planes, inflated
  actuator,  ///< capped two-material tube clamped at z = 0 (dissertation Fig. 30)
};

/// Frame in which the material's fiber directions are given.
enum class FiberFrame {
  global,       ///< as given (plate)
  cylindrical,  ///< (hoop, axial, radial) per element: angle α from the tube axis
  spherical,    ///< (tangent, tangent, radial) per element
};

enum class LoadControl {
  stretch,   ///< plate: λ(t)
  pressure,  ///< follower pressure p(t) on the cavity surface
  volume,    ///< cavity volume V(t) = ratio(t) · V0, pressure is the unknown (passes limit points)
};

struct StructureSpec {
  StructureKind kind = StructureKind::tube;
  PlateSpec plate;
  TubeSpec tube;
  SphereSpec sphere;
  bool plane_strain = false;          ///< tube without cap: u_z = 0 on both ends
  MaterialPtr material;               ///< region 0
  MaterialPtr material_region1;       ///< actuator's stiffer lower half (y < 0); defaults to material
  FiberFrame fiber_frame = FiberFrame::global;
  LoadControl control = LoadControl::pressure;
  PiecewiseLinear load;               ///< λ(t), p(t) [MPa] or V/V0(t)
  fe::Formulation formulation = fe::Formulation::fbar;
};

struct Structure {
  fe::FeModel model;
  StructureSpec spec;
  std::vector<int> inner_nodes, end_nodes;  ///< probes: cavity wall; free end (tube zmax / plate xmax)
  std::vector<int> load_dofs;               ///< plate: x-dofs of xmax (reaction force)
};

/// Builds mesh, materials (rotated into the fiber frame per element), constraints and loads.
Structure build_structure(const StructureSpec& spec);

/// Probe columns for a structure kind (time first).
std::vector<std::string> probe_names(const Structure& s);
/// Probe values at the current state of the simulation (same order as probe_names).
std::vector<double> probe_values(const Structure& s, const fe::Simulation& sim);

}  // namespace softhom::macro
