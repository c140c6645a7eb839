#pragma once
// Device outputs of imported-mesh scenes ([device] table): quantities of the dissertation's chapter-III
// devices computed from the mesh's physical surfaces at each output step (device.csv).
//
//   cpasmo  (§3.4, Fig. 12–13): maximum height of the top surface, the same maximum over the halves
//           θ < 45° and θ > 45° of the quarter model (equal by the diagonal symmetry of the device),
//           the channel volume, and the expansion of the wells of each radial region: the relative
//           change of a well's opening area π r̄² (r̄: mean distance of its rim nodes from their
//           centroid), averaged over the wells of the region.
//   gripper (§3.6, Fig. 17–18): the finger angle α of each fingertip surface (angle between the
//           vertical and the line from the finger's root centroid to its tip centroid, positive
//           towards the axis: closing; measured from the undeformed finger, so α = 0 at rest: the
//           root section has the channel's hole, so its nodal centroid is slightly off the tip's),
//           the channel volume and its change, and the smallest distance
//           of a fingertip node to the axis; the run stops before the fingers touch, when that
//           distance falls below stop_distance (fingers are not in contact in the model). With
//           rigid obstacles ([[contact.obstacles]], a held sample) also the grip force: the normal
//           force of each obstacle contact and the force of the sample on one finger (their sum over
//           the modelled fingers divided by the modelled share of the fingers: a fingertip cut by a
//           mirror plane counts half). Contacts between the fingers are modelled by symmetry: the
//           fingers are mirror images of each other in the planes through the axis between them, so a
//           finger touches its neighbour where it touches that plane (frictionless: mirror points do not
//           slip on each other); a rigid plane obstacle through the z axis is such a mirror plane, and
//           finger_contact_force_N is the mean force of those contacts (each the force between two
//           neighbouring fingers). The other contacts, rigid obstacles or pairs with a deformable sample
//           ([[contact.pairs]]), hold the sample: their normal forces and the grip force. A deformable
//           sample (sample_surface) adds its reach towards the fingers, the mean over the modelled
//           fingers of the largest x·e_k of its surface's nodes (e_k: finger k's radial direction; the
//           sample's radius at rest when it is centred on the axis), and its compression, the relative
//           decrease of that reach.
//   tube    a tube along z clamped at its lower end: axial and radial stretch of the gauge section,
//           twist of the free end (helix_tube.hpp, TubeGauge).
//   bending an actuator along z clamped at "zmin": end rotation (bending angle), chord angle and tip
//           displacement of its free end "zmax" (bending_gauge.hpp). Tube and bending also serve the
//           generated tube and actuator geometries, whose surfaces have these names.
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "softhom/fe/contact.hpp"
#include "softhom/fe/solver.hpp"
#include "softhom/macro/bending_gauge.hpp"
#include "softhom/macro/helix_tube.hpp"
#include "softhom/macro/structures.hpp"

namespace softhom::macro {

enum class DeviceKind { none, cpasmo, gripper, tube, bending };

struct DeviceSpec {
  DeviceKind kind = DeviceKind::none;
  // cpasmo
  std::string top_surface = "top";
  std::string well_prefix = "wells_region";  ///< surfaces <prefix>1 … <prefix><regions>: well side walls
  int regions = 7;
  // gripper
  std::vector<std::string> tips{"tip_0", "tip_120"};  ///< fingertip (top face) surfaces
  int fingers = 3;            ///< fingers equally spaced about the z axis (each tip's radial direction)
  double root_z = 0.0;        ///< height of the fingers' roots (the base's top) [mm]
  double stop_distance = 0.0;  ///< stop when a fingertip node comes this close to the axis [mm]
  std::string sample_surface;  ///< a held deformable sample's surface ("": none)
};

/// Node sets and reference measures of a device, built once from the structure.
class DeviceProbe {
 public:
  /// InputError naming device.<key> when a surface is missing from the mesh.
  DeviceProbe(const DeviceSpec& spec, const Structure& structure);

  /// device.csv header (units in the names).
  std::vector<std::string> columns() const;
  /// One row at the simulation's current state.
  std::vector<double> values(const fe::Simulation& sim) const;
  /// Non-empty when the run must stop after `row` (gripper: a fingertip node is within stop_distance
  /// of the axis, or the distance extrapolated linearly in the load value from `previous` to `next_time` would
  /// be: the step that would close the gap is not taken). `previous` may be null (first step).
  std::string stop_reason(const std::vector<double>& row, const std::vector<double>* previous, double next_time) const;
  const DeviceSpec& spec() const { return spec_; }

 private:
  struct Well {
    std::vector<int> rim;  ///< side-wall nodes on the top surface level
    double r0 = 0.0;       ///< reference mean rim radius
  };
  struct Finger {
    std::vector<int> tip, root;
    Vec3 radial = Vec3::Zero();  ///< unit radial direction of the finger (from the finger pitch)
    double angle0 = 0.0;         ///< reference angle of the root-to-tip line (nodal centroids: ≈ 0)
    double share = 1.0;          ///< the modelled part of the finger: 1/2 when a mirror plane cuts it
  };
  DeviceSpec spec_;
  const Structure* structure_;
  std::vector<int> top_;
  double top_z0_ = 0.0;
  std::vector<std::vector<Well>> regions_;
  std::vector<Finger> fingers_;
  std::shared_ptr<const TubeGauge> tube_;
  std::shared_ptr<const BendingGauge> bending_;
  /// Gripper: a contact's label (device.csv column stem) and its normal force at the converged state.
  struct GripContact {
    std::string label;
    const fe::Contribution* contribution = nullptr;
    bool between_fingers = false;  ///< a mirror plane through the axis: the contact of neighbouring fingers
  };
  std::vector<GripContact> contacts_;  ///< gripper: the contacts between fingers and with the held sample
  double volume0_ = 0.0;
  std::vector<int> sample_;  ///< gripper: the held sample's surface nodes
  double sample_reach0_ = 0.0;
  /// Gripper with a sample: the mean over the fingers of the largest x·e_k over the sample's nodes.
  double sample_reach(const std::vector<Vec3>& x) const;
  double channel_volume(const std::vector<Vec3>& x) const;
  /// Gripper: tip_axis_distance_mm's column (after t, pressure, the volumes and the angles).
  std::size_t distance_column() const { return 5 + fingers_.size(); }
  /// Gripper with contacts: each contact's normal force, then the mean force between neighbouring fingers
  /// (with mirror-plane contacts) and the grip force on one finger (with sample contacts) [N].
  std::vector<double> grip_forces(const fe::Simulation& sim) const;
};

}  // namespace softhom::macro
