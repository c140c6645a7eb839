#pragma once
// The FE engine's side of an RVE scene ([solver] engine = "fe"): the generated section of
// [microstructure] and the FE [solver] keys (mesh and Newton settings), declared key by key.
#include <string>
#include <vector>

#include <toml++/toml.h>

#include "softhom/core/keys.hpp"
#include "softhom/rve/fe_mesh.hpp"
#include "softhom/rve/fe_solver.hpp"
#include "softhom/rve/geometry.hpp"

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

/// Key documentation of [solver] for engine = "fe".
keys::TableDoc fe_rve_solver_table();

/// Every table of an RVE scene: the common ones, [solver] of the FFT engine and of the FE engine.
std::vector<keys::TableDoc> rve_scene_tables();

}  // namespace softhom::studies
