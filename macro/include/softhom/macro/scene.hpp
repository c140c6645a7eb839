#pragma once
// Macro scene files (`softhom macro SCENE.toml`) → a StructureSpec, the Newton options and the output
// times. Every key is declared once (macro_scene_tables(): type, default, range, unit, doc); unknown,
// renamed and mistyped keys, out-of-range numbers and unconstrained bodies are InputErrors naming the
// TOML path of the field.
//
//   [geometry] type = "tube" | "actuator" | "sphere" | "plate" | "gmsh" with the sizes and cell counts
//              of that type (geometry.hpp), elements = "hex8" | "tet10", fiber_frame
//   gmsh only: [[boundary]] surface, fix = ["x", "y", "z"]; [probe] surface; [regions.<volume>];
//              geometry.geo + mesh_size instead of geometry.file; [device] (devices.hpp)
//   [material] (+ [material_lower] for actuators), [load] control, path = [[t, v], ...], steps,
//   [solver]   tolerance, max_newton_iterations, max_krylov_iterations, max_cutbacks, substeps,
//              mixed_pressure, max_step_seconds, formulation, linear_solver, petsc_options, verbose
//   [output]   fields = true | false | [t1, t2, ...] (field snapshots at these load-path times)
#include <filesystem>
#include <vector>

#include <toml++/toml.h>

#include "softhom/fe/solver.hpp"
#include "softhom/core/keys.hpp"
#include "softhom/macro/devices.hpp"
#include "softhom/macro/structures.hpp"

namespace softhom::macro {

struct MacroScene {
  StructureSpec spec;
  fe::NewtonOptions newton;
  std::vector<double> times;        ///< output times (uniform steps, merged with the field times)
  bool fields = true;               ///< write field snapshots
  std::vector<double> field_times;  ///< snapshots only at these times (empty: at t = 0 and every output time)
  DeviceSpec device;                ///< [device]: device.csv quantities (kind none: no device)
  /// True when a snapshot is due at time t (an output time or 0).
  bool fields_at(double t) const;
};

/// Parses a macro scene; `scene_file` resolves a relative geometry.file / geometry.geo (gmsh), and a
/// geometry.geo is meshed into `mesh_cache` (empty: mesh_cache_dir(), mesh_generation.hpp).
MacroScene parse_macro_scene(const toml::table& scene, const std::filesystem::path& scene_file = {},
                             const std::filesystem::path& mesh_cache = {});

/// The declared tables of a macro scene, for `softhom keys macro` and docs/keys.md.
std::vector<keys::TableDoc> macro_scene_tables();

}  // namespace softhom::macro
