#include "device_keys.hpp"

#include "softhom/io/scene.hpp"

namespace softhom::macro {

const keys::KeyTable<DeviceSpec>& device_table() {
  using O = DeviceSpec;
  static const keys::KeyTable<O> t = [] {
    keys::KeyTable<O> k("device", "device outputs on the mesh's physical surfaces, written to device.csv (cpasmo: heights and well expansion by region; gripper: finger angle, contact forces, a held sample's compression, stop before the fingers touch; tube: axial and radial stretch, twist; bending: end rotation and tip displacement). Gmsh meshes; tube and bending also generated tubes and actuators.");
    k.choice("kind", &O::kind, {{"cpasmo", DeviceKind::cpasmo}, {"gripper", DeviceKind::gripper}, {"tube", DeviceKind::tube}, {"bending", DeviceKind::bending}},
             "which device's quantities (macro/devices.hpp)")
        .required()
        .text("top_surface", &O::top_surface, "cpasmo: the top surface whose rise is the height")
        .text("well_prefix", &O::well_prefix, "cpasmo: surfaces <prefix>1 … <prefix>N hold the side walls of the wells of regions 1 … N")
        .integer("regions", &O::regions, keys::closed_range(1, 1000), "", "cpasmo: number of well regions N")
        .custom(
            "tips", "list of strings", "gripper: the fingertip (top face) surfaces",
            [](const toml::node& n, const std::string& f, O& o) {
              const toml::array& a = keys::read_array(n, f);
              o.tips.clear();
              for (std::size_t i = 0; i < a.size(); ++i) o.tips.push_back(keys::read_text(*a.get(i), keys::index_field(f, i)));
              if (o.tips.empty()) throw InputError(f, "[]", "give at least one fingertip surface");
            },
            "[\"tip_0\", \"tip_120\"]")
        .integer("fingers", &O::fingers, keys::closed_range(1, 360), "", "gripper: fingers equally spaced about the z axis")
        .number("root_z", &O::root_z, keys::any_value(), "mm", "gripper: height of the fingers' roots (top of the base)")
        .number("stop_distance", &O::stop_distance, keys::at_least(0), "mm",
                "gripper: stop when a fingertip node is this close to the z axis (0: never)")
        .text("sample_surface", &O::sample_surface,
              "gripper: the surface of a held deformable sample (a Gmsh physical surface); adds its reach towards the fingers and its compression");
    return k;
  }();
  return t;
}

DeviceSpec read_device(const toml::node* node) {
  DeviceSpec d;
  if (node) device_table().read(keys::read_table(*node, "device"), "device", d);
  return d;
}

}  // namespace softhom::macro
