#pragma once
// Fiber geometry of a structure ([[fibers]] tables): helices on a cylinder about the z axis (single, or
// double: the mirror family at −α from the same start angles), families of straight lines, and the
// polylines of a Gmsh physical curve group (read by the scene: the macro library does no file I/O), as
// polylines of fe::TiedFibers (fe/fibers.hpp), which ties them to the structure's mesh. Lengths in mm,
// angles in degrees from the tube axis (spec §7: a fiber at α lies along (sin α, cos α) in the
// (hoop, axial) frame).
#include <string>
#include <vector>

#include "softhom/fe/fibers.hpp"

namespace softhom::macro {

enum class FiberGeometry {
  helix,         ///< one family at +α
  double_helix,  ///< the families +α and −α, mirror images in every plane through the axis and a start angle
  straight,      ///< count parallel lines from `from` to `to`, the k-th shifted by k · spacing
  gmsh,          ///< the line elements of a physical curve group, each a fiber element (2- or 3-node as in the file)
};

struct FiberSpec {
  FiberGeometry geometry = FiberGeometry::double_helix;
  // Helices
  double angle_deg = 45.0;            ///< from the axis, in [0, 90); or from the pitch
  double pitch = 0.0;                 ///< axial advance per turn [mm] (> 0 replaces angle_deg)
  int count = 6;                      ///< fibers per family (start angles spread evenly over 360° when not given)
  std::vector<double> start_deg;      ///< start angles of the family's fibers at z = z_from [deg]
  double radius = 0.0;                ///< helix radius (0: the tube's outer radius for tie = surface, its mid-wall otherwise)
  double z_from = 0.0, z_to = -1.0;   ///< axial extent (z_to < 0: the tube's length)
  // Straight lines
  Vec3 from{0, 0, 0}, to{1, 0, 0}, spacing{0, 0, 0};
  /// Elements per fiber (0: about the host's smallest cell size long).
  int elements = 0;
  // Gmsh curve group
  std::string group;                  ///< physical curve group (name, or tag as text)
  std::string file;                   ///< .msh or .geo holding it (empty: the structure's own Gmsh mesh)
  double mesh_size = 0.0;             ///< a .geo's mesh size [mm]
  std::vector<std::vector<Vec3>> polylines;  ///< the group's chained lines, as read (options.order from the file)
  fe::FiberOptions options;           ///< law, area, order, tie, surface, volume correction
};

/// The helix angle from the pitch (or the angle itself when no pitch is given) [deg].
double helix_angle_deg(const FiberSpec& spec, double radius);

/// The polylines of one [[fibers]] table: each fiber's points (2 × elements + 1 for 3-node elements,
/// the middle points on the curve). `default_element_length` sets the elements when spec.elements = 0.
fe::FiberLines fiber_lines(const FiberSpec& spec, double radius, double z_to, double default_element_length);

struct Structure;
/// Ties the spec's [[fibers]] to the built structure (after its materials: the volume correction
/// reads the hosts'), each as a contribution of its model. Helices need a full tube (sweep 360).
void add_fibers(Structure& s);

}  // namespace softhom::macro
