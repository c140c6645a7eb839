#pragma once
// Gmsh mesh import (MSH file format version 4.1, ASCII or binary) into fe::Mesh. The file layer: the
// solver libraries keep the mesh types and do no file I/O.
//
// Read: $MeshFormat, $PhysicalNames, $Entities (entity tag → physical tags), $Nodes, $Elements; other
// sections are skipped. Volume elements: 4-node tetrahedra (type 4, promoted to tet10 with straight
// mid-edge nodes shared between neighbours), 10-node tetrahedra (11) and 8-node hexahedra (5).
// Boundary elements on surfaces that belong to a physical group: 3- and 6-node triangles (2, 9) and
// 4-node quadrilaterals (3); points and lines (15, 1, 8) are ignored.
//
// Mapping: every volume physical group is an element region (Mesh::region_names[id] is its name, or
// its tag as text when $PhysicalNames has none; elements of volumes without a physical group form the
// region ""). Every surface physical group is a named surface: each of its faces is matched to the
// face of a volume element with the same vertices and stored in that element's orientation, so
// normals point out of the solid. Tets are oriented positively; elements must have positive
// Jacobians at their Gauss points.
//
// Binary files (file-type 1, Mesh.Binary = 1): the same sections with ints, size_t (data-size 4 or 8
// bytes) and doubles in the writer's byte order, which the endianness marker (the int 1 after the
// header) tells; other byte orders are swapped. Lines in error messages are then the section's.
//
// Errors are InputError("FILE:LINE", token, problem): unsupported version, unknown or
// unsupported element type, reference to a missing node or entity, a face that is no element's
// face, an inverted element.
#include <array>
#include <filesystem>
#include <istream>
#include <map>
#include <string>
#include <vector>

#include "softhom/fe/mesh.hpp"

namespace softhom::io {

/// Parses MSH 4.1 text; `source` names the file in error messages. With `straighten_inverted`, a
/// quadratic tet whose curved edges give a non-positive Jacobian at a Gauss point (gmsh curving its
/// mid-edge nodes onto a surface of small radius, e.g. a thin fiber) gets straight edges instead of
/// being refused: its mid-edge nodes move to the edge midpoints, which its neighbours share (the
/// surface moves by O(h²/R) there); a tet whose corners are inverted is still refused.
fe::Mesh parse_gmsh(std::istream& in, const std::string& source, bool straighten_inverted = false);
/// Reads a .msh file through the checked opener (files.hpp, kMeshFile): a file that is no regular
/// file of at most 1 GiB is an InputError naming `field`, the scene key that names the file.
fe::Mesh read_gmsh(const std::filesystem::path& file, const std::string& field = "geometry.file",
                   bool straighten_inverted = false);

/// The line elements of one physical curve group (2-node lines, type 1, or 3-node lines, type 8) as
/// polylines: lines that share an end node are chained (a node where more or fewer than two lines meet
/// ends a chain; a closed loop is one chain), each chain's points in order along it, for 3-node lines
/// end, middle, end, middle, ..., end. The file may hold volumes too (the host mesh) or lines only.
struct GmshLineGroup {
  int nodes_per_line = 2;                         ///< 2 or 3 (one kind per group)
  std::vector<std::vector<Vec3>> polylines;       ///< in the order of the group's first lines in the file
};
/// InputError naming `group_field` when no physical curve group has that name (or tag), when the group
/// holds no line elements, or when it mixes 2- and 3-node lines; the file's own errors as read_gmsh's
/// (naming the file and line), the file's kind naming `file_field`.
GmshLineGroup parse_gmsh_line_group(std::istream& in, const std::string& source, const std::string& group,
                                    const std::string& group_field);
GmshLineGroup read_gmsh_line_group(const std::filesystem::path& file, const std::string& group,
                                   const std::string& group_field, const std::string& file_field);

/// A triangulated surface for shells (fe/shell.hpp): the triangles of chosen physical surfaces and the
/// physical curves as named edges. Volume elements in the file are ignored.
struct GmshSurface {
  std::vector<Vec3> nodes;                       ///< the nodes the triangles use, renumbered
  std::vector<std::array<int, 3>> triangles;     ///< in the file's orientation
  std::map<std::string, std::vector<int>> groups;  ///< physical surface name → its triangles
  /// Physical curve name → its segments (a 3-node line as its two halves) among the surface's nodes.
  std::map<std::string, std::vector<std::array<int, 2>>> curves;
  int split_quadratic = 0;  ///< 6-node triangles, each split into its four 3-node triangles (corner, corner, corner, middle)
};

/// Parses MSH 4.1 text into the triangles of the physical surfaces `groups` (all physical surfaces when
/// empty; every triangle when the file has none). A 6-node triangle becomes its four 3-node triangles on
/// its mid-edge nodes (the rotation-free shell takes its curvature from edge neighbours: the four
/// share the quadratic element's nodes). Throws InputError naming `groups_field` (its entry) for a group
/// the file lacks (listing those it has) or one holding no triangles, and for quadrangles.
GmshSurface parse_gmsh_surface(std::istream& in, const std::string& source, const std::vector<std::string>& groups,
                               const std::string& groups_field);
/// The same from a file read through the checked opener (`field` names the key of the file).
GmshSurface read_gmsh_surface(const std::filesystem::path& file, const std::vector<std::string>& groups,
                              const std::string& field, const std::string& groups_field);

}  // namespace softhom::io
