// Contact pairs of a macro scene (contact.hpp): each obstacle on its surface as an fe::ObstacleContact.
#include "softhom/macro/contact.hpp"

#include <memory>

#include "softhom/materials/errors.hpp"
#include "softhom/materials/shell_section.hpp"

namespace softhom::macro {

double host_shear_modulus(const fe::FeModel& model, const std::vector<fe::Quad>& quads,
                          const std::vector<fe::Tri6>& tris) {
  const fe::Mesh& mesh = model.mesh;
  std::vector<char> on_surface(mesh.num_nodes(), 0);
  for (const auto& q : quads)
    for (int n : q) on_surface[n] = 1;
  for (const auto& q : tris)
    for (int n : q) on_surface[n] = 1;
  double sum = 0.0;
  int count = 0;
  for (int e = 0; e < mesh.num_elements(); ++e) {
    const int* nodes = mesh.element_nodes(e);
    bool touches = false;
    for (int a = 0; a < mesh.element_size(e) && !touches; ++a) touches = on_surface[nodes[a]];
    if (!touches || !model.element_material[e]) continue;
    sum += model.element_material[e]->initial_shear_modulus();
    ++count;
  }
  return count ? sum / count : 0.0;
}

const fe::ShellDomain* shell_of(const fe::FeModel& model) {
  for (const auto& c : model.contributions)
    if (const auto* shell = dynamic_cast<const fe::ShellDomain*>(c.get())) return shell;
  return nullptr;
}

namespace {

/// A shell section's initial shear modulus: its layers' by thickness.
double section_shear_modulus(const ShellSection& section) {
  double sum = 0.0;
  for (const ShellLayer& layer : section.layers()) sum += layer.thickness * layer.law->initial_shear_modulus();
  return sum / section.thickness();
}

}  // namespace

void add_contacts(const ContactSpec& spec, fe::FeModel& model) {
  const fe::Mesh& mesh = model.mesh;
  // On a shell scene the faces are the mid-surface's triangles: the contact surface is the face half
  // the thickness towards the obstacle, and the penalty scales with the section's shear modulus.
  const fe::ShellDomain* shell = shell_of(model);
  for (std::size_t k = 0; k < spec.obstacles.size(); ++k) {
    const ObstacleSpec& o = spec.obstacles[k];
    if (!mesh.has_surface(o.surface))
      throw InputError(o.field + ".surface", "\"" + o.surface + "\"", "no surface of that name in the mesh");
    const auto quad_it = mesh.surfaces.find(o.surface);
    std::vector<fe::Quad> quads = quad_it != mesh.surfaces.end() ? quad_it->second : std::vector<fe::Quad>{};
    std::vector<fe::Tri6> tris = mesh.tri_surface(o.surface);
    if (quads.empty() && tris.empty())
      throw InputError(o.field + ".surface", "\"" + o.surface + "\"", "the surface has no faces");
    fe::ObstacleContact::Options opt;
    opt.law.penalty = opt.law.tangential_penalty = o.penalty;  // 0: 100 G/h per face
    opt.shear_modulus = shell ? section_shear_modulus(shell->section()) : host_shear_modulus(model, quads, tris);
    opt.offset = shell ? 0.5 * shell->section().thickness() : 0.0;
    if (!(o.penalty > 0.0) && !(opt.shear_modulus > 0.0))
      throw InputError(o.field + ".penalty", "0", "no shear modulus on the surface to scale it by: give a penalty");
    opt.law.friction = o.friction;
    opt.augmented = o.augmented;
    opt.field = o.field;
    opt.label = spec.obstacles.size() == 1 ? "contact" : "contact_" + std::to_string(k);
    model.add(std::make_shared<fe::ObstacleContact>(mesh, std::move(quads), std::move(tris), o.obstacle, opt));
  }
  add_surface_contacts(spec.pairs, model);
}

}  // namespace softhom::macro
