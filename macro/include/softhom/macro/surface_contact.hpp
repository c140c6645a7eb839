#pragma once
// Contact between the structure's own surfaces ([[contact.pairs]] and [[contact.self]] of a macro scene,
// keys declared in surface_contact_keys.cpp): each pair or self-contact surface becomes one
// fe::SurfaceContact, with the penalty 100 G/h of fe/contact.hpp (G of the softer surface's elements)
// unless the scene gives one.
#include <string>
#include <vector>

#include "softhom/fe/model.hpp"
#include "softhom/fe/surface_contact.hpp"

namespace softhom::macro {

struct SurfacePairSpec {
  std::string slave, master;  ///< a pair's surfaces; a self-contact has its surface in `slave` alone
  bool self = false;
  double penalty = 0.0;       ///< ε [MPa/mm]; 0: 100 G/h per slave face
  double friction = 0.0;      ///< Coulomb coefficient μ ∈ [0, 3]
  double tangential_penalty = 0.0;  ///< ε_T [MPa/mm]; 0: ε / 10
  bool augmented = true;
  bool two_pass = false;      ///< a pair's master points against the slave faces too
  fe::SurfaceContact::Options::Integration integration = fe::SurfaceContact::Options::Integration::segments;
  std::string field;          ///< its TOML path, "contact.pairs[k]" or "contact.self[k]", for messages
};

/// One fe::SurfaceContact per spec, added to the model (after its materials are assigned). Throws
/// InputError naming <field>.slave / .master / .surface when a surface does not exist or has no faces.
void add_surface_contacts(const std::vector<SurfacePairSpec>& specs, fe::FeModel& model);

}  // namespace softhom::macro
