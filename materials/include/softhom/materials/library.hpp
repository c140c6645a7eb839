#pragma once
// Validated construction of materials from a description (what a scene file says), including the
// named parameter sets of spec §6. Every invalid parameter raises InputError naming the field.
#include <optional>
#include <string>
#include <vector>

#include "softhom/materials/laws.hpp"

namespace softhom {

enum class LawKind { gent_hgo, neo_hookean, yeoh, ogden };

/// A material as described in input. `field_prefix` is prepended to field names in error messages
/// (e.g. "material" or "phases.matrix").
struct MaterialSpec {
  std::string field_prefix = "material";
  std::string preset;  ///< name from spec §6, or empty
  LawKind law = LawKind::gent_hgo;
  GentHGOParams gent;
  NeoHookeanParams neo_hookean;
  YeohParams yeoh;
  OgdenParams ogden;
  std::optional<PronySeries> prony;
};

/// Names of the parameter sets of spec §6 ("ecoflex", "pdms", "glass", "ecoflex-anisotropic", ...).
std::vector<std::string> preset_names();
/// The spec filled from a named set (fibers empty: directions come from the scene). Throws InputError
/// on an unknown name.
MaterialSpec preset_spec(const std::string& name, const std::string& field_prefix = "material");

/// Checks every parameter (G > 0, Jm > 0, K > 0, k1 ≥ 0, k2 ≥ 0, |a0| > 0, 0 < g∞ ≤ 1, Σ g = 1, τ > 0,
/// Ogden sizes, ...) and throws InputError with "<prefix>.<field>" on the first violation.
void validate(const MaterialSpec& spec);
/// validate() then build.
MaterialPtr build_material(const MaterialSpec& spec);

}  // namespace softhom
