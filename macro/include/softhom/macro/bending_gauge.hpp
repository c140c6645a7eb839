#pragma once
// The bending of an actuator along z clamped at its lower end ("zmin") and free at its upper end
// ("zmax", the end cap's face) that `[device] kind = "bending"` reports (devices.hpp):
//   end rotation (the bending angle θ of fiber-reinforced bending actuators, Polygerinos et al., IEEE
//     T-RO 31(3) 2015): the angle between the clamp's axis e_z and the free end's axis R e_z, R the
//     best-fit rotation of the "zmax" nodes (polar factor of Σ (x − x̄)(X − X̄)ᵀ: a rigid motion of the
//     end gives its rotation exactly). It reads θ in [0°, 180°]; beyond, it is 360° − that angle, told
//     apart by the chord angle (the chord of a circular arc turns by θ/2, so φ > 90° means θ > 180°);
//   chord angle φ (the dissertation's tip angle, Fig. 30/32): the angle between e_z and the line from
//     the clamp's centre to the free end's centre;
//   the free end's mean displacement.
#include <string>
#include <vector>

#include "softhom/fe/mesh.hpp"

namespace softhom::macro {

class BendingGauge {
 public:
  /// InputError on `field` when the mesh has no "zmin" or "zmax" surface.
  BendingGauge(const fe::Mesh& mesh, const std::string& field);
  static std::vector<std::string> columns();
  std::vector<double> values(const std::vector<Vec3>& X, const std::vector<Vec3>& x) const;

 private:
  std::vector<int> clamp_, end_;
};

/// The end rotation θ [deg] of the nodes `end` (see BendingGauge) about the reference axis e_z, with
/// the chord angle φ [deg] that tells θ beyond 180°.
double end_rotation_deg(const std::vector<int>& end, const std::vector<Vec3>& X, const std::vector<Vec3>& x,
                        double chord_angle_deg);

}  // namespace softhom::macro
