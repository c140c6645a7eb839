// Size estimate of a structure before it is built, and its refusal when the machine cannot hold it.
#include <cmath>
#include <string>

#include "softhom/macro/structures.hpp"
#include "softhom/materials/errors.hpp"

namespace softhom::macro {
namespace {

// Factorization fill per dof, measured with bench_macro --factor-once on the 3D tube: 1.1e6 dofs
// ≈ 16 GiB of CHOLMOD factor. Nested-dissection fill of a 3D mesh grows like n^(4/3), so below that
// size this overestimates a little and above it underestimates: a refusal is certain, an acceptance
// near the limit is not.
constexpr double kFactorBytesPerDof = 16.0 * 1024 * 1024 * 1024 / 1.1e6;
// Mesh, element geometry and history, the stiffness (~81 entries per column for hex8: values, row
// indices, transposed positions, CHOLMOD's copy of the upper triangle) and the Newton/GMRES vectors.
constexpr double kMeshBytesPerDof = 4096.0;
// The PETSc Krylov path instead of a factor: its copies of the tangent (the uncondensed AIJ matrix,
// the field split's displacement block and hypre's copy of it, ~80 entries per row for tet10), the
// multigrid hierarchy and the GMRES basis (8 bytes per dof and iteration, up to the restart of 200).
// Measured on the cPASMO scenes (tet10): 9.6–10 kB per dof of peak from 3e4 to 1.6e5 dofs, 8.1 kB at
// 1.22e6 dofs after 70 of the ~170 GMRES iterations of its first solve (BENCHMARKS.md, "Device scenes").
constexpr double kKrylovBytesPerDof = 6144.0;

double plate_nodes(const PlateSpec& p, bool tet10) {
  const int m = tet10 ? 2 : 1;  // tet10: a mid node on every edge (and the split's diagonals)
  return double(m * p.cells[0] + 1) * double(m * p.cells[1] + 1) * double(m * p.cells[2] + 1);
}

double tube_nodes(const TubeSpec& t, bool tet10) {
  const int m = tet10 ? 2 : 1;
  const double around = double(m * t.circumferential_cells) + (t.sweep_deg < 360.0 ? 1.0 : 0.0);
  double n = double(m * t.radial_cells + 1) * around * double(m * t.axial_cells + 1);
  if (t.cap_thickness > 0.0)  // the cap: a disk of the wall's and the core's cells, cap_axial_cells thick
    n += double(m * (t.radial_cells + t.cap_core_cells) + 1) * around * double(m * t.cap_axial_cells);
  return n;
}

double sphere_nodes(const SphereSpec& s, bool tet10) {
  const int m = tet10 ? 2 : 1;
  const double patch = double(m * s.patch_cells + 1);
  return 3.0 * patch * patch * double(m * s.radial_cells + 1);
}

std::string gib(double bytes) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.3g GiB", bytes / (1024.0 * 1024.0 * 1024.0));
  return buffer;
}

}  // namespace

SizeEstimate estimate_size_of_nodes(double nodes, bool factorized_solver) {
  SizeEstimate e;
  e.nodes = nodes;
  e.dofs = 3.0 * e.nodes;
  e.mesh_bytes = kMeshBytesPerDof * e.dofs;
  if (factorized_solver) e.factor_bytes = kFactorBytesPerDof * e.dofs;
  else e.krylov_bytes = kKrylovBytesPerDof * e.dofs;
  return e;
}

SizeEstimate estimate_size(const StructureSpec& spec) {
  double nodes = 0.0;
  switch (spec.kind) {
    case StructureKind::plate: nodes = plate_nodes(spec.plate, spec.tet10); break;
    case StructureKind::tube:
    case StructureKind::actuator: nodes = tube_nodes(spec.tube, spec.tet10); break;
    case StructureKind::sphere: nodes = sphere_nodes(spec.sphere, spec.tet10); break;
    case StructureKind::imported: nodes = double(spec.imported.mesh.num_nodes()); break;
    case StructureKind::shell: nodes = shell_nodes_estimate(spec.shell); break;
  }
  return estimate_size_of_nodes(nodes, spec.factorized_solver);
}

std::string size_field(const StructureSpec& spec) {
  switch (spec.kind) {
    case StructureKind::plate: return "geometry.cells";
    case StructureKind::tube:
    case StructureKind::actuator: return "geometry.circumferential_cells";
    case StructureKind::sphere: return "geometry.patch_cells";
    case StructureKind::imported: return "geometry.file";
    case StructureKind::shell: return spec.shell.shape == ShellShape::gmsh ? "geometry.file" : "geometry.cells";
  }
  return "geometry";
}

void refuse_if_too_large(const StructureSpec& spec, double available_bytes, const std::string& field) {
  if (!(available_bytes > 0.0)) return;
  const SizeEstimate e = estimate_size(spec);
  if (e.bytes() <= available_bytes) return;
  char dofs[32];
  std::snprintf(dofs, sizeof dofs, "%.3g", e.dofs);
  const std::string value = spec.kind == StructureKind::plate
                                ? "[" + std::to_string(spec.plate.cells[0]) + ", " + std::to_string(spec.plate.cells[1]) +
                                      ", " + std::to_string(spec.plate.cells[2]) + "]"
                                : "";
  throw InputError(field, value, "the structure is too large for this machine: " + std::string(dofs) + " dofs need about " +
                                  gib(e.bytes()) + " (mesh " + gib(e.mesh_bytes) +
                                  (spec.factorized_solver ? ", factorization " + gib(e.factor_bytes)
                                                          : ", PETSc matrix, multigrid and Krylov basis " + gib(e.krylov_bytes)) +
                                  ") but " + gib(available_bytes) + " are available; use fewer cells");
}

}  // namespace softhom::macro
