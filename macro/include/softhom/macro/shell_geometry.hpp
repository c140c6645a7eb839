#pragma once
// Triangulated mid-surfaces for shell structures (fe/shell.hpp), lengths in mm. Every generator
// orients its triangles (outward normals for closed and convex surfaces) and names its boundary edges
// so that scenes can hold them ("x0": the edges on the plane x = 0, ...).
#include <array>
#include <map>
#include <string>
#include <vector>

#include "softhom/fe/mesh.hpp"
#include "softhom/fe/shell.hpp"

namespace softhom::macro {

struct ShellSurface {
  fe::Mesh mesh;  ///< nodes only (the triangles are the shell's)
  std::vector<fe::Tri3> triangles;
  std::map<std::string, std::vector<std::array<int, 2>>> edges;  ///< named boundary edges (node pairs)
  std::map<std::string, std::vector<int>> groups;  ///< named sets of triangles, each with its own probes
  /// Nodes of the named boundary edges (sorted, unique); empty for an unknown name.
  std::vector<int> edge_nodes(const std::string& name) const;
};

/// Sphere of radius R about the origin: the whole closed surface (8 octants of n × n cells each, an
/// octahedron subdivided and projected), or the octant x, y, z ≥ 0 with edges x0, y0, z0.
ShellSurface make_shell_sphere(double radius, int n, bool octant);

/// Cylinder of radius R along z, 0 ≤ z ≤ length, angles [0, sweep_deg] (360: closed around; else edges
/// "theta0" at θ = 0 (the plane y = 0) and "theta1" at θ = sweep), with edges "z0" and "z1" at its ends.
ShellSurface make_shell_cylinder(double radius, double length, double sweep_deg, int n_around, int n_axial);

/// Flat rectangle [0, Lx] × [0, Ly] in the plane z = 0 (normal +z), edges xmin, xmax, ymin, ymax.
ShellSurface make_shell_strip(double lx, double ly, int nx, int ny);

/// Hemisphere z ≥ 0 of radius R with a hole of half-angle hole_deg about the z axis, quarter
/// x, y ≥ 0 (edges "x0", "y0", the free "hole" and the equator "z0"), n cells along each direction.
ShellSurface make_shell_hemisphere(double radius, double hole_deg, int n);

/// Barrel vault along x: radius R, length L, half opening angle phi_deg about the vertical z axis,
/// quarter x ≥ 0, y ≥ 0 of it (the Scordelis–Lo roof): edges "x0" and "y0" (symmetry), "xL" (the
/// diaphragm at x = L/2) and "free" (the straight edge), nx × ny cells.
ShellSurface make_shell_vault(double radius, double length, double phi_deg, int nx, int ny);

}  // namespace softhom::macro
