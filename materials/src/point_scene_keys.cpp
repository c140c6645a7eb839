// [solver] of `softhom point`, declared key by key (same spellings as the RVE and macro solvers).
#include "softhom/materials/errors.hpp"
#include "softhom/materials/scene_keys.hpp"

namespace softhom {
namespace {

const keys::KeyTable<PointSolverOptions>& point_solver_keys() {
  using O = PointSolverOptions;
  static const keys::KeyTable<PointSolverOptions> t = [] {
    keys::KeyTable<PointSolverOptions> k("solver", "material-point Newton iteration on the free stress components");
    k.number("tolerance", &O::tolerance, keys::open_range(0.0, 1.0), "-",
             "max |P_free - P_target| relative to max(|P|, 1e-6 G0)")
        .integer("max_newton_iterations", &O::max_iterations, keys::closed_range(1, 10000), "-", "Newton iterations per sub-step")
        .renamed("max_iterations")
        .integer("max_cutbacks", &O::max_cutbacks, keys::closed_range(0, 60), "-",
                 "times a step may be halved (60 halvings reach the resolution of a double)")
        .number("max_step_seconds", &O::max_step_seconds, keys::at_least(0.0), "s",
                "wall-time budget of one output step's cut-backs (0: unlimited)");
    return k;
  }();
  return t;
}

struct PointTop {
  std::string description;
  const toml::node* material = nullptr;
  const toml::node* load = nullptr;
  const toml::node* solver = nullptr;
};

const keys::KeyTable<PointTop>& point_top_keys() {
  static const keys::KeyTable<PointTop> t = [] {
    keys::KeyTable<PointTop> k("", "the tables of a point scene");
    auto node_of = [](const toml::node* PointTop::*member) {
      return [member](const toml::node& n, const std::string& f, PointTop& p) { p.*member = &keys::read_table(n, f); };
    };
    k.text("description", &PointTop::description, "what the scene is for (copied to summary.json)")
        .custom("material", "table", "[material]: the constitutive law", node_of(&PointTop::material), "required")
        .custom("load", "table", "[load]: the load path", node_of(&PointTop::load), "required")
        .custom("solver", "table", "[solver]: Newton settings", node_of(&PointTop::solver), "defaults");
    return k;
  }();
  return t;
}

}  // namespace

PointScene parse_point_scene(const toml::table& scene) {
  PointTop top;
  point_top_keys().read(scene, "", top);
  if (!top.material) throw InputError("material", "", "missing [material] table");
  if (!top.load) throw InputError("load", "", "missing [load] table");
  PointScene s;
  s.material = parse_material(*top.material->as_table(), "material");
  s.control = parse_load(*top.load->as_table(), "load");
  s.solver = parse_point_solver(top.solver, "solver");
  return s;
}

std::vector<keys::TableDoc> point_scene_tables() {
  std::vector<keys::TableDoc> t{point_top_keys().describe()};
  t.front().path = "(top level)";
  for (auto& d : material_tables("material")) t.push_back(d);
  for (auto& d : load_tables("load")) t.push_back(d);
  t.push_back(point_solver_table());
  return t;
}

PointSolverOptions parse_point_solver(const toml::node* solver, const std::string& path) {
  PointSolverOptions o;
  point_solver_keys().read_optional(solver, path, o);
  return o;
}

keys::TableDoc point_solver_table() { return point_solver_keys().describe(); }

}  // namespace softhom
