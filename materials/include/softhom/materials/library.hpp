#pragma once
// Validated construction of materials from a description (what a scene file says), including the
// named parameter sets of spec §6. Every invalid parameter raises InputError naming the field.
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "softhom/core/key_range.hpp"
#include "softhom/materials/laws.hpp"

namespace softhom {

enum class LawKind { gent_hgo, neo_hookean, yeoh, ogden, fiber_composite };

/// Laws whose material table takes [[fibers]] families (the spec's `gent` holds them).
inline bool has_fiber_families(LawKind k) { return k == LawKind::gent_hgo || k == LawKind::fiber_composite; }

/// The moduli the fiber-composite law adds to Gent + HGO (its Gent and HGO part is `gent`).
struct FiberShearModuli {
  double GL = 0.0;
  double GT = 0.0;
  double Ef = 0.0;
};

/// A material as described in input. `field_prefix` is prepended to field names in error messages
/// (e.g. "material" or "phases.matrix").
struct MaterialSpec {
  std::string field_prefix = "material";
  std::string preset;  ///< name from spec §6, or empty
  LawKind law = LawKind::gent_hgo;
  GentHGOParams gent;
  FiberShearModuli fiber_shear;  ///< fiber_composite only
  NeoHookeanParams neo_hookean;
  YeohParams yeoh;
  OgdenParams ogden;
  std::optional<PronySeries> prony;
};

/// One parameter of a constitutive law as a scene key of a material table.
struct LawParameter {
  std::string name;  ///< TOML key ("G")
  std::string unit;  ///< "MPa" or "-"
  keys::Range range;   ///< allowed values (each entry, for lists)
  std::string doc;
  bool list = false;  ///< one value per term (Ogden); a bare number is a list of one
  std::string default_text = "required (or from the preset)";
  /// Stores the value(s) into the spec; null when the law's `finish` combines it with others.
  std::function<void(MaterialSpec&, const std::vector<double>&)> set;
};

/// A constitutive law as the material tables know it: its `law = ` name and its parameters. The
/// material parser, its "not a parameter of this law" refusals and the key documentation all read
/// this table, so a new law is its kernel plus one entry here.
struct LawEntry {
  LawKind kind;
  std::string name;                  ///< law = "<name>"
  std::vector<std::string> aliases;  ///< other accepted spellings
  std::string display;               ///< in messages ("Gent-HGO")
  std::string doc;
  std::vector<LawParameter> parameters;
  /// Cross-parameter rules after every given parameter is stored (neo-Hookean: E and nu together,
  /// instead of mu and K); `given` holds the values read, `path` the table's TOML path.
  std::function<void(MaterialSpec&, const std::map<std::string, std::vector<double>>& given, const std::string& path)>
      finish;
};
const std::vector<LawEntry>& law_table();
const LawEntry& law_entry(LawKind kind);

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
