// FE-engine keys of an RVE scene: one declaration per key, next to the options they fill.
#include "softhom/studies/rve_fe_scene.hpp"

#include <optional>

#include "softhom/materials/errors.hpp"
#include "softhom/rve/fft_solver_keys.hpp"
#include "softhom/studies/rve_scene.hpp"

namespace softhom::studies {
namespace {

/// What [solver] says for the FE engine; sizes left unset default from the cell side.
struct FeKeys {
  bool three_d = false;
  std::optional<double> mesh_size, interface_size, length;
  rve::SectionMeshOptions mesh;
  rve::FeSolverOptions solver;
  std::optional<rve::FePressure> pressure;
  bool umfpack = false;
};

const keys::KeyTable<rve::SectionMeshOptions>& section_mesh_keys() {
  using M = rve::SectionMeshOptions;
  static const keys::KeyTable<rve::SectionMeshOptions> t = [] {
    keys::KeyTable<rve::SectionMeshOptions> k("solver", "");
    k.number("grading", &M::grading, keys::above(0.0), "-", "element size growth per unit distance from the nearest interface")
        .number("min_angle_deg", &M::min_angle_deg, keys::left_open(0.0, 20.7), "deg",
                "section mesh: smallest triangle angle (CGAL terminates up to 20.7)")
        .flag("curved_interfaces", &M::curved_interfaces, "mid-side nodes on the exact fiber boundary")
        .flag("corner_refinement", &M::corner_refinement, "section: graded refinement toward rectangular-fiber corners")
        .number("corner_exponent", &M::corner_exponent, keys::open_range(0.0, 1.0), "-", "exponent of the corner grading");
    return k;
  }();
  return t;
}

const keys::KeyTable<rve::FeSolverOptions>& fe_newton_keys() {
  using S = rve::FeSolverOptions;
  static const keys::KeyTable<rve::FeSolverOptions> t = [] {
    keys::KeyTable<rve::FeSolverOptions> k("solver", "");
    k.number("tolerance", &S::tolerance, keys::open_range(0.0, 1.0), "-", "Newton: residual, macro stress and pressure errors relative to the stress scale")
        .integer("max_newton_iterations", &S::max_newton_iterations, keys::closed_range(1, 10000), "-", "Newton iterations per sub-step")
        .integer("max_cutbacks", &S::max_cutbacks, keys::closed_range(0, 60), "-",
                 "times a step may be halved (60 halvings reach the resolution of a double)")
        .number("max_step_seconds", &S::max_step_seconds, keys::at_least(0.0), "s",
                "wall-time budget of one output step's cut-backs (0: unlimited)")
        .flag("mixed_pressure", &S::mixed_pressure, "mixed (u, p) Newton iteration in nearly incompressible phases");
    return k;
  }();
  return t;
}

const keys::KeyTable<FeKeys>& fe_keys() {
  static const keys::KeyTable<FeKeys> t = [] {
    keys::KeyTable<FeKeys> k("solver (engine = \"fe\")", "FE engine: periodic conforming mesh of the generated section or cell");
    k.custom("engine", "choice", "\"fe\" selects these keys", [](const toml::node& n, const std::string& f, FeKeys&) {
               if (keys::read_text(n, f) != "fe") throw InputError(f, keys::describe_value(n), "must be \"fe\" here");
             }, "\"fft\"", "\"fe\"")
        .custom("fe_mesh", "choice", "\"section\": T6 cross-section mesh; \"3d\": periodic Tet10 cell mesh",
                [](const toml::node& n, const std::string& f, FeKeys& k) {
                  static const keys::Choices<bool> c{{{"section", false}, {"3d", true}}, {}};
                  k.three_d = keys::read_choice(n, f, c);
                },
                "\"section\"", "\"section\", \"3d\"")
        .number("mesh_size", &FeKeys::mesh_size, keys::above(0.0), "length", "element size away from the fibers")
        .default_text("cell side / 16 (section), / 6 (3d)")
        .number("interface_size", &FeKeys::interface_size, keys::above(0.0), "length", "element size at the fiber boundaries")
        .default_text("mesh_size / 3 (section), / 2 (3d)")
        .include(section_mesh_keys(), &FeKeys::mesh)
        .number("length", &FeKeys::length, keys::above(0.0), "length", "3d: cell length along the fibers")
        .default_text("the cell side")
        .include(fe_newton_keys(), &FeKeys::solver)
        .custom("pressure", "choice", "pressure space: \"p1\" (P2+bubble / discontinuous P1, section) or \"p0\" (P2/P0, the only 3d option)",
                [](const toml::node& n, const std::string& f, FeKeys& k) {
                  static const keys::Choices<rve::FePressure> c{{{"p1", rve::FePressure::p1_bubble}, {"p0", rve::FePressure::p0}}, {}};
                  k.pressure = keys::read_choice(n, f, c);
                },
                "\"p1\" (section), \"p0\" (3d)", "\"p1\", \"p0\"")
        .custom("linear_solver", "choice", "sparse direct solver (CHOLMOD falls back to UMFPACK when needed)",
                [](const toml::node& n, const std::string& f, FeKeys& k) {
                  static const keys::Choices<bool> c{{{"cholmod", false}, {"umfpack", true}}, {}};
                  k.umfpack = keys::read_choice(n, f, c);
                },
                "\"cholmod\"", "\"cholmod\", \"umfpack\"");
    return k;
  }();
  return t;
}

}  // namespace

rve::Section parse_fe_section(const toml::table& t, double& target_vf, std::string& note) {
  const std::string p = "microstructure";
  if (t.contains("image"))
    throw InputError(p + ".image", "", "the FE engine needs a generated section (shape, arrangement, volume_fraction)");
  microstructure_fiber_angle(t);  // every key checked as for the FFT engine (grid is ignored)
  std::string label;
  const rve::FiberCellSpec spec = parse_fiber_cell_spec(t, p, label);
  target_vf = spec.volume_fraction;
  if (spec.volume_fraction == 0.0) {
    rve::Section s;
    s.L1 = s.L2 = spec.cell_size.value_or(1.0);
    note = "matrix only";
    return s;
  }
  const rve::Section s = rve::generate_section(spec, p);
  note = label + ", cell " + format_number(s.L1) + " x " + format_number(s.L2);
  return s;
}

FeRveSettings parse_fe_rve_solver(const toml::table& scene, double L1) {
  FeKeys k;
  fe_keys().read_optional(scene.get("solver"), "solver", k);
  const std::string p = "solver";
  FeRveSettings f;
  f.three_d = k.three_d;
  f.mesh = k.mesh;
  f.mesh.mesh_size = k.mesh_size.value_or(L1 / (f.three_d ? 6.0 : 16.0));
  f.mesh.interface_size = k.interface_size.value_or(f.mesh.mesh_size / (f.three_d ? 2.0 : 3.0));
  f.mesh3d.mesh_size = f.mesh.mesh_size;
  f.mesh3d.interface_size = f.mesh.interface_size;
  f.mesh3d.grading = f.mesh.grading;
  f.mesh3d.curved_interfaces = f.mesh.curved_interfaces;
  if (k.length && !f.three_d) throw InputError(p + ".length", format_number(*k.length), "only with fe_mesh = \"3d\"");
  f.mesh3d.length = k.length.value_or(0.0);
  f.solver = k.solver;
  const rve::FePressure pressure = k.pressure.value_or(f.three_d ? rve::FePressure::p0 : rve::FePressure::p1_bubble);
  if (pressure == rve::FePressure::p1_bubble && f.three_d)
    throw InputError(p + ".pressure", "\"p1\"", "the 3D tetrahedral mesh supports p0 (P2/P0) only");
  f.solver.pressure = pressure;
  f.solver.use_umfpack = k.umfpack;
  return f;
}

std::string rve_scene_engine(const toml::table& scene) {
  static const keys::Choices<std::string> engines{{{"fft", "fft"}, {"fe", "fe"}, {"auto", "auto"}}, {}};
  const toml::table* solver = scene["solver"].as_table();
  const toml::node* node = solver ? solver->get("engine") : nullptr;
  return node ? keys::read_choice(*node, "solver.engine", engines) : "fft";
}

FeRveSetup parse_fe_rve_setup(const toml::table& scene, bool with_load) {
  FeRveSetup s;
  const toml::table& micro = rve_microstructure(scene);
  s.phases = parse_rve_phases(scene);
  s.section = parse_fe_section(micro, s.target_vf, s.geometry_note);
  if (s.target_vf > 0.0 && !s.phases.has_fiber) throw InputError("phases.fiber", "", "missing (the cell has fibers)");
  s.fiber_angle_deg = microstructure_fiber_angle(micro);
  s.settings = parse_fe_rve_solver(scene, s.section.L1);
  s.plate = microstructure_is_plate(micro);
  if (s.plate) {
    if (s.settings.three_d)
      throw InputError("microstructure.cell", "\"plate\"", "a plate is a section (its fibers are straight): use fe_mesh = \"section\"");
    rve::check_plate_section(s.section);
  }
  if (with_load) s.control = parse_rve_load(scene);
  if (s.plate && with_load) rve::check_plate_control(s.control);
  return s;
}

FeRveMesh mesh_fe_rve(const FeRveSetup& setup) {
  FeRveMesh m;
  if (setup.settings.three_d) {
    m.cell = std::make_unique<rve::CellMesh>(rve::mesh_cell(setup.section, setup.settings.mesh3d));
  } else {
    m.section = std::make_unique<rve::SectionMesh>(rve::mesh_section(setup.section, setup.settings.mesh));
    if (setup.plate) rve::make_plate(*m.section);
  }
  return m;
}

std::unique_ptr<rve::FeRveSolver> make_fe_rve_solver(FeRveMesh mesh, const FeRveSetup& setup) {
  const auto& [matrix, fiber, has_fiber] = setup.phases;
  if (mesh.section)
    return std::make_unique<rve::FeRveSolver>(std::move(*mesh.section), matrix, fiber, setup.fiber_angle_deg,
                                              setup.control.frame, setup.settings.solver);
  return std::make_unique<rve::FeRveSolver>(std::move(*mesh.cell), matrix, fiber, setup.fiber_angle_deg,
                                            setup.control.frame, setup.settings.solver);
}

keys::TableDoc fe_rve_solver_table() { return fe_keys().describe(); }

std::vector<keys::TableDoc> rve_scene_tables() {
  std::vector<keys::TableDoc> t = rve_common_tables();
  t.push_back(rve::fft_solver_keys().describe());
  t.back().path = "solver (engine = \"fft\")";
  t.push_back(fe_rve_solver_table());
  return t;
}

}  // namespace softhom::studies
