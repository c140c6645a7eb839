// Contact between the structure's surfaces (surface_contact.hpp): each pair or self-contact surface
// of a macro scene as an fe::SurfaceContact.
#include "softhom/macro/surface_contact.hpp"

#include <algorithm>
#include <memory>

#include "softhom/fe/surface_contact.hpp"
#include "softhom/macro/contact.hpp"
#include "softhom/materials/errors.hpp"

namespace softhom::macro {
namespace {

fe::ContactSurface named_surface(const fe::Mesh& mesh, const std::string& name, const std::string& field) {
  if (!mesh.has_surface(name)) throw InputError(field, "\"" + name + "\"", "no surface of that name in the mesh");
  fe::ContactSurface s;
  const auto quads = mesh.surfaces.find(name);
  if (quads != mesh.surfaces.end()) s.quads = quads->second;
  s.tris = mesh.tri_surface(name);
  s.name = name;
  if (s.quads.empty() && s.tris.empty()) throw InputError(field, "\"" + name + "\"", "the surface has no faces");
  return s;
}

}  // namespace

void add_surface_contacts(const std::vector<SurfacePairSpec>& specs, fe::FeModel& model) {
  const fe::Mesh& mesh = model.mesh;
  int pairs = 0, selves = 0;
  for (const SurfacePairSpec& s : specs) (s.self ? selves : pairs) += 1;
  int pair_index = 0, self_index = 0;
  for (const SurfacePairSpec& s : specs) {
    // A shell's faces are its mid-surface's triangles, which the pairs' closest-point projection does
    // not take (a triangle as a quad with a doubled node); obstacles do (macro/contact.hpp).
    if (shell_of(model))
      throw InputError(s.field, s.self ? "[[contact.self]]" : "[[contact.pairs]]",
                       "a shell scene's surfaces touch [[contact.obstacles]] only");
    fe::SurfaceContact::Options opt;
    opt.penalty = s.penalty;
    opt.friction = s.friction;
    opt.tangential_penalty = s.tangential_penalty;
    opt.augmented = s.augmented;
    opt.two_pass = s.two_pass;
    opt.integration = s.integration;
    opt.field = s.field;
    if (s.self) {
      opt.label = selves == 1 ? "contact_self" : "contact_self_" + std::to_string(self_index++);
      fe::ContactSurface surface = named_surface(mesh, s.slave, s.field + ".surface");
      opt.shear_modulus = host_shear_modulus(model, surface.quads, surface.tris);
      if (!(s.penalty > 0.0) && !(opt.shear_modulus > 0.0))
        throw InputError(s.field + ".penalty", "0", "no shear modulus on the surface to scale it by: give a penalty");
      model.add(std::make_shared<fe::SurfaceContact>(mesh, std::move(surface), opt));
      continue;
    }
    opt.label = pairs == 1 ? "contact_pair" : "contact_pair_" + std::to_string(pair_index++);
    fe::ContactSurface slave = named_surface(mesh, s.slave, s.field + ".slave");
    fe::ContactSurface master = named_surface(mesh, s.master, s.field + ".master");
    // The softer side's modulus: its penetration stays (p/G) h/100 of its own compliance.
    opt.shear_modulus = std::min(host_shear_modulus(model, slave.quads, slave.tris),
                                 host_shear_modulus(model, master.quads, master.tris));
    if (!(s.penalty > 0.0) && !(opt.shear_modulus > 0.0))
      throw InputError(s.field + ".penalty", "0", "no shear modulus on the surfaces to scale it by: give a penalty");
    model.add(std::make_shared<fe::SurfaceContact>(mesh, std::move(slave), std::move(master), opt));
  }
}

}  // namespace softhom::macro
