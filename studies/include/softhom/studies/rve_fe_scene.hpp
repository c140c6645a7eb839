#pragma once
// The FE engine's side of an RVE scene ([solver] engine = "fe"): the generated section of
// [microstructure] and the FE [solver] keys (mesh and Newton settings), declared key by key.
#include <memory>
#include <string>
#include <vector>

#include <toml++/toml.h>

#include "softhom/core/keys.hpp"
#include "softhom/rve/fe_mesh.hpp"
#include "softhom/rve/fe_solver.hpp"
#include "softhom/rve/geometry.hpp"
#include "softhom/studies/rve_scene.hpp"

namespace softhom::studies {

/// [microstructure] → generated section (the FE engine needs the exact geometry, not an image; `grid`
/// is the FFT resolution and ignored). `target_vf`: the requested fraction, `note`: one line.
rve::Section parse_fe_section(const toml::table& microstructure, double& target_vf, std::string& note);

/// Mesh and solver settings of the FE engine.
struct FeRveSettings {
  bool three_d = false;           ///< fe_mesh = "3d": periodic Tet10 cell mesh, else a T6 section mesh
  rve::SectionMeshOptions mesh;   ///< section mesh (sizes also used by the 3D mesher)
  rve::CellMeshOptions mesh3d;
  rve::FeSolverOptions solver;
};
/// [solver] for engine = "fe" (absent: defaults); `L1` is the cell side that sets the default sizes.
FeRveSettings parse_fe_rve_solver(const toml::table& scene, double L1);

/// [solver] engine of an RVE scene: "fft" (also without a [solver] table or key), "fe" or "auto"
/// (InputError naming solver.engine for anything else).
std::string rve_scene_engine(const toml::table& scene);

/// Everything an FE RVE run needs, parsed and validated from a scene table (not [output]): the run of
/// `softhom rve` with engine = "fe" and an FE case of `softhom sweep` read the scene through this.
struct FeRveSetup {
  RvePhases phases;
  rve::Section section;
  double target_vf = 0.0;
  std::string geometry_note;
  double fiber_angle_deg = 0.0;
  bool plate = false;  ///< [microstructure] cell = "plate": the section mesh's y2 faces free (rve::make_plate)
  FeRveSettings settings;
  MixedControl control;  ///< [load] (when parsed with_load)
};
FeRveSetup parse_fe_rve_setup(const toml::table& scene, bool with_load);

/// The FE cell's mesh: a section mesh (made a plate's when the setup says so) or a 3D cell mesh.
struct FeRveMesh {
  std::unique_ptr<rve::SectionMesh> section;
  std::unique_ptr<rve::CellMesh> cell;
};
/// Meshes the setup's cell: its section (a plate's when the setup says so) or its 3D cell.
FeRveMesh mesh_fe_rve(const FeRveSetup& setup);
/// The FE solver of the setup on its mesh (which it takes).
std::unique_ptr<rve::FeRveSolver> make_fe_rve_solver(FeRveMesh mesh, const FeRveSetup& setup);

/// Key documentation of [solver] for engine = "fe".
keys::TableDoc fe_rve_solver_table();

/// Every table of an RVE scene: the common ones, [solver] of the FFT engine and of the FE engine.
std::vector<keys::TableDoc> rve_scene_tables();

}  // namespace softhom::studies
