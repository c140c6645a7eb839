// softhom rve with [solver] engine = "fe": FE homogenization of the same cell on a periodic conforming
// T6 section mesh (rve/fe_solver.hpp). Same scene tables and the same response.csv columns and
// summary.json keys as the FFT engine (plus mesh statistics), so curves overlay directly.
//
// The FE [solver] keys are declared with their options in studies/rve_fe_scene.cpp (docs/keys.md);
// [microstructure].grid is ignored (it is the FFT resolution).
#include "cmd_rve_fe.hpp"

#include <array>
#include <chrono>
#include <memory>
#include <cmath>
#include <iostream>
#include <sstream>

#include "softhom/io/fields.hpp"
#include "softhom/io/files.hpp"
#include "softhom/io/scene.hpp"
#include "softhom/io/summary.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/materials/library.hpp"
#include "softhom/fe/tet10.hpp"
#include "softhom/rve/fe_solver.hpp"
#include "softhom/rve/geometry.hpp"
#include "softhom/studies/rve_fe_scene.hpp"
#include "softhom/studies/rve_scene.hpp"

#include "rve_output.hpp"

namespace softhom::app {
namespace {

io::UnstructuredMesh field_mesh(const rve::SectionMesh& m) {
  io::UnstructuredMesh u;
  u.cell_type = io::CellType::triangle6;
  for (const auto& x : m.nodes) {
    u.coordinates.push_back(x.x());
    u.coordinates.push_back(x.y());
    u.coordinates.push_back(0.0);
  }
  for (const auto& e : m.elements)
    for (int a : e) u.connectivity.push_back(a);
  return u;
}

/// 3D cell mesh: the unwrapped periodic copies are written as they are (the cell appears with
/// jagged faces, each element once), Tet10 in the VTK/XDMF node order.
io::UnstructuredMesh field_mesh(const rve::CellMesh& m) {
  io::UnstructuredMesh u;
  u.cell_type = io::CellType::tetra10;
  for (const auto& x : m.nodes)
    for (int c = 0; c < 3; ++c) u.coordinates.push_back(x[c]);
  for (const auto& e : m.elements) {
    std::array<int, 10> v;
    for (int a = 0; a < 10; ++a) v[fe::kTet10ToVtk[a]] = e[a];
    for (int a : v) u.connectivity.push_back(a);
  }
  return u;
}

}  // namespace

std::string choose_engine(toml::table& scene, std::string& why) {
  auto* solver = scene["solver"].as_table();
  auto* micro = scene["microstructure"].as_table();
  if (!solver || !micro) throw InputError("solver.engine", "auto", "needs [microstructure] and [solver] tables");
  if (!solver->contains("target_error"))
    throw InputError("solver.target_error", "", "engine = \"auto\" needs target_error (relative error of the homogenized stress)");
  const double target = keys::read_number(*solver->get("target_error"), "solver.target_error", keys::open_range(0.0, 0.5));
  if (micro->contains("grid") || solver->contains("mesh_size"))
    throw InputError("solver.target_error", format_number(target),
                     "give either target_error (engine = \"auto\") or a resolution (grid / mesh_size), not both");
  const studies::RvePhases phases = studies::parse_rve_phases(scene);
  if (!phases.has_fiber) throw InputError("phases.fiber", "", "missing");
  const MaterialPtr& matrix = phases.matrix;
  const MaterialPtr& fiber = phases.fiber;
  const double kg = matrix->initial_bulk_modulus() / matrix->initial_shear_modulus();
  const double contrast = fiber->initial_shear_modulus() / matrix->initial_shear_modulus();
  double target_vf = 0.0;
  std::string note;
  const rve::Section section = studies::parse_fe_section(*micro, target_vf, note);
  // Error models of the benchmark cell (circle, VF 0.23, α = 45°, λ = 1.5; BENCHMARKS.md):
  //   FFT (rotated, composite voxels, first order): e ≈ c / n, with c set by the fiber/matrix shear
  //     contrast, not by K/G (the ecoflex gap is the same at K/G = 1e2 … 1.2e5):
  //     c = 6.2e-3 at contrast 5.9 (PDMS), 0.067 at 226 (ecoflex) → c ≈ 6.2e-3 (contrast / 5.9)^0.65.
  //   FE (P2+bubble/P1, order 3.3): e ≈ 1e-5 (4/d)^3.3 with mesh_size = L/d; a factor 10 of
  //     safety for cells with corners (rectangular fibers: lower regularity) → d = 4 (1e-4/e)^(1/3.3).
  // Cost (one thread, 5 load steps): FFT 16² ≈ 0.25 s, ×≈5 per doubling of n, ×≈6 for nearly
  // incompressible matrices (K/G > 1e4: more Newton and Krylov iterations); FE L/4 ≈ 1 s, ×≈3 per
  // doubling of d.
  const double c_fft = 6.2e-3 * std::pow(std::max(contrast, 1.0) / 5.9, 0.65);
  int n = 16;
  while (c_fft / n > target && n < 1024) n *= 2;
  const double fft_cost = 0.25 * std::pow(5.0, std::log2(n / 16.0)) * (kg > 1e4 ? 6.0 : 1.0);
  double d = 4.0;
  if (target < 1e-4) d = std::ceil(4.0 * std::pow(1e-4 / target, 1.0 / 3.3));
  const double fe_cost = 1.0 * std::pow(3.0, std::log2(d / 4.0));
  std::ostringstream os;
  if (fft_cost <= fe_cost) {
    toml::array g;
    g.push_back(n);
    g.push_back(int(std::lround(n * section.L2 / section.L1)));
    micro->insert_or_assign("grid", std::move(g));
    solver->erase("target_error");
    solver->erase("engine");
    os << "engine auto: FFT " << n << "² for target error " << target << " (matrix K/G " << kg << ", shear contrast "
       << contrast << ")";
    why = os.str();
    return "fft";
  }
  solver->erase("target_error");
  solver->insert_or_assign("engine", "fe");
  solver->insert_or_assign("mesh_size", section.L1 / d);
  solver->insert_or_assign("interface_size", section.L1 / (3.0 * d));
  os << "engine auto: FE, mesh_size L/" << d << " for target error " << target << " (matrix K/G " << kg
       << ", shear contrast " << contrast << ")";
  why = os.str();
  return "fe";
}

int run_rve_fe(const CommandOptions& options, const LoadedScene& scene) {
  const auto wall_start = std::chrono::steady_clock::now();
  const toml::table& micro = studies::rve_microstructure(scene.table);
  const studies::RvePhases phases = studies::parse_rve_phases(scene.table);
  const MaterialPtr& matrix = phases.matrix;
  const MaterialPtr& fiber = phases.fiber;
  double target_vf = 0.0;
  std::string geometry_note;
  const rve::Section section = studies::parse_fe_section(micro, target_vf, geometry_note);
  if (target_vf > 0.0 && !phases.has_fiber) throw InputError("phases.fiber", "", "missing (the cell has fibers)");
  const double alpha = studies::microstructure_fiber_angle(micro);
  const studies::FeRveSettings settings = studies::parse_fe_rve_solver(scene.table, section.L1);

  const bool microstructure_only = studies::parse_rve_output(scene.table, nullptr).microstructure_only;
  MixedControl control;
  if (!microstructure_only) control = studies::parse_rve_load(scene.table);
  const studies::RveOutputSettings output = studies::parse_rve_output(scene.table, microstructure_only ? nullptr : &control);
  const std::string& fields_mode = output.fields_mode;
  std::filesystem::create_directories(options.out);

  const auto mesh_start = std::chrono::steady_clock::now();
  nlohmann::json mesh_json;
  io::UnstructuredMesh fmesh;
  std::vector<int> phase;
  double fiber_measure = 0.0, cell_measure = section.L1 * section.L2;
  std::unique_ptr<rve::SectionMesh> mesh2d;
  std::unique_ptr<rve::CellMesh> mesh3d;
  if (!settings.three_d) {
    mesh2d = std::make_unique<rve::SectionMesh>(rve::mesh_section(section, settings.mesh));
    const rve::SectionMesh& mesh = *mesh2d;
    const rve::SectionMeshQuality& q = mesh.quality;
    mesh_json = {{"elements", mesh.num_elements()},
                 {"nodes", mesh.num_nodes()},
                 {"vertices", mesh.vertices},
                 {"element_type", "T6 (6-node triangle, curved interfaces)"},
                 {"mesh_size", settings.mesh.mesh_size},
                 {"interface_size", settings.mesh.interface_size},
                 {"min_angle_deg", q.min_angle_deg},
                 {"max_angle_deg", q.max_angle_deg},
                 {"min_radius_ratio", q.min_radius_ratio},
                 {"mean_radius_ratio", q.mean_radius_ratio},
                 {"min_edge", q.min_edge},
                 {"max_edge", q.max_edge},
                 {"refinement_passes", q.refinement_passes},
                 {"mirrored_boundary_points", q.mirrored_points},
                 {"max_pairing_error", q.max_pairing_error},
                 {"fiber_area_error", q.fiber_area_error},
                 {"refined_corners", q.refined_corners},
                 {"min_corner_size", q.min_corner_size}};
    fmesh = field_mesh(mesh);
    phase = mesh.phase;
    fiber_measure = mesh.area(1);
  } else {
    mesh3d = std::make_unique<rve::CellMesh>(rve::mesh_cell(section, settings.mesh3d));
    const rve::CellMesh& mesh = *mesh3d;
    const rve::CellMeshQuality& q = mesh.quality;
    mesh_json = {{"elements", mesh.num_elements()},
                 {"nodes", mesh.num_nodes()},
                 {"vertices", mesh.vertices},
                 {"element_type", "Tet10 (10-node tetrahedron, curved interfaces)"},
                 {"cell_length", mesh.L3},
                 {"mesh_size", settings.mesh3d.mesh_size},
                 {"interface_size", settings.mesh3d.interface_size},
                 {"min_dihedral_deg", q.min_dihedral_deg},
                 {"max_dihedral_deg", q.max_dihedral_deg},
                 {"min_radius_ratio", q.min_radius_ratio},
                 {"mean_radius_ratio", q.mean_radius_ratio},
                 {"min_edge", q.min_edge},
                 {"max_edge", q.max_edge},
                 {"periodic_copies", q.periodic_copies},
                 {"max_pairing_error", q.max_pairing_error},
                 {"fiber_volume_error", q.fiber_volume_error},
                 {"aspect_stretch", q.aspect_stretch},
                 {"mesh_seed", q.seed_used}};
    fmesh = field_mesh(mesh);
    phase = mesh.phase;
    fiber_measure = mesh.volume(1);
    cell_measure *= mesh.L3;
  }
  mesh_json["mesh_time_s"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - mesh_start).count();
  const int num_elements = int(phase.size());
  const char* element_name = settings.three_d ? "Tet10" : "T6";

  if (microstructure_only) {
    io::FieldWriter writer(options.out / "fields", fmesh);
    writer.begin_step(0.0);
    writer.add("phase", std::span<const int>(phase), io::Centering::cell);
    writer.end_step();
    writer.close();
    nlohmann::json summary = io::summary_base("rve", scene.file, scene.table);
    summary["engine"] = "fe";
    summary["microstructure_only"] = true;
    io::set_run_status(summary, true, "");
    summary["cell_size"] = {section.L1, section.L2};
    summary["volume_fraction_target"] = target_vf;
    summary["volume_fraction_achieved"] = fiber_measure / cell_measure;
    summary["geometry"] = geometry_note;
    summary["mesh"] = mesh_json;
    io::write_summary(options.out, summary);
    if (!options.quiet) std::cerr << "softhom rve: mesh written to " << (options.out / "fields.xdmf").string() << "\n";
    return 0;
  }

  std::unique_ptr<rve::FeRveSolver> solver_ptr =
      mesh2d ? std::make_unique<rve::FeRveSolver>(std::move(*mesh2d), matrix, fiber, alpha, control.frame, settings.solver)
             : std::make_unique<rve::FeRveSolver>(std::move(*mesh3d), matrix, fiber, alpha, control.frame, settings.solver);
  rve::FeRveSolver& solver = *solver_ptr;
  const double t_end = control.times.back();
  std::unique_ptr<io::FieldWriter> writer;
  if (fields_mode != "none") {
    writer = std::make_unique<io::FieldWriter>(options.out / "fields", fmesh);
    set_rve_field_attributes(*writer, alpha, std::string(element_name) + " mesh, node coordinates in the grid frame");
  }
  auto want_fields = [&](double t) { return output.wants_fields(t, t_end); };
  RveRecorder record(options.out, studies::rve_response_columns());
  Progress progress(options.quiet);
  auto on_step = [&](const rve::RveStep& s, const rve::FeFields* f) {
    record.record(s, studies::rve_response_row(s));
    if (f && writer) {
      writer->begin_step(s.t);
      writer->add("displacement", f->displacement, 3, io::Centering::node, "mm");
      writer->add("F", f->F, 9, io::Centering::cell, "1");
      writer->add("P", f->P, 9, io::Centering::cell, "MPa");
      writer->add("sigma", f->sigma, 9, io::Centering::cell, "MPa");
      writer->add("von_mises", f->von_mises, 1, io::Centering::cell, "MPa");
      writer->add("J", f->J, 1, io::Centering::cell, "1");
      writer->add("phase", std::span<const int>(f->phase), io::Centering::cell);
      writer->end_step();
    }
    progress.update(rve_progress_line("[rve fe " + scene.name + "] ", s, t_end));
    stop_point(record.steps.size() - 1);
  };
  const rve::RveRunResult result = run_rve_engine(solver, control, on_step, want_fields, record);
  progress.finish();
  for (const auto& line : result.log)
    if (!options.quiet) std::cerr << "[rve fe " << scene.name << "] " << line << "\n";
  record.csv.flush();
  if (writer) writer->close();
  const nlohmann::json& step_log = record.step_log;

  mesh_json["equations"] = solver.num_equations();
  mesh_json["matrix_nonzeros"] = solver.matrix_nonzeros();
  nlohmann::json summary = io::summary_base("rve", scene.file, scene.table);
  summary["engine"] = "fe";
  // The FFT engine's keys, with their FE meaning (no grid: the mesh statistics are under "mesh").
  summary["grid"] = nullptr;
  summary["ranks"] = 1;  // the FE engine runs on one process
  summary["voxels"] = nullptr;
  summary["cell_size"] = {section.L1, section.L2};
  summary["geometry"] = geometry_note;
  summary["volume_fraction_target"] = target_vf;
  summary["volume_fraction_achieved"] = solver.achieved_volume_fraction();
  summary["fiber_angle_deg"] = alpha;
  summary["matrix"] = matrix->describe();
  summary["fiber"] = fiber->describe();
  summary["load"] = control.name;
  summary["discretization"] = settings.three_d ? "fe-tet10-p0"
                             : settings.solver.pressure == rve::FePressure::p0 ? "fe-t6-p0" : "fe-t6+bubble-p1";
  summary["quadrature_points"] = settings.three_d ? 4 : 6;
  summary["solver"] = std::string("newton-") + solver.linear_solver();
  summary["reference_medium"] = nullptr;
  summary["krylov_operator"] = nullptr;  // FFT-engine keys: same summary contract
  summary["tangent_precision"] = nullptr;
  summary["preconditioner"] = nullptr;
  summary["volumetric"] = nullptr;
  summary["solver_memory_by_array"] = nullptr;  // FFT engine only
  summary["solver_bytes_per_voxel"] = nullptr;
  summary["phase_image_bytes_per_rank"] = nullptr;  // FFT engine only (its voxel image)
  summary["indefinite_solver"] = nullptr;
  summary["composite_tangent"] = nullptr;
  summary["tolerance"] = settings.solver.tolerance;
  summary["fft"] = nullptr;
  summary["fft_planning_s"] = 0.0;
  summary["mesh"] = mesh_json;
  summary["factorizations"] = solver.factorizations();
  summary["linear_solver_time_s"] = solver.factorization_seconds();
  summary["assembly_time_s"] = solver.assembly_seconds();
  summary["columns"] = io::columns_json(record.csv.table().columns());
  if (fields_mode != "none") summary["fields_file"] = "fields.xdmf";
  summary["checkpoint"] = nullptr;  // FFT engine only (--resume)
  if (!finish_rve_summary(summary, result, step_log, solver.memory_bytes(), options.out, wall_start))
    return run_exit_code(false);
  if (!options.quiet)
    std::cerr << "softhom rve (fe): " << num_elements << " " << element_name << " elements, " << result.steps.size() - 1
              << " steps, " << result.newton_iterations << " Newton iterations, " << result.wall_seconds << " s → "
              << options.out.string() << "\n";
  return 0;
}

}  // namespace softhom::app
