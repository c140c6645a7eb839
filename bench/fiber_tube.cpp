// Tied-fiber tubes: (1) the middle of a capped tube with near-inextensible helices against the
// thin-walled kinematic model (macro/fiber_tube_model.hpp) for thin and thick walls; (2) the
// dissertation's Table 17 pair and the single-helix tube (Tables 18–19): the shipped anisotropic
// scenes against the same tubes with glass fibers (E = 10 MPa, 0.5 mm) tied on the outer surface;
// (3) the cost of the fibers: the Table 17 tube with and without them. Plain program, ~1–2 min.
//
//   bench_fiber_tube [--source DIR] [--part 1|2|3] (DIR: the source tree, for studies/scenes; default: the
//                                                  working directory; --part: only (1), (2) or (3))
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>

#include <toml++/toml.h>

#include "../tests/macro/fiber_tube.hpp"
#include "softhom/macro/fiber_tube_model.hpp"
#include "softhom/macro/scene.hpp"

using namespace softhom;

namespace {

void kinematic_table() {
  std::printf("\n(1) middle of the tube vs thin-walled kinematic model (G 0.1, K 100, E A 500 N, 12 fibers per family)\n");
  std::printf("%-7s %-6s %-6s %-8s | %-9s %-9s %-7s | %-9s %-9s %-7s | %-9s %-9s\n", "Ro/Ri", "alpha", "helix", "p [MPa]",
              "ez FE", "ez model", "gap", "eth FE", "eth model", "gap", "twist FE", "model");
  struct Row {
    double ro, alpha, p;
    bool twin;
  };
  for (const Row& row : {Row{5.5, 40, 0.01, true}, Row{5.5, 70, 0.01, true}, Row{5.5, 40, 0.004, false},
                         Row{6.5, 40, 0.03, true}, Row{6.5, 70, 0.03, true}, Row{7.5, 40, 0.04, true}}) {
    test::FiberTubeCase c;
    c.outer_radius = row.ro;
    c.radial_cells = row.ro > 6.0 ? 3 : 1;
    c.angle_deg = row.alpha;
    c.pressure = row.p;
    c.geometry = row.twin ? macro::FiberGeometry::double_helix : macro::FiberGeometry::helix;
    c.substeps = 8;
    const test::FiberTubeResult r = test::inflate_fiber_tube(c);
    macro::ThinTube t;
    t.inner_radius = c.inner_radius;
    t.outer_radius = c.outer_radius;
    t.shear_modulus = c.G;
    t.angle_deg = c.angle_deg;
    t.double_helix = row.twin;
    const macro::ThinTubeState m = macro::thin_tube_state(t, c.pressure);
    const double ez = r.axial_stretch_mid - 1, mz = m.axial_stretch - 1, et = r.hoop_stretch_mid - 1, mt = m.hoop_stretch - 1;
    std::printf("%-7.2f %-6.0f %-6s %-8.3g | %-9.4f %-9.4f %-6.1f%% | %-9.4f %-9.4f %-6.1f%% | %-9.3f %-9.3f%s\n", row.ro / 5.0,
                row.alpha, row.twin ? "double" : "single", row.p, ez, mz, 100 * (ez - mz) / std::abs(mz), et, mt,
                100 * (et - mt) / std::abs(mt), r.twist_mid_deg, m.twist_per_length * 0.5 * c.length * 180 / M_PI,
                r.reached ? "" : "  (not reached)");
  }
}

struct SceneRun {
  bool reached = false;
  double axial = 1, radial = 1, twist = 0, angle = 0, seconds = 0;
  int newton = 0, fiber_elements = 0;
};

/// Runs a macro scene table to its end: the end's axial stretch, inner radial stretch, twist, and the
/// mean |angle| of the fibers at the middle third of the tube.
SceneRun run_scene(const toml::table& scene) {
  const macro::MacroScene ms = macro::parse_macro_scene(scene);
  const auto t0 = std::chrono::steady_clock::now();
  const macro::Structure s = macro::build_structure(ms.spec);
  fe::Simulation sim(s.model, ms.newton);
  SceneRun r;
  r.reached = true;
  for (double t : ms.times)
    if (!sim.advance_to(t).reached()) {
      r.reached = false;
      break;
    }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const auto v = macro::probe_values(s, sim);
  r.radial = v[4];
  r.axial = v[5];
  r.twist = v[6];
  r.newton = sim.stats().newton_iterations;
  if (!s.fibers.empty()) {
    fe::Iterate it;
    it.u = &sim.displacement();
    const auto states = s.fibers[0]->states(s.model.mesh, it);
    const auto& ref = s.fibers[0]->reference_points();
    const auto& conn = s.fibers[0]->connectivity();
    const int m = s.fibers[0]->nodes_per_element();
    int n = 0;
    for (std::size_t e = 0; e < states.size(); ++e) {
      const double z = 0.5 * (ref[conn[m * e]][2] + ref[conn[m * e + 1]][2]);
      if (z < ms.spec.tube.length / 3 || z > 2 * ms.spec.tube.length / 3) continue;
      r.angle += std::abs(states[e].angle_deg);
      ++n;
    }
    r.angle /= std::max(n, 1);
    r.fiber_elements = s.fibers[0]->num_elements();
  }
  return r;
}

/// The shipped anisotropic scene with its [material] replaced by the matrix and its fibers tied.
toml::table tied_version(toml::table scene, const std::string& matrix, bool twin, double angle) {
  toml::table* g = scene["geometry"].as_table();
  g->erase("fiber_frame");
  scene.insert_or_assign("material", toml::table{{"preset", matrix}});
  toml::table f{{"geometry", twin ? "double_helix" : "helix"}, {"angle_deg", angle}, {"count", 6}, {"tie", "surface"},
                {"modulus", 10.0}, {"area", 0.19635}};
  scene.insert_or_assign("fibers", toml::array{f});
  return scene;
}

void print_run(const char* what, const SceneRun& r) {
  std::printf("  %-34s axial %.4f  radial(inner) %.4f  twist %8.3f deg  fiber |angle| %5.1f  %3d Newton  %6.2f s%s\n", what,
              r.axial, r.radial, r.twist, r.angle, r.newton, r.seconds, r.reached ? "" : "  (not reached)");
}

void dissertation_tables(const std::string& source) {
  std::printf("\n(2) dissertation Table 17 (double helix) and Tables 18-19 (single helix): anisotropic model vs tied glass fibers\n");
  struct Case {
    const char* scene;
    const char* matrix;
    bool twin;
    double angle;
  };
  for (const Case& c : {Case{"macro_tube_helix15_pdms", "pdms", true, 15}, Case{"macro_tube_helix45_pdms", "pdms", true, 45},
                        Case{"macro_tube_helix15_ecoflex", "ecoflex", true, 15},
                        Case{"macro_tube_helix45_ecoflex", "ecoflex", true, 45},
                        Case{"macro_tube_single_helix45_ecoflex", "ecoflex", false, 45}}) {
    const toml::table scene = toml::parse_file(source + "/studies/scenes/" + c.scene + ".toml");
    std::printf("%s\n", c.scene);
    print_run("anisotropic (homogenized) model", run_scene(scene));
    const SceneRun tied = run_scene(tied_version(scene, c.matrix, c.twin, c.angle));
    print_run("tied fibers on the outer surface", tied);
  }
}

/// The machine's load averages (1, 5, 15 min) as /proc/loadavg gives them: the cost is measured on a
/// shared machine, so each figure comes with the load it was taken under.
std::string load_average() {
  std::FILE* f = std::fopen("/proc/loadavg", "r");
  char buf[64] = "?";
  if (f) {
    if (!std::fgets(buf, sizeof buf, f)) buf[0] = '\0';
    std::fclose(f);
  }
  std::string s(buf);
  const auto cut = s.find(' ', s.find(' ', s.find(' ') + 1) + 1);
  return cut == std::string::npos ? s : s.substr(0, cut);
}

struct CostRun {
  bool reached = false;
  int newton = 0, dofs = 0, fiber_elements = 0;
  double wall = 0.0, assembly = 0.0, factorization = 0.0, own = 0.0;
};

/// One run of the Table 17 ecoflex tube, with or without its tied fibers, to 1 kPa in one load step.
CostRun cost_run(const toml::table& scene, bool with) {
  struct Drop final : fe::AssemblySink {
    Drop() : AssemblySink(true) {}
    void add_residual(int, const int*, const double*) override {}
    void add_tangent(int, const int*, int, const int*, const double*) override {}
    void add_border(int, const int*, const double*, const double*) override {}
    void add_constraint_value(double) override {}
  };
  toml::table t = tied_version(scene, "ecoflex", true, 45);
  if (!with) t.erase("fibers");
  t.insert_or_assign("load", toml::table{{"control", "pressure"}, {"path", toml::array{toml::array{0.0, 0.0}, toml::array{1.0, 0.001}}}, {"steps", 1}});
  const macro::MacroScene ms = macro::parse_macro_scene(t);
  const auto t0 = std::chrono::steady_clock::now();
  const macro::Structure s = macro::build_structure(ms.spec);
  fe::Simulation sim(s.model, ms.newton);
  CostRun r;
  r.reached = sim.advance_to(1.0).reached();
  r.wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const fe::RunStats st = sim.stats();
  r.newton = st.newton_iterations;
  r.dofs = sim.num_free_dofs();
  r.assembly = st.assembly_time;
  r.factorization = st.linear.factorization;
  if (with) {
    r.fiber_elements = s.fibers[0]->num_elements();
    Drop drop;
    fe::Iterate it;
    it.u = &sim.displacement();
    const int reps = 50;
    const auto a0 = std::chrono::steady_clock::now();
    for (int k = 0; k < reps; ++k) (void)s.fibers[0]->assemble(s.model.mesh, it, drop);
    r.own = std::chrono::duration<double>(std::chrono::steady_clock::now() - a0).count() / reps;
  }
  return r;
}

/// (3) The cost of the fibers: the Table 17 ecoflex tube with its tied fibers and without, each built
/// and taken one load step to 1 kPa (both tubes deform alike there), the fastest of `repeats` runs
/// (the machine is shared: the fastest is the least disturbed), total and per Newton iteration; and the
/// fibers' own assembly (residual and tangent into a sink that drops them).
void cost(const std::string& source, int repeats = 3) {
  std::printf("\n(3) cost of the tied fibers (macro_tube_helix45_ecoflex geometry, 6 + 6 glass fibers on the outer surface), "
              "fastest of %d runs each; load average before: %s\n", repeats, load_average().c_str());
  const toml::table scene = toml::parse_file(source + "/studies/scenes/macro_tube_helix45_ecoflex.toml");
  CostRun best[2];
  for (int k = 0; k < repeats; ++k)
    for (int with = 1; with >= 0; --with) {
      const CostRun r = cost_run(scene, with == 1);
      if (k == 0 || r.wall < best[with].wall) best[with] = r;
    }
  for (int with = 1; with >= 0; --with) {
    const CostRun& r = best[with];
    const int n = std::max(1, r.newton);
    std::printf("  %-15s %5d free dofs %4d fiber elements: %2d Newton, total %.3f s, %.3f s per iteration (assembly %.4f s, "
                "factorization %.4f s), fibers' own assembly %.5f s%s\n",
                with ? "with fibers" : "without fibers", r.dofs, r.fiber_elements, r.newton, r.wall, r.wall / n, r.assembly / n,
                r.factorization / n, r.own, r.reached ? "" : " (not reached)");
  }
  const double per_with = best[1].wall / std::max(1, best[1].newton), per_without = best[0].wall / std::max(1, best[0].newton);
  std::printf("  ratio with / without: total %.2f, per Newton iteration %.2f; load average after: %s\n",
              best[1].wall / best[0].wall, per_with / per_without, load_average().c_str());
}

}  // namespace

int main(int argc, char** argv) {
  std::setvbuf(stdout, nullptr, _IOLBF, 0);  // rows as they come
  std::string source = ".", part = "all";
  for (int a = 1; a + 1 < argc; ++a) {
    if (std::string(argv[a]) == "--source") source = argv[a + 1];
    if (std::string(argv[a]) == "--part") part = argv[a + 1];
  }
  if (!std::filesystem::exists(source + "/studies/scenes")) {
    std::fprintf(stderr, "bench_fiber_tube: no studies/scenes under %s (give --source DIR)\n", source.c_str());
    return 2;
  }
  if (part == "all" || part == "1") kinematic_table();
  if (part == "all" || part == "2") dissertation_tables(source);
  if (part == "all" || part == "3") cost(source);
  return 0;
}
