#pragma once
// Structure-scale problems assembled from a plain description (no file I/O): the generators of
// geometry.hpp, boundary conditions for each structure kind, fiber frames, loads and the probes
// reported in response.csv.
#include <array>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "softhom/fe/solver.hpp"
#include "softhom/macro/contact.hpp"
#include "softhom/macro/fiber_geometry.hpp"
#include "softhom/macro/geometry.hpp"
#include "softhom/macro/shell_structure.hpp"

namespace softhom::macro {

enum class StructureKind {
  plate,     ///< uniaxial tension along x: xmin u_x = 0, xmax u_x = (λ(t) − 1) L_x, rigid modes pinned
  tube,      ///< inflated tube; plane-strain ends (u_z = 0 at both ends) or clamped at z = 0 (capped)
  sphere,    ///< 1/8 sphere with symmetry planes, inflated
  actuator,  ///< capped two-material tube clamped at z = 0 (dissertation Fig. 30)
  imported,  ///< a mesh from outside (Gmsh) with constraints and loads on its named surfaces
  shell,     ///< a thin shell (shell_structure.hpp), pressurized or under cavity-volume control
};

/// Frame in which the material's fiber directions are given.
enum class FiberFrame {
  global,       ///< as given (plate)
  cylindrical,  ///< (hoop, axial, radial) per element: angle α from the tube axis
  spherical,    ///< (tangent, tangent, radial) per element
};

enum class LoadControl {
  stretch,   ///< plate: λ(t)
  pressure,  ///< follower pressure p(t) on the cavity surface
  volume,    ///< cavity volume V(t) = ratio(t) · V0, pressure is the unknown (passes limit points)
};

/// An imported mesh (io::read_gmsh by the caller: the macro library does no file I/O) and what acts on
/// its physical groups.
struct ImportedSpec {
  fe::Mesh mesh;
  std::string file;  ///< the .msh it was read from ([[fibers]] curve groups default to it)
  struct Fix {
    std::string surface;
    std::array<bool, 3> components{false, false, false};  ///< u_i = 0 on the surface's nodes
  };
  std::vector<Fix> fixed;
  std::vector<std::string> load_surfaces;  ///< follower pressure, or the cavity under volume control
  Vec3 cavity_mask{1.0, 1.0, 1.0};        ///< see fe::CavityControl
  std::string probe_surface;               ///< optional: its mean displacement is reported
  std::map<std::string, MaterialPtr> region_materials;  ///< by physical volume name (others: material)
};

struct StructureSpec {
  StructureKind kind = StructureKind::tube;
  PlateSpec plate;
  TubeSpec tube;
  SphereSpec sphere;
  ImportedSpec imported;
  ShellStructureSpec shell;
  bool tet10 = false;                 ///< split the generated hexes into 10-node tets (mid nodes on curved surfaces)
  bool plane_strain = false;          ///< tube without cap: u_z = 0 on both ends
  MaterialPtr material;               ///< region 0
  MaterialPtr material_region1;       ///< actuator's stiffer lower half (y < 0); defaults to material
  FiberFrame fiber_frame = FiberFrame::global;
  LoadControl control = LoadControl::pressure;
  PiecewiseLinear load;               ///< λ(t), p(t) [MPa] or V/V0(t)
  fe::Formulation formulation = fe::Formulation::fbar;
  /// The linear solver factorizes the tangent (CHOLMOD/UMFPACK); false: the PETSc Krylov path, whose
  /// memory estimate holds a multigrid hierarchy and a Krylov basis instead of a factor.
  bool factorized_solver = true;
  ContactSpec contact;                ///< rigid obstacles against the structure's surfaces
  std::vector<FiberSpec> fibers;      ///< [[fibers]]: fibers tied to the mesh (fiber_geometry.hpp)
};

struct Structure {
  fe::FeModel model;
  StructureSpec spec;
  std::vector<int> inner_nodes, end_nodes;  ///< probes: cavity wall; free end (tube zmax / plate xmax)
  std::vector<int> load_dofs;               ///< plate: x-dofs of xmax (reaction force)
  std::shared_ptr<const fe::ShellDomain> shell;  ///< shell structures: the shell contribution
  std::vector<std::shared_ptr<const fe::TiedFibers>> fibers;  ///< also among model.contributions
};

/// Builds mesh, materials (rotated into the fiber frame per element), constraints and loads.
Structure build_structure(const StructureSpec& spec);

/// Probe columns for a structure kind (time first).
std::vector<std::string> probe_names(const Structure& s);
/// Probe values at the current state of the simulation (same order as probe_names).
std::vector<double> probe_values(const Structure& s, const fe::Simulation& sim);

}  // namespace softhom::macro

namespace softhom::macro {

/// Memory a structure needs before any of it is built: its nodes and dofs from the cell counts (or
/// the imported mesh), the mesh and assembly data, and the sparse factorization's fill.
struct SizeEstimate {
  double nodes = 0.0, dofs = 0.0;  ///< dofs: 3 per node (constraints not subtracted)
  double mesh_bytes = 0.0;         ///< mesh, element data, stiffness pattern and work vectors
  double factor_bytes = 0.0;       ///< the factorization (Cholesky or LU fill); 0 on the Krylov path
  double krylov_bytes = 0.0;       ///< Krylov path: PETSc's matrix, multigrid hierarchy and GMRES basis
  double bytes() const { return mesh_bytes + factor_bytes + krylov_bytes; }
};
SizeEstimate estimate_size(const StructureSpec& spec);
/// The estimate of a mesh of `nodes` nodes (a mesh not yet made: a .geo at its mesh_size).
SizeEstimate estimate_size_of_nodes(double nodes, bool factorized_solver);


/// Throws InputError on `field` (the geometry key that sets the size, e.g. "geometry.cells") with the
/// estimate when the structure would not fit in `available_bytes` (0: unknown, nothing refused).
/// build_structure calls it with the available memory; a scene parser may call it earlier.
void refuse_if_too_large(const StructureSpec& spec, double available_bytes, const std::string& field);

/// The geometry key whose value sets a structure's size ("geometry.cells", "geometry.file", ...).
std::string size_field(const StructureSpec& spec);

}  // namespace softhom::macro
