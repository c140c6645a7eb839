// The [[contact.pairs]] (two surfaces of the structure) and [[contact.self]] (one surface against itself)
// tables of macro scenes, declared once here.
#include "surface_contact_keys.hpp"

#include <string>

namespace softhom::macro {
namespace {

const char* const kPenaltyDoc = "penalty; 0: 100 G/h per slave face, G of the softer surface's elements (no tuning needed)";
const char* const kFrictionDoc =
    "Coulomb coefficient μ (0: frictionless): regularized stick (anchors convected with the master surface) and slip";
const char* const kTangentialPenaltyDoc =
    "stick penalty ε_T; 0: a tenth of the normal penalty, 10 G/h (elastic slip before sliding ≤ μ p h / 10 G)";
const char* const kAugmentedDoc = "augment the contact pressure once per converged step (false: pure penalty)";
const char* const kIntegrationDoc =
    "the slave faces' quadrature: \"segments\" cuts each face into its pieces over the master faces (a uniform "
    "pressure crosses between any meshes), \"points\" keeps the faces' Gauss points (exact only where the slave "
    "faces are the finer and nested in the master's)";

using Integration = fe::SurfaceContact::Options::Integration;

template <class Spec>
void add_integration(keys::KeyTable<Spec>& k) {
  k.choice("integration", static_cast<Integration Spec::*>(&SurfacePairSpec::integration),
           {{"segments", Integration::segments}, {"points", Integration::points}}, kIntegrationDoc);
}

/// A self-contact's keys, whose quadrature defaults to the Gauss points: on the gripper's fingers
/// pressing corner against corner (gripper_self_contact_coarse.toml) the segments left the mirror-
/// symmetric branch past 350 kPa, the points stay on it (docs/macro.md).
struct SelfContactSpec : SurfacePairSpec {
  SelfContactSpec() {
    self = true;
    integration = Integration::points;
  }
};

const keys::KeyTable<SurfacePairSpec>& pair_table() {
  using S = SurfacePairSpec;
  static const keys::KeyTable<S> t = [] {
    keys::KeyTable<S> k("contact.pairs[]",
                        "Contact between two deformable surfaces of the structure (fe/surface_contact.hpp): the slave "
                        "surface's quadrature points against the master's faces, paired at every step, penalty with "
                        "one augmentation per step and optional Coulomb friction. A uniform pressure crosses exactly between "
                        "non-matching meshes (integration = \"segments\").");
    k.text("slave", &S::slave, "surface whose quadrature points touch: a built-in name or a Gmsh physical surface")
        .required()
        .text("master", &S::master, "surface whose faces they touch")
        .required()
        .number("penalty", &S::penalty, keys::at_least(0), "MPa/mm", kPenaltyDoc)
        .number("friction", &S::friction, keys::closed_range(0, 3), "-", kFrictionDoc)
        .number("tangential_penalty", &S::tangential_penalty, keys::at_least(0), "MPa/mm", kTangentialPenaltyDoc)
        .flag("augmented", &S::augmented, kAugmentedDoc)
        .flag("two_pass", &S::two_pass, "also the master's points against the slave's faces, each pass weighted 1/2");
    add_integration(k);
    return k;
  }();
  return t;
}

const keys::KeyTable<SelfContactSpec>& self_table() {
  using S = SelfContactSpec;
  static const keys::KeyTable<S> t = [] {
    keys::KeyTable<S> k("contact.self[]",
                        "Self-contact of one surface (a wall folding onto itself, fingers touching): every point "
                        "against the surface's faces that face it, never its own face or one sharing a node with it; "
                        "two-pass, each point weighted 1/2.");
    k.text("surface", &S::slave, "the surface: a built-in name or a Gmsh physical surface (several bodies may share it)")
        .required()
        .number("penalty", &S::penalty, keys::at_least(0), "MPa/mm", kPenaltyDoc)
        .number("friction", &S::friction, keys::closed_range(0, 3), "-", kFrictionDoc)
        .number("tangential_penalty", &S::tangential_penalty, keys::at_least(0), "MPa/mm", kTangentialPenaltyDoc)
        .flag("augmented", &S::augmented, kAugmentedDoc);
    add_integration(k);
    return k;
  }();
  return t;
}

void read_list(const toml::table& contact, const char* key, bool self, std::vector<SurfacePairSpec>& out) {
  const toml::node* list = contact.get(key);
  if (!list) return;
  const std::string name = std::string("contact.") + key;
  const toml::array& arr = keys::read_array(*list, name);
  for (std::size_t i = 0; i < arr.size(); ++i) {
    const std::string field = keys::index_field(name, i);
    const toml::table& table = keys::read_table(*arr.get(i), field);
    if (self) {
      SelfContactSpec s;
      s.field = field;
      self_table().read(table, field, s);
      out.push_back(std::move(s));
    } else {
      SurfacePairSpec s;
      s.field = field;
      pair_table().read(table, field, s);
      out.push_back(std::move(s));
    }
  }
}

}  // namespace

std::vector<SurfacePairSpec> read_surface_contacts(const toml::table& contact) {
  std::vector<SurfacePairSpec> out;
  read_list(contact, "pairs", false, out);
  read_list(contact, "self", true, out);
  return out;
}

std::vector<keys::TableDoc> surface_contact_tables() { return {pair_table().describe(), self_table().describe()}; }

}  // namespace softhom::macro
