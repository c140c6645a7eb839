// [[fibers]] of a structure tied to its mesh (fiber_geometry.hpp): the defaults a tube gives the
// helices (radius, extent, element length, tie surface) and the contribution added to the model.
#include <algorithm>
#include <cmath>
#include <memory>

#include "softhom/core/input_error.hpp"
#include "softhom/macro/fiber_geometry.hpp"
#include "softhom/macro/structures.hpp"

namespace softhom::macro {
namespace {

bool is_tube(const StructureSpec& spec) {
  return spec.kind == StructureKind::tube || spec.kind == StructureKind::actuator;
}

/// The smallest cell size of a generated structure along the fibers' way (tubes: axial and
/// circumferential at the fiber's radius; plates: any direction); imported meshes: 1 mm.
double default_element_length(const StructureSpec& spec, double radius) {
  if (is_tube(spec)) {
    const TubeSpec& t = spec.tube;
    const double hoop = spec.tube.sweep_deg * M_PI / 180.0 * radius / t.circumferential_cells;
    return std::min(t.length / t.axial_cells, hoop);
  }
  if (spec.kind == StructureKind::plate) {
    const Vec3& size = spec.plate.size;
    return std::min({size[0] / spec.plate.cells[0], size[1] / spec.plate.cells[1], size[2] / spec.plate.cells[2]});
  }
  return 1.0;
}

fe::FiberLines lines_of(const StructureSpec& spec, FiberSpec& f) {
  const std::string& field = f.options.field;
  double radius = f.radius, z_to = f.z_to;
  if (f.geometry != FiberGeometry::straight && f.geometry != FiberGeometry::gmsh) {
    if (is_tube(spec)) {
      const TubeSpec& t = spec.tube;
      if (t.sweep_deg < 360.0 - 1e-9)
        throw InputError(field + ".geometry", "helix", "needs a full tube (geometry.sweep_deg = 360): a helix breaks the quarter's symmetry");
      if (radius <= 0.0)
        radius = f.options.tie == fe::FiberTie::surface ? t.outer_radius : 0.5 * (t.inner_radius + t.outer_radius);
      if (z_to < 0.0) z_to = t.length;
    } else if (radius <= 0.0 || z_to < 0.0) {
      throw InputError(field + (radius <= 0.0 ? ".radius" : ".z_to"), "", "required for helices outside a generated tube");
    }
  }
  if (is_tube(spec) && f.options.tie == fe::FiberTie::surface && f.options.surface.empty()) f.options.surface = "outer";
  return fiber_lines(f, radius, z_to, default_element_length(spec, radius > 0.0 ? radius : 1.0));
}

/// The keys that place a fiber, for a message about a fiber that does not fit the mesh.
std::string placing_keys(const FiberSpec& f) {
  const std::string& k = f.options.field;
  if (f.geometry == FiberGeometry::straight) return k + ".from, " + k + ".to, " + k + ".spacing";
  if (f.geometry == FiberGeometry::gmsh)
    return k + ".group = \"" + f.group + "\" in " + (f.file.empty() ? "geometry's mesh" : f.options.field + ".file = \"" + f.file + "\"");
  return k + ".radius, " + k + ".z_from, " + k + ".z_to";
}

}  // namespace

void add_fibers(Structure& s) {
  for (FiberSpec f : s.spec.fibers) {
    const fe::FiberLines lines = lines_of(s.spec, f);
    std::shared_ptr<const fe::TiedFibers> fibers;
    try {
      fibers = std::make_shared<const fe::TiedFibers>(s.model.mesh, lines, f.options, s.model.element_material);
    } catch (const InputError& e) {
      if (e.field() != f.options.field) throw;  // a key of its own (area, surface, ...)
      throw InputError(e.field(), e.value(), std::string(e.what()).substr(e.field().size() + e.value().size() + 5) +
                                                 " (placed by " + placing_keys(f) + ")");
    }
    s.fibers.push_back(fibers);
    s.model.add(fibers);
  }
}

}  // namespace softhom::macro
