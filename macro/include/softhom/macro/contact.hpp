#pragma once
// Contact of a structure's surface with rigid obstacles ([[contact.obstacles]] of a macro scene, keys
// declared in contact_keys.cpp): each obstacle becomes one fe::ObstacleContact on the named surface
// (a built-in surface of a generated structure, "outer", "zmax", ..., or a Gmsh physical surface), with
// the penalty 100 G/h of fe/contact.hpp unless the scene gives one.
#include <string>
#include <vector>

#include "softhom/fe/contact.hpp"
#include "softhom/fe/model.hpp"
#include "softhom/fe/shell.hpp"
#include "softhom/macro/surface_contact.hpp"

namespace softhom::macro {

struct ObstacleSpec {
  fe::RigidObstacle obstacle;
  std::string surface;     ///< the body's surface that touches it
  double friction = 0.0;   ///< Coulomb coefficient μ
  double penalty = 0.0;    ///< ε_N = ε_T [MPa/mm]; 0: 100 G/h (fe::default_contact_penalty)
  bool augmented = true;   ///< the multiplier augmented once per converged step
  std::string field;       ///< its TOML path, "contact.obstacles[k]", for messages
};

struct ContactSpec {
  std::vector<ObstacleSpec> obstacles;
  std::vector<SurfacePairSpec> pairs;  ///< [[contact.pairs]] and [[contact.self]] (surface_contact.hpp)
};

/// The initial shear modulus of the elements that touch the faces' nodes (their mean), for the penalty.
double host_shear_modulus(const fe::FeModel& model, const std::vector<fe::Quad>& quads,
                          const std::vector<fe::Tri6>& tris);

/// The shell of a shell scene's model (its faces are a mid-surface's triangles), or null.
const fe::ShellDomain* shell_of(const fe::FeModel& model);

/// One fe::ObstacleContact per obstacle and one fe::SurfaceContact per pair or self-contact surface, added
/// to the model (after its materials are assigned). Throws
/// InputError naming <field>.surface when the surface does not exist in the mesh or has no faces.
void add_contacts(const ContactSpec& spec, fe::FeModel& model);

}  // namespace softhom::macro
