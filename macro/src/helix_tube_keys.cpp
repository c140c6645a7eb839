#include "helix_tube_keys.hpp"

namespace softhom::macro {

const keys::KeyTable<HelixTubeSpec>& helix_tube_table() {
  using O = HelixTubeSpec;
  static const keys::KeyTable<O> t = [] {
    keys::KeyTable<O> k("helix_tube",
                        "gmsh only, with geometry.geo: a tube whose wall holds one helical family of solid fibers "
                        "(studies/meshes/helix_tube.geo); the parameters are checked and passed to the .geo with "
                        "-setnumber. Physical volumes matrix, fibers, cap; surfaces inner, zmin, zmax, outer.");
    const keys::Range length = keys::left_open(0.0, 1e6);
    k.number("inner_radius", &O::inner_radius, length, "mm", "cavity radius R_i")
        .required()
        .number("wall_thickness", &O::wall_thickness, length, "mm", "wall thickness t (one layer of fibers)")
        .required()
        .number("length", &O::length, length, "mm", "wall length, from the open end z = 0 to the cap")
        .required()
        .number("cap_thickness", &O::cap_thickness, length, "mm", "end cap (physical volume \"cap\") at z = length")
        .required()
        .number("helix_angle_deg", &O::helix_angle_deg, keys::closed_range(0.0, 80.0), "deg",
                "fiber angle from the tube axis (right-handed helix)")
        .integer("fibers", &O::fibers, keys::closed_range(0, 1000), "",
                 "fibers around the tube, on the mid-wall radius (0: the tube without fibers)")
        .number("volume_fraction", &O::volume_fraction, keys::open_range(0.0, 0.5), "-",
                "fiber volume fraction of the wall; the fiber radius follows, r = sqrt(VF s t / pi) with the spacing "
                "s = 2 pi R_m cos(alpha) / fibers (instead of fiber_radius)")
        .number("fiber_radius", &O::fiber_radius, length, "mm", "fiber radius (instead of volume_fraction)")
        .number("fiber_mesh_size", &O::fiber_mesh_size, keys::at_least(0), "mm",
                "element size inside the fibers and within one fiber radius around them, growing to geometry.mesh_size "
                "over two more radii (0: geometry.mesh_size everywhere; thin fibers need it)");
    return k;
  }();
  return t;
}

HelixTubeSpec read_helix_tube(const toml::node& node) {
  HelixTubeSpec s;
  helix_tube_table().read(keys::read_table(node, "helix_tube"), "helix_tube", s);
  check_helix_tube(s);
  return s;
}

}  // namespace softhom::macro
