#pragma once
// A tube whose wall holds one helical family of solid fibers (studies/meshes/helix_tube.geo): the
// parameters a scene's [helix_tube] table gives the .geo, checked before gmsh runs, and the tube's
// gauge quantities (axial stretch, radial stretch, twist) that `[device] kind = "tube"` reports.
//
// The fibers lie on the mid-wall radius R_m = R_i + t/2, n of them at helix angle α from the axis,
// one layer through the wall. Their spacing measured perpendicular to the fibers is
// s = 2π R_m cos α / n, so a fiber radius r gives the wall the fiber volume fraction
//   VF = n π r² / (2π R_m t cos α) = π r² / (s t),
// the square-array cell of side t × s (s = t: the chapter-IV cell, one fiber per t × t square).
#include <string>
#include <utility>
#include <vector>

#include "softhom/fe/mesh.hpp"
#include "softhom/materials/tensor.hpp"

namespace softhom::macro {

struct HelixTubeSpec {
  double inner_radius = 0.0;     ///< R_i [mm]
  double wall_thickness = 0.0;   ///< t [mm]
  double length = 0.0;           ///< wall length (the cap follows) [mm]
  double cap_thickness = 0.0;    ///< end cap at z = length [mm]
  double helix_angle_deg = 0.0;  ///< α from the tube axis
  int fibers = 0;                ///< n (0: the tube without fibers)
  double volume_fraction = 0.0;  ///< VF of the wall (gives the fiber radius), or
  double fiber_radius = 0.0;     ///< r [mm] directly (exactly one of the two when fibers > 0)
  double fiber_mesh_size = 0.0;  ///< element size in and near the fibers [mm] (0: the global size)
};

/// Fiber spacing s perpendicular to the fibers [mm].
double helix_fiber_spacing(const HelixTubeSpec& s);
/// The fiber radius: given, or from the volume fraction, r = sqrt(VF s t / π).
double helix_fiber_radius(const HelixTubeSpec& s);
/// The wall's fiber volume fraction π r² / (s t).
double helix_volume_fraction(const HelixTubeSpec& s);

/// InputError naming helix_tube.<key> when the tube cannot be built: α outside [0, 80]°, no fiber
/// size (or both), a fiber thicker than 0.8 t (it must leave matrix on both wall faces) or neighbours
/// closer than 0.2 s (their gap must hold elements).
void check_helix_tube(const HelixTubeSpec& s);

/// The .geo's -setnumber parameters (names as in helix_tube.geo's DefineConstant).
std::vector<std::pair<std::string, double>> helix_tube_geo_parameters(const HelixTubeSpec& s);

/// Gauge quantities of a tube along z clamped at its lower end, from its physical surfaces "inner"
/// (the cavity wall), "outer" and "zmax" (the free end's face). The wall spans the reference z range
/// [z0, z1] of "inner"; the gauge section is its middle half, away from the clamp and the cap:
///   axial stretch  = Δz̄ / ΔZ̄ between the "outer" nodes near z0 + L/4 and near z0 + 3L/4 (bands ±L/10),
///   radial stretch = mean r / mean R of the "outer" (and "inner") nodes in the gauge section,
///   twist          = rotation about z of the free end: atan2(Σ (X × x)_z, Σ X·x) over the "zmax"
///                    nodes' xy-components (a rigid rotation θ gives θ exactly), and the same between
///                    the two gauge bands,
///   end displacement = mean u_z of "zmax".
class TubeGauge {
 public:
  /// InputError on `field` when a surface is missing or the gauge bands hold no node.
  TubeGauge(const fe::Mesh& mesh, const std::string& field);
  static std::vector<std::string> columns();
  std::vector<double> values(const std::vector<Vec3>& X, const std::vector<Vec3>& x) const;

 private:
  std::vector<int> band_a_, band_b_, outer_, inner_, end_;
};

}  // namespace softhom::macro
