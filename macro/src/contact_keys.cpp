// The [contact] table of macro scenes: [[contact.obstacles]], each a rigid plane, sphere or cylinder
// on a surface of the structure, declared once here.
#include "contact_keys.hpp"

#include "surface_contact_keys.hpp"

#include <array>
#include <set>
#include <string>

#include "softhom/materials/errors.hpp"

namespace softhom::macro {
namespace {

using Shape = fe::RigidObstacle::Shape;

/// The keys of one [[contact.obstacles]] table, before the checks across them (to_spec).
struct ObstacleKeys {
  Shape type = Shape::plane;
  std::string surface;
  std::vector<double> position, normal, axis;
  double radius = 0.0;
  std::vector<std::array<double, 4>> path;
  double friction = 0.0;
  double penalty = 0.0;
  bool augmented = true;
};

void read_obstacle_path(const toml::node& n, const std::string& f, ObstacleKeys& o) {
  const toml::array& a = keys::read_array(n, f);
  o.path.clear();
  for (std::size_t i = 0; i < a.size(); ++i) {
    const std::string fi = keys::index_field(f, i);
    const std::vector<double> row = keys::read_numbers(*a.get(i), fi, keys::any_value(), 4, 4);
    if (row[0] < 0.0 || (!o.path.empty() && row[0] < o.path.back()[0]))
      throw InputError(keys::index_field(fi, 0), format_number(row[0]), "times must start at 0 or later and not decrease");
    o.path.push_back({row[0], row[1], row[2], row[3]});
  }
  if (o.path.empty()) throw InputError(f, "[]", "give at least one point [t, ux, uy, uz]");
}

const keys::KeyTable<ObstacleKeys>& obstacle_table() {
  using O = ObstacleKeys;
  static const keys::KeyTable<O> t = [] {
    keys::KeyTable<O> k("contact.obstacles[]",
                        "A rigid obstacle and the structure's surface that touches it (fe/contact.hpp: quadrature-point "
                        "penalty with one augmentation per step, regularized Coulomb friction). The penetration of a "
                        "converged step stays below (p/G) h/100 (p contact pressure, G shear modulus, h face size).");
    k.choice("type", &O::type, {{"plane", Shape::plane}, {"sphere", Shape::sphere}, {"cylinder", Shape::cylinder}},
             "obstacle shape (the body lies on the normal's side of a plane, outside a sphere or cylinder)")
        .required()
        .text("surface", &O::surface, "the structure's surface: a built-in name (\"outer\", \"zmax\", ...) or a Gmsh physical surface; on a shell \"shell\" "
              "or a named group (the outer face, half the thickness from the mid-surface, touches)")
        .required()
        .numbers("position", &O::position, keys::any_value(), 3, 3, "mm",
                 "at t = 0: a point of the plane, the sphere's centre, a point of the cylinder's axis")
        .required()
        .numbers("normal", &O::normal, keys::any_value(), 3, 3, "-", "plane only: its normal, pointing towards the body")
        .default_text("required for a plane")
        .numbers("axis", &O::axis, keys::any_value(), 3, 3, "-", "cylinder only: the axis direction")
        .default_text("required for a cylinder")
        .number("radius", &O::radius, keys::at_least(0), "mm", "sphere and cylinder: radius")
        .default_text("required for a sphere or cylinder")
        .custom("path", "list of [t, ux, uy, uz]", "translation of the obstacle over time, piecewise linear",
                read_obstacle_path, "fixed", "", "s, mm")
        .number("friction", &O::friction, keys::closed_range(0, 3), "-",
                "Coulomb coefficient μ (0: frictionless; rubber on glass reaches about 3)")
        .number("penalty", &O::penalty, keys::at_least(0), "MPa/mm",
                "normal and stick penalty; 0: 100 G/h from the surface's elements (no tuning needed)")
        .flag("augmented", &O::augmented, "augment the contact pressure once per converged step (false: pure penalty)");
    return k;
  }();
  return t;
}

struct ContactKeys {};

const keys::KeyTable<ContactKeys>& contact_table() {
  static const keys::KeyTable<ContactKeys> t = [] {
    keys::KeyTable<ContactKeys> k("contact", "Contact with rigid obstacles and between the structure's surfaces; probes "
                                             "per obstacle, pair and self-contact surface in response.csv, contact "
                                             "pressure and gap per face in <label>.h5/.xdmf.");
    k.custom("obstacles", "list of tables", "the obstacles ([[contact.obstacles]] below)",
             [](const toml::node&, const std::string&, ContactKeys&) {})
        .custom("pairs", "list of tables", "contact between two surfaces ([[contact.pairs]] below)",
                [](const toml::node&, const std::string&, ContactKeys&) {})
        .custom("self", "list of tables", "self-contact of a surface ([[contact.self]] below)",
                [](const toml::node&, const std::string&, ContactKeys&) {});
    return k;
  }();
  return t;
}

Vec3 unit_vector(const std::vector<double>& v, const std::string& field) {
  const Vec3 d(v[0], v[1], v[2]);
  if (!(d.norm() > 0.0)) throw InputError(field, "[0, 0, 0]", "must be a non-zero direction");
  return d.normalized();
}

/// The checks across keys: a direction and radius where the shape needs them, none where it does not.
ObstacleSpec to_spec(const ObstacleKeys& k, const std::set<std::string>& present, const std::string& field) {
  ObstacleSpec s;
  s.field = field;
  s.surface = k.surface;
  s.friction = k.friction;
  s.penalty = k.penalty;
  s.augmented = k.augmented;
  fe::RigidObstacle& o = s.obstacle;
  o.shape = k.type;
  o.point = Vec3(k.position[0], k.position[1], k.position[2]);
  o.radius = k.radius;
  const std::string type = o.shape_name();
  auto refuse_extra = [&](const char* key) {
    if (present.count(key))
      throw InputError(field + "." + key, "", std::string("not a key of a ") + type + " obstacle");
  };
  auto need = [&](const char* key) {
    if (!present.count(key)) throw InputError(field + "." + key, "", std::string("missing: a ") + type + " obstacle needs it");
  };
  if (o.shape == Shape::plane) {
    need("normal");
    refuse_extra("axis");
    refuse_extra("radius");
    o.direction = unit_vector(k.normal, field + ".normal");
  } else {
    need("radius");
    refuse_extra("normal");
    if (!(k.radius > 0.0)) throw InputError(field + ".radius", format_number(k.radius), "must be positive");
    if (o.shape == Shape::cylinder) {
      need("axis");
      o.direction = unit_vector(k.axis, field + ".axis");
    } else {
      refuse_extra("axis");
    }
  }
  if (!k.path.empty())
    for (int c = 0; c < 3; ++c) {
      o.path[c] = PiecewiseLinear{{}, {}};
      for (const auto& row : k.path) {
        o.path[c].t.push_back(row[0]);
        o.path[c].v.push_back(row[1 + c]);
      }
    }
  return s;
}

}  // namespace

ContactSpec read_contact(const toml::node* node) {
  ContactSpec spec;
  if (!node) return spec;
  const toml::table& table = keys::read_table(*node, "contact");
  ContactKeys unused;
  contact_table().read(table, "contact", unused);
  spec.pairs = read_surface_contacts(table);
  const toml::node* list = table.get("obstacles");
  if (!list && spec.pairs.empty())
    throw InputError("contact.obstacles", "", "missing: give [[contact.obstacles]], [[contact.pairs]] or [[contact.self]] tables");
  if (!list) return spec;
  const toml::array& arr = keys::read_array(*list, "contact.obstacles");
  for (std::size_t i = 0; i < arr.size(); ++i) {
    const std::string field = keys::index_field("contact.obstacles", i);
    ObstacleKeys k;
    const std::set<std::string> present = obstacle_table().read(keys::read_table(*arr.get(i), field), field, k);
    spec.obstacles.push_back(to_spec(k, present, field));
  }
  return spec;
}

std::vector<keys::TableDoc> contact_tables() {
  std::vector<keys::TableDoc> tables{contact_table().describe(), obstacle_table().describe()};
  for (keys::TableDoc& t : surface_contact_tables()) tables.push_back(std::move(t));
  return tables;
}

}  // namespace softhom::macro
