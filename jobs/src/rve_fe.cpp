// softhom rve with [solver] engine = "fe": FE homogenization of the same cell on a periodic conforming
// T6 section mesh or Tet10 cell mesh (rve/fe_solver.hpp). Same scene tables and the same response.csv
// columns and summary.json keys as the FFT engine (plus mesh statistics), so curves overlay directly.
//
// The FE [solver] keys are declared with their options in studies/rve_fe_scene.cpp (docs/keys.md);
// [microstructure].grid is ignored (it is the FFT resolution).
#include <array>
#include <chrono>
#include <iostream>
#include <memory>

#include "rve_jobs.hpp"
#include "rve_output.hpp"
#include "softhom/fe/tet10.hpp"
#include "softhom/io/fields.hpp"
#include "softhom/io/summary.hpp"
#include "softhom/rve/fe_solver.hpp"

namespace softhom::jobs {
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

/// The statistics both FE meshes report (summary.json "mesh").
template <class Mesh, class Sizes>
nlohmann::json mesh_json(const Mesh& mesh, const char* element_type, const Sizes& sizes) {
  const auto& q = mesh.quality;
  return {{"elements", mesh.num_elements()},        {"nodes", mesh.num_nodes()},
          {"vertices", mesh.vertices},              {"element_type", element_type},
          {"mesh_size", sizes.mesh_size},           {"interface_size", sizes.interface_size},
          {"min_radius_ratio", q.min_radius_ratio}, {"mean_radius_ratio", q.mean_radius_ratio},
          {"min_edge", q.min_edge},                 {"max_edge", q.max_edge},
          {"max_pairing_error", q.max_pairing_error}};
}

nlohmann::json section_mesh_json(const rve::SectionMesh& mesh, const studies::FeRveSettings& settings) {
  const rve::SectionMeshQuality& q = mesh.quality;
  nlohmann::json j = mesh_json(mesh, "T6 (6-node triangle, curved interfaces)", settings.mesh);
  j["min_angle_deg"] = q.min_angle_deg;
  j["max_angle_deg"] = q.max_angle_deg;
  j["refinement_passes"] = q.refinement_passes;
  j["mirrored_boundary_points"] = q.mirrored_points;
  j["fiber_area_error"] = q.fiber_area_error;
  j["refined_corners"] = q.refined_corners;
  j["min_corner_size"] = q.min_corner_size;
  return j;
}

nlohmann::json cell_mesh_json(const rve::CellMesh& mesh, const studies::FeRveSettings& settings) {
  const rve::CellMeshQuality& q = mesh.quality;
  nlohmann::json j = mesh_json(mesh, "Tet10 (10-node tetrahedron, curved interfaces)", settings.mesh3d);
  j["cell_length"] = mesh.L3;
  j["min_dihedral_deg"] = q.min_dihedral_deg;
  j["max_dihedral_deg"] = q.max_dihedral_deg;
  j["periodic_copies"] = q.periodic_copies;
  j["fiber_volume_error"] = q.fiber_volume_error;
  j["aspect_stretch"] = q.aspect_stretch;
  j["mesh_seed"] = q.seed_used;
  return j;
}

/// The FE cell's mesh (a section or a 3D cell), what field files and the summary say of it.
struct FeCellMesh {
  std::unique_ptr<rve::SectionMesh> section;
  std::unique_ptr<rve::CellMesh> cell;
  nlohmann::json json;
  io::UnstructuredMesh field_mesh;
  std::vector<int> phase;
  double fiber_measure = 0.0, cell_measure = 0.0;
  const char* element_name = "T6";
};

FeCellMesh mesh_fe_cell(const FeRveJob& fe) {
  const auto mesh_start = std::chrono::steady_clock::now();
  FeCellMesh m;
  m.cell_measure = fe.section.L1 * fe.section.L2;
  studies::FeRveMesh meshed = studies::mesh_fe_rve(fe);
  m.section = std::move(meshed.section);
  m.cell = std::move(meshed.cell);
  if (m.section) {
    m.json = section_mesh_json(*m.section, fe.settings);
    m.field_mesh = field_mesh(*m.section);
    m.phase = m.section->phase;
    m.fiber_measure = m.section->area(1);
  } else {
    m.json = cell_mesh_json(*m.cell, fe.settings);
    m.field_mesh = field_mesh(*m.cell);
    m.phase = m.cell->phase;
    m.fiber_measure = m.cell->volume(1);
    m.cell_measure *= m.cell->L3;
    m.element_name = "Tet10";
  }
  m.field_mesh.coordinates = vectors_in_load_frame(m.field_mesh.coordinates, fe.fiber_angle_deg);
  m.json["mesh_time_s"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - mesh_start).count();
  return m;
}

void write_fe_microstructure(const RveJob& job, const FeRveJob& fe, const FeCellMesh& mesh, Sink& sink,
                             const RunOptions& options) {
  if (std::unique_ptr<io::FieldWriter> writer = sink.open_fields("fields", mesh.field_mesh)) {
    writer->begin_step(0.0);
    writer->add("phase", std::span<const int>(mesh.phase), io::Centering::cell);
    writer->end_step();
    writer->close();
  }
  nlohmann::json summary = io::summary_base("rve", job.scene.file, job.scene.table);
  summary["engine"] = "fe";
  summary["microstructure_only"] = true;
  io::set_run_status(summary, true, "");
  summary["cell_size"] = {fe.section.L1, fe.section.L2};
  summary["volume_fraction_target"] = fe.target_vf;
  summary["volume_fraction_achieved"] = mesh.fiber_measure / mesh.cell_measure;
  summary["geometry"] = fe.geometry_note;
  summary["mesh"] = mesh.json;
  sink.write_summary(summary);
  if (!options.quiet) std::cerr << "softhom rve: mesh written to " << sink.where("fields.xdmf") << "\n";
}

void write_fe_fields(io::FieldWriter& writer, double t, const rve::FeFields& f, double fiber_angle_deg) {
  writer.begin_step(t);
  writer.add("displacement", vectors_in_load_frame(f.displacement, fiber_angle_deg), 3, io::Centering::node, "mm");
  writer.add("F", f.F, 9, io::Centering::cell, "1");
  writer.add("P", f.P, 9, io::Centering::cell, "MPa");
  writer.add("sigma", f.sigma, 9, io::Centering::cell, "MPa");
  writer.add("von_mises", f.von_mises, 1, io::Centering::cell, "MPa");
  writer.add("J", f.J, 1, io::Centering::cell, "1");
  writer.add("phase", std::span<const int>(f.phase), io::Centering::cell);
  writer.end_step();
}

/// The FE engine's summary: the FFT engine's keys with their FE meaning (no grid: the mesh statistics
/// are under "mesh"; FFT-only keys null), so that both engines' summaries have one contract.
nlohmann::json fe_summary(const RveJob& job, const FeRveJob& fe, nlohmann::json mesh_json, const rve::FeRveSolver& solver) {
  mesh_json["equations"] = solver.num_equations();
  mesh_json["matrix_nonzeros"] = solver.matrix_nonzeros();
  nlohmann::json summary = io::summary_base("rve", job.scene.file, job.scene.table);
  summary["engine"] = "fe";
  summary["grid"] = nullptr;
  summary["ranks"] = 1;  // the FE engine runs on one process
  summary["voxels"] = nullptr;
  summary["cell_size"] = {fe.section.L1, fe.section.L2};
  summary["cell"] = fe.plate ? "plate" : "periodic";
  summary["geometry"] = fe.geometry_note;
  summary["volume_fraction_target"] = fe.target_vf;
  summary["volume_fraction_achieved"] = solver.achieved_volume_fraction();
  summary["fiber_angle_deg"] = fe.fiber_angle_deg;
  summary["matrix"] = fe.phases.matrix->describe();
  summary["fiber"] = fe.phases.fiber->describe();
  summary["load"] = fe.control.name;
  summary["discretization"] = fe.settings.three_d ? "fe-tet10-p0"
                              : fe.settings.solver.pressure == rve::FePressure::p0 ? "fe-t6-p0" : "fe-t6+bubble-p1";
  summary["quadrature_points"] = fe.settings.three_d ? 4 : 6;
  summary["solver"] = std::string("newton-") + solver.linear_solver();
  for (const char* fft_only : {"reference_medium", "krylov_operator", "tangent_precision", "preconditioner", "volumetric",
                               "solver_memory_by_array", "solver_bytes_per_voxel", "phase_image_bytes_per_rank",
                               "indefinite_solver", "composite_tangent", "fft", "checkpoint"})
    summary[fft_only] = nullptr;
  summary["tolerance"] = fe.settings.solver.tolerance;
  summary["fft_planning_s"] = 0.0;
  summary["mesh"] = mesh_json;
  summary["factorizations"] = solver.factorizations();
  summary["linear_solver_time_s"] = solver.factorization_seconds();
  summary["assembly_time_s"] = solver.assembly_seconds();
  summary["columns"] = io::columns_json(studies::rve_response_columns());
  if (fe.output.fields_mode != "none") summary["fields_file"] = "fields.xdmf";
  return summary;
}

}  // namespace

bool run_fe_rve(const RveJob& job, const FeRveJob& fe, Sink& sink, const RunOptions& options) {
  const auto wall_start = std::chrono::steady_clock::now();
  sink.prepare();
  FeCellMesh mesh = mesh_fe_cell(fe);
  if (job.microstructure_only) {
    write_fe_microstructure(job, fe, mesh, sink, options);
    return true;
  }
  const double alpha = fe.fiber_angle_deg;
  auto solver = studies::make_fe_rve_solver({std::move(mesh.section), std::move(mesh.cell)}, fe);
  const double t_end = fe.control.times.back();
  std::unique_ptr<io::FieldWriter> writer;
  if (fe.output.fields_mode != "none") writer = sink.open_fields("fields", mesh.field_mesh);
  if (writer)
    set_rve_field_attributes(*writer, alpha, std::string(mesh.element_name) + " mesh");
  auto want_fields = [&](double t) { return fe.output.wants_fields(t, t_end); };
  RveRecorder record(sink, studies::rve_response_columns());
  Progress progress(options.quiet);
  auto on_step = [&](const rve::RveStep& s, const rve::FeFields* f) {
    record.record(s, studies::rve_response_row(s));
    if (f && writer) write_fe_fields(*writer, s.t, *f, alpha);
    progress.update(rve_progress_line("[rve fe " + job.scene.name + "] ", s, t_end));
    stop_point(record.steps.size() - 1);
  };
  const rve::RveRunResult result = run_rve_engine(*solver, fe.control, on_step, want_fields, record);
  progress.finish();
  for (const auto& line : result.log)
    if (!options.quiet) std::cerr << "[rve fe " << job.scene.name << "] " << line << "\n";
  sink.flush();
  if (writer) writer->close();
  nlohmann::json summary = fe_summary(job, fe, std::move(mesh.json), *solver);
  if (!finish_rve_summary(summary, result, record.step_log, solver->memory_bytes(), sink, wall_start, 0.0, job.warnings))
    return false;
  if (!options.quiet)
    std::cerr << "softhom rve (fe): " << mesh.phase.size() << " " << mesh.element_name << " elements, "
              << result.steps.size() - 1 << " steps, " << result.newton_iterations << " Newton iterations, "
              << result.wall_seconds << " s → " << sink.where("") << "\n";
  return true;
}

}  // namespace softhom::jobs
