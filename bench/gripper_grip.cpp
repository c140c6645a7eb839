// The cost of contact on the gripper holding a sample or closing past its fingers' first contact
// (studies/devices/gripper_grip_rigid_*.toml, gripper_contact_*.toml, gripper_sample_*.toml): the scene is
// run through its load steps once with its contacts (rigid obstacles and pairs between surfaces) and once
// without them (the free gripper, up to the step before the first contact). Per load step: Newton
// iterations, cut-backs, CPU time, CPU time per Newton iteration, the contact force (device.csv's
// grip_force_N plus finger_contact_force_N) and the tip-to-axis distance; then the mean Newton
// iterations per step before and after the first contact, the time per Newton iteration of both runs
// over the steps they share, and the contacts' own assembly (residual and tangent of every contact,
// timed alone at the final state) against the whole assembly of one Newton iteration.
//
//   bench_gripper_grip [SCENE.toml] [MESH_SIZE]     (default: studies/devices/gripper_grip_rigid_coarse.toml
//                                                    from the source tree, at its mesh size)
//
// The mesh is cached as `softhom macro` caches it (SOFTHOM_MESH_CACHE, else the system's temporary
// directory). Peak memory: run under /usr/bin/time -v.
#include <cstdio>
#include <ctime>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "softhom/fe/contact.hpp"
#include "softhom/fe/solver.hpp"
#include "softhom/fe/surface_contact.hpp"
#include "softhom/io/scene.hpp"
#include "softhom/macro/devices.hpp"
#include "softhom/macro/mesh_generation.hpp"
#include "softhom/macro/scene.hpp"
#include "softhom/macro/structures.hpp"

using namespace softhom;

namespace {

/// Processor time of this process: on a shared machine its wall time measures the others' load too
/// (run with OMP_NUM_THREADS=1, where the two agree on an idle machine).
double cpu_seconds() { return double(std::clock()) / CLOCKS_PER_SEC; }

/// Discards what a contribution assembles (its evaluation alone is timed).
class NullSink final : public fe::AssemblySink {
 public:
  NullSink() : AssemblySink(true) {}
  void add_residual(int, const int*, const double* r) override { sum += r[0]; }
  void add_tangent(int, const int*, int, const int*, const double* k) override { sum += k[0]; }
  void add_border(int, const int*, const double*, const double*) override {}
  void add_constraint_value(double) override {}
  double sum = 0.0;
};

struct StepRow {
  double t = 0.0, pressure_kPa = 0.0, seconds = 0.0, grip_N = 0.0, tip_mm = 0.0;
  int newton = 0, cutbacks = 0;
  bool reached = false;
};

/// Runs `structure` through the output times (or until a step fails, or `last` steps), one row each.
std::vector<StepRow> run(const macro::MacroScene& ms, const macro::Structure& structure, std::size_t last,
                         fe::Simulation& sim) {
  const macro::DeviceProbe probe(ms.device, structure);
  const std::vector<std::string> columns = probe.columns();
  auto column = [&](const std::string& name) {
    for (std::size_t c = 0; c < columns.size(); ++c)
      if (columns[c] == name) return int(c);
    return -1;
  };
  const int grip = column("grip_force_N"), between = column("finger_contact_force_N"), tip = column("tip_axis_distance_mm");
  std::vector<StepRow> rows;
  for (std::size_t k = 0; k < ms.times.size() && k < last; ++k) {
    const double t0 = cpu_seconds();
    const fe::AdvanceResult r = sim.advance_to(ms.times[k]);
    StepRow row;
    row.seconds = cpu_seconds() - t0;
    row.t = ms.times[k];
    row.newton = r.counts.newton_iterations;
    row.cutbacks = r.counts.cutbacks;
    row.reached = r.reached();
    const std::vector<double> v = probe.values(sim);
    row.pressure_kPa = v[1];
    row.grip_N = (grip >= 0 ? v[grip] : 0.0) + (between >= 0 ? v[between] : 0.0);
    row.tip_mm = tip >= 0 ? v[tip] : 0.0;
    rows.push_back(row);
    if (!row.reached) break;
  }
  return rows;
}

void print(const char* title, const std::vector<StepRow>& rows) {
  std::printf("%s\n%8s %6s %8s %9s %10s %10s %9s\n", title, "p_kPa", "newton", "cutbacks", "cpu_s", "cpu/newton",
              "contact_N", "tip_mm");
  for (const StepRow& r : rows)
    std::printf("%8.1f %6d %8d %9.2f %10.3f %10.4g %9.4f%s\n", r.pressure_kPa, r.newton, r.cutbacks, r.seconds,
                r.newton ? r.seconds / r.newton : 0.0, r.grip_N, r.tip_mm, r.reached ? "" : "  (not reached)");
}

}  // namespace

int main(int argc, char** argv) {
  const std::filesystem::path scene_file = argc > 1 ? argv[1] : "studies/devices/gripper_grip_rigid_coarse.toml";
  toml::table scene = io::load_scene(scene_file);
  if (argc > 2) scene["geometry"].as_table()->insert_or_assign("mesh_size", std::atof(argv[2]));
  const macro::MacroScene ms = macro::parse_macro_scene(scene, scene_file, macro::mesh_cache_dir({}));
  const macro::Structure with = macro::build_structure(ms.spec);
  std::vector<std::shared_ptr<const fe::Contribution>> contacts;
  int points = 0;
  macro::Structure without = with;
  without.model.contributions.clear();
  for (const auto& c : with.model.contributions) {
    if (auto oc = std::dynamic_pointer_cast<const fe::ObstacleContact>(c)) points += oc->num_points();
    else if (auto sc = std::dynamic_pointer_cast<const fe::SurfaceContact>(c)) points += sc->num_points();
    else {
      without.model.contributions.push_back(c);
      continue;
    }
    contacts.push_back(c);
  }
  std::printf("scene %s: %d nodes, %d elements, %zu contacts\n", scene_file.string().c_str(),
              with.model.mesh.num_nodes(), with.model.mesh.num_elements(), contacts.size());

  fe::Simulation sim(with.model, ms.newton);
  const double t0 = cpu_seconds();
  const std::vector<StepRow> grip = run(ms, with, ms.times.size(), sim);
  const double total = cpu_seconds() - t0;
  print("with contact:", grip);
  std::size_t first = grip.size();
  for (std::size_t k = 0; k < grip.size() && first == grip.size(); ++k)
    if (grip[k].grip_N > 0.0) first = k;
  // The free gripper over the steps before the first contact (beyond it the fingers would pass
  // through the sample's place).
  fe::Simulation free_sim(without.model, ms.newton);
  const std::vector<StepRow> free_rows = run(ms, without, first, free_sim);
  print("without contact (the steps before the first contact):", free_rows);

  auto mean = [](const std::vector<StepRow>& rows, std::size_t from, std::size_t to, bool per_iteration) {
    double a = 0.0, b = 0.0;
    for (std::size_t k = from; k < to && k < rows.size(); ++k) {
      a += per_iteration ? rows[k].seconds : rows[k].newton;
      b += per_iteration ? rows[k].newton : 1.0;
    }
    return b > 0.0 ? a / b : 0.0;
  };
  std::printf("first contact in the step to %.1f kPa; whole run %.1f s CPU, %d Newton iterations, %d cut-backs\n",
              first < grip.size() ? grip[first].pressure_kPa : 0.0, total, sim.stats().newton_iterations,
              sim.stats().cutbacks);
  std::printf("Newton iterations per step: %.2f before the first contact, %.2f from it on (without contact: %.2f)\n",
              mean(grip, 0, first, false), mean(grip, first, grip.size(), false), mean(free_rows, 0, first, false));
  std::printf("CPU seconds per Newton iteration: %.3f with contact (all steps), %.3f with contact and %.3f without "
              "over the steps before contact\n",
              mean(grip, 0, grip.size(), true), mean(grip, 0, first, true), mean(free_rows, 0, first, true));

  // The contacts' own assembly at the final state, against one Newton iteration's whole assembly.
  const fe::RunStats st = sim.stats();
  const int reps = 200;
  NullSink sink;
  const double tc = cpu_seconds();
  for (int r = 0; r < reps; ++r)
    for (const auto& c : contacts) c->assemble(with.model.mesh, sim.converged_iterate(*c), sink);
  const double contact_seconds = (cpu_seconds() - tc) / reps;
  const double assembly = st.tangent_assemblies ? st.assembly_time / (st.tangent_assemblies + st.residual_assemblies) : 0.0;
  std::printf("assembly of the contacts alone: %.1f us CPU per evaluation (%d points); whole assembly %.4f s wall per "
              "evaluation (%d with tangent, %d residual only); linear solves %.1f s wall of the run\n",
              1e6 * contact_seconds, points, assembly, st.tangent_assemblies, st.residual_assemblies,
              st.linear.factorization + st.linear.solve);
  return grip.empty() || !grip.back().reached ? 1 : 0;
}
