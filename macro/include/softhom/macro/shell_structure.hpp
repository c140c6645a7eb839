#pragma once
// Shell structures of the macro engine: a triangulated mid-surface (built-in or from Gmsh), its
// layered section (softhom/materials/shell_section.hpp), edge conditions, and a follower pressure or
// cavity-volume control on the whole surface (fe/shell.hpp for the element).
#include <memory>
#include <string>
#include <vector>

#include "softhom/fe/shell.hpp"
#include "softhom/macro/shell_geometry.hpp"

namespace softhom::macro {

enum class ShellShape {
  sphere,         ///< closed sphere (rigid motions held at three poles: see build_shell)
  sphere_octant,  ///< x, y, z ≥ 0 with symmetry edges x0, y0, z0
  cylinder,       ///< along z; sweep 90: quarter with symmetry edges theta0 (y = 0), theta1 (x = 0)
  strip,          ///< flat rectangle in the plane z = 0
  hemisphere,     ///< quarter hemisphere with a hole: symmetry edges x0, y0
  vault,          ///< quarter barrel vault (Scordelis–Lo roof): symmetry x0, y0, diaphragm xL
  gmsh,           ///< a triangle surface from a mesh file (its physical curves name the edges)
};

/// The condition of a named boundary edge: its displacements and its rotation (fe::ShellEdge).
struct ShellEdgeCondition {
  enum class Type { clamped, simply_supported, symmetry, free, diaphragm };
  std::string edge;
  Type type = Type::clamped;
  int normal = -1;  ///< symmetry: axis normal to the plane (0, 1, 2); −1: taken from the edge's name
};

struct ShellStructureSpec {
  ShellShape shape = ShellShape::sphere;
  double radius = 10.0, length = 10.0, width = 1.0;
  double sweep_deg = 360.0, hole_deg = 18.0, angle_deg = 40.0;
  int cells = 8, axial_cells = 8;
  ShellSurface imported;  ///< gmsh: the surface (read by the caller; the macro library does no file I/O)
  std::shared_ptr<const ShellSection> section;
  fe::ShellFrameRule frame;
  std::vector<ShellEdgeCondition> edges;  ///< beyond the shape's own symmetry edges; others are free
};

/// The shape's surface.
ShellSurface make_shell_surface(const ShellStructureSpec& spec);

/// The symmetry edges a built-in shape holds by itself, as conditions.
std::vector<ShellEdgeCondition> default_shell_edges(ShellShape shape, double sweep_deg);

/// Nodes of the surface (3 per triangle × triangles, before gluing) as a size estimate.
double shell_nodes_estimate(const ShellStructureSpec& spec);

}  // namespace softhom::macro

namespace softhom::macro {

struct Structure;
/// Builds a shell structure into s.model from s.spec.shell, s.spec.control and s.spec.load: the shell
/// contribution (s.shell), its edges' constraints and the load on the whole surface. Throws InputError
/// for edges the surface does not have, a cavity (volume control) on a surface open elsewhere than on
/// symmetry edges, or a closed sphere's cavity enclosing no volume.
void build_shell(Structure& s);

}  // namespace softhom::macro
