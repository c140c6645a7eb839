#pragma once
// The scene tables of the materials library, declared key by key (softhom/core/keys.hpp): material
// tables ([material], [phases.<name>] and their fibers / viscoelastic sub-tables), load tables
// ([load]) and the material-point solver ([solver] of `softhom point`). Every refusal is an
// InputError naming the TOML path ("material.G", "load.stretch[2][1]").
#include <string>
#include <vector>

#include <toml++/toml.h>

#include "softhom/core/keys.hpp"
#include "softhom/materials/driver.hpp"
#include "softhom/materials/library.hpp"
#include "softhom/materials/loading.hpp"

namespace softhom {

/// A material table (path: its TOML path, e.g. "material" or "phases.matrix"):
///   preset = "<spec §6 name>" and/or law = "gent" | "neo-hookean" | "yeoh" | "ogden", the law's
///   parameters (law_table()), k1, k2, kappa (defaults of the fiber families), fiber_invariant,
///   tension_only, [[<path>.fibers]] and [<path>.viscoelastic]. See docs/keys.md.
MaterialSpec parse_material(const toml::table& table, const std::string& path);

/// A load table: type = "uniaxial" | "equibiaxial" | "pure-shear" | "simple-shear" | "mixed", its path
/// (stretch / gamma / F and P with path), output steps (steps or dt). See docs/keys.md.
MixedControl parse_load(const toml::table& table, const std::string& path);

/// [solver] of `softhom point` (absent table: defaults).
PointSolverOptions parse_point_solver(const toml::node* solver, const std::string& path = "solver");

/// A `softhom point` scene: [material], [load], [solver] (and a description string).
struct PointScene {
  MaterialSpec material;
  MixedControl control;
  PointSolverOptions solver;
};
PointScene parse_point_scene(const toml::table& scene);

/// Key documentation: the material table at `path` with its sub-tables and one table per law.
std::vector<keys::TableDoc> material_tables(const std::string& path);
std::vector<keys::TableDoc> load_tables(const std::string& path);
keys::TableDoc point_solver_table();
/// Every table of a point scene (for `softhom keys point`).
std::vector<keys::TableDoc> point_scene_tables();

/// The most output steps a load path may have: each is a converged solve and a row of the response
/// table, so 1e6 is already hours of solves and a response.csv of hundreds of MB; finer resolution
/// belongs in the solver's sub-steps (cut-backs), which are not output.
inline constexpr double kMaxOutputSteps = 1e6;

}  // namespace softhom
