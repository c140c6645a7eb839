// RVE scene tables → FFT solver inputs (moved from apps/cmd_rve.cpp; see rve_scene.hpp).
#include "softhom/studies/rve_scene.hpp"

#include <cmath>

#include "softhom/io/fields.hpp"
#include "softhom/io/scene.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/materials/library.hpp"

namespace softhom::studies {
namespace {

std::vector<int> grid_of(const toml::table& t, const std::string& path) {
  std::vector<int> n;
  const auto* arr = t["grid"].as_array();
  if (!arr) {
    const int g = int(io::get_number_or(t, "grid", path, 64));
    return {g, g};
  }
  for (const auto& e : *arr) {
    const auto v = e.value<double>();
    if (!v || *v < 1 || *v != std::floor(*v)) throw InputError(path + ".grid", "", "entries must be positive integers");
    n.push_back(int(*v));
  }
  if (n.size() < 2 || n.size() > 3) throw InputError(path + ".grid", "", "give [n1, n2] (section) or [n1, n2, n3]");
  return n;
}

/// The phase image (grid frame) of [microstructure]; `target_vf` is the requested fraction.
rve::PhaseImage build_phase_image_impl(const toml::table& t, double& target_vf, std::string& geometry_note) {
  const std::string p = "microstructure";
  io::check_keys(t, p, {"shape", "arrangement", "volume_fraction", "radius", "width", "height", "cell_size",
                        "section_rotation_deg", "fiber_count", "min_gap", "seed", "fiber_angle_deg", "grid", "image"});
  const std::vector<int> n = grid_of(t, p);
  if (const auto* img = t["image"].as_table()) {
    io::check_keys(*img, p + ".image", {"file", "dataset", "size"});
    const std::string file = io::get_string_or(*img, "file", p + ".image", "");
    const std::string dataset = io::get_string_or(*img, "dataset", p + ".image", "/phase");
    if (file.empty()) throw InputError(p + ".image.file", "", "missing");
    const io::Dataset d = io::read_dataset(file, dataset);
    rve::PhaseImage im;
    // C order: [n3][n2][n1] or [n2][n1] → i1 fastest, as in PhaseImage.
    if (d.dims.size() == 2) im.n = {int(d.dims[1]), int(d.dims[0]), 1};
    else if (d.dims.size() == 3) im.n = {int(d.dims[2]), int(d.dims[1]), int(d.dims[0])};
    else throw InputError(p + ".image.dataset", dataset, "must be 2D or 3D");
    im.fiber_fraction = d.values;
    for (double& v : im.fiber_fraction)
      if (!(v >= 0.0 && v <= 1.0)) throw InputError(p + ".image.dataset", dataset, "values must be fiber fractions in [0, 1]");
    const double h = 1.0 / im.n[0];
    im.size = {1.0, im.n[1] * h, im.n[2] * h};
    target_vf = im.volume_fraction();
    geometry_note = "imported " + file + ":" + dataset;
    return im;
  }
  target_vf = io::get_number_or(t, "volume_fraction", p, 0.0);
  if (target_vf == 0.0) {
    rve::PhaseImage im;
    im.n = {n[0], n[1], n.size() == 3 ? n[2] : 1};
    const double h = 1.0 / n[0];
    im.size = {1.0, n[1] * h, im.n[2] * h};
    im.fiber_fraction.assign(im.voxels(), 0.0);
    geometry_note = "matrix only";
    return im;
  }
  std::string label;
  const rve::FiberCellSpec spec = parse_fiber_cell_spec(t, p, label);
  const rve::Section section = rve::generate_section(spec, p);
  // Square pixels: n2 follows the cell aspect ratio when only n1 matters.
  rve::PhaseImage im = rve::voxelize_section(section, n[0], n[1]);
  if (n.size() == 3 && n[2] > 1) im = rve::extrude(im, n[2]);
  geometry_note = label + ", cell " + std::to_string(section.L1) + " x " +
                  std::to_string(section.L2);
  return im;
}

}  // namespace

rve::FiberCellSpec parse_fiber_cell_spec(const toml::table& t, const std::string& p, std::string& label) {
  rve::FiberCellSpec spec;
  spec.volume_fraction = io::get_number_or(t, "volume_fraction", p, 0.0);
  const std::string shape = io::get_string_or(t, "shape", p, "circle");
  if (shape == "circle") spec.shape = rve::SectionShape::circle;
  else if (shape == "rectangle" || shape == "square") spec.shape = rve::SectionShape::rectangle;
  else throw InputError(p + ".shape", shape, "circle, rectangle or square");
  const std::string arr = io::get_string_or(t, "arrangement", p, "square");
  if (arr == "square") spec.arrangement = rve::Arrangement::square;
  else if (arr == "hexagonal") spec.arrangement = rve::Arrangement::hexagonal;
  else if (arr == "random") spec.arrangement = rve::Arrangement::random;
  else throw InputError(p + ".arrangement", arr, "square, hexagonal or random");
  spec.radius = io::get_number_or(t, "radius", p, 0.0);
  spec.width = io::get_number_or(t, "width", p, 0.0);
  spec.height = io::get_number_or(t, "height", p, shape == "square" ? spec.width : 0.0);
  if (t.contains("cell_size")) spec.cell_size = io::get_number(t, "cell_size", p);
  spec.section_rotation_deg = io::get_number_or(t, "section_rotation_deg", p, 0.0);
  spec.fiber_count = int(io::get_number_or(t, "fiber_count", p, 1));
  spec.min_gap = io::get_number_or(t, "min_gap", p, 0.0);
  spec.seed = std::uint64_t(io::get_number_or(t, "seed", p, 1));
  label = shape + " fibers, " + arr + " arrangement";
  return spec;
}

rve::PhaseImage build_phase_image(const toml::table& t, double& target_vf, std::string& geometry_note) {
  return build_phase_image_impl(t, target_vf, geometry_note);
}

rve::FftSolverOptions parse_fft_solver_options(const toml::table& scene, std::filesystem::path& wisdom) {
  rve::FftSolverOptions o;
  const auto* t = scene["solver"].as_table();
  if (!t) return o;
  const std::string p = "solver";
  io::check_keys(*t, p, {"discretization", "scheme", "reference", "tolerance", "krylov_tolerance", "max_newton_iterations",
                         "max_krylov_iterations", "max_fixed_point_iterations", "max_cutbacks", "fftw", "fftw_wisdom", "mixed_pressure"});
  const std::string d = io::get_string_or(*t, "discretization", p, "rotated");
  try {
    o.discretization = fft::parse_discretization(d);
  } catch (const std::invalid_argument&) {
    throw InputError(p + ".discretization", d, "spectral, rotated or hex");
  }
  const std::string s = io::get_string_or(*t, "scheme", p, "newton-cg");
  if (s == "newton-cg") o.scheme = rve::FftScheme::newton_cg;
  else if (s == "moulinec-suquet") o.scheme = rve::FftScheme::moulinec_suquet;
  else throw InputError(p + ".scheme", s, "newton-cg or moulinec-suquet");
  const std::string r = io::get_string_or(*t, "reference", p, "mean-tangent");
  if (r == "mean-tangent") o.reference = rve::ReferenceMedium::mean_tangent;
  else if (r == "isotropic") o.reference = rve::ReferenceMedium::isotropic;
  else if (r == "geometric") o.reference = rve::ReferenceMedium::geometric;
  else throw InputError(p + ".reference", r, "mean-tangent, geometric or isotropic");
  o.tolerance = io::get_number_or(*t, "tolerance", p, o.tolerance);
  if (!(o.tolerance > 0 && o.tolerance < 1)) throw InputError(p + ".tolerance", std::to_string(o.tolerance), "must lie in (0, 1)");
  o.krylov_tolerance = io::get_number_or(*t, "krylov_tolerance", p, o.krylov_tolerance);
  o.max_newton_iterations = int(io::get_number_or(*t, "max_newton_iterations", p, o.max_newton_iterations));
  o.max_krylov_iterations = int(io::get_number_or(*t, "max_krylov_iterations", p, o.max_krylov_iterations));
  o.max_fixed_point_iterations = int(io::get_number_or(*t, "max_fixed_point_iterations", p, o.max_fixed_point_iterations));
  o.max_cutbacks = int(io::get_number_or(*t, "max_cutbacks", p, o.max_cutbacks));
  o.mixed_pressure = io::get_bool_or(*t, "mixed_pressure", p, o.mixed_pressure);
  if (o.max_newton_iterations < 1) throw InputError(p + ".max_newton_iterations", "", "must be >= 1");
  if (o.max_cutbacks < 0) throw InputError(p + ".max_cutbacks", "", "must be >= 0");
  const std::string f = io::get_string_or(*t, "fftw", p, "measure");
  if (f == "estimate") o.plan.rigor = fft::PlanRigor::estimate;
  else if (f == "measure") o.plan.rigor = fft::PlanRigor::measure;
  else if (f == "patient") o.plan.rigor = fft::PlanRigor::patient;
  else throw InputError(p + ".fftw", f, "estimate, measure or patient");
  wisdom = io::get_string_or(*t, "fftw_wisdom", p, "");
  o.plan.wisdom_file = wisdom;
  return o;
}

std::vector<std::string> rve_response_columns() {
  std::vector<std::string> c{"t"};
  auto tensor = [&](const std::string& name) {
    for (int i = 1; i <= 3; ++i)
      for (int j = 1; j <= 3; ++j) c.push_back(name + std::to_string(i) + std::to_string(j));
  };
  tensor("F");
  tensor("P");
  tensor("sigma");
  c.push_back("fiber_angle_deg");
  c.push_back("delta_fiber_angle_deg");
  tensor("P_matrix_");
  tensor("P_fiber_");
  tensor("sigma_matrix_");
  tensor("sigma_fiber_");
  c.push_back("newton_iterations");
  c.push_back("krylov_iterations");
  c.push_back("substeps");
  return c;
}

std::vector<double> rve_response_row(const rve::RveStep& s) {
  std::vector<double> r{s.t};
  auto tensor = [&](const Mat3& m) {
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) r.push_back(m(i, j));
  };
  tensor(s.F);
  tensor(s.P);
  tensor(s.sigma);
  r.push_back(s.fiber_angle_deg);
  r.push_back(s.fiber_angle_change_deg);
  tensor(s.P_matrix);
  tensor(s.P_fiber);
  tensor(s.sigma_matrix);
  tensor(s.sigma_fiber);
  r.push_back(s.newton_iterations);
  r.push_back(s.krylov_iterations);
  r.push_back(s.substeps);
  return r;
}

RveSceneSetup parse_rve_scene(const toml::table& scene, bool with_load) {
  io::check_keys(scene, "", {"description", "microstructure", "phases", "load", "solver", "output"});
  const auto* micro = scene["microstructure"].as_table();
  if (!micro) throw InputError("microstructure", "", "missing [microstructure] table");
  const auto* phases = scene["phases"].as_table();
  if (!phases) throw InputError("phases", "", "missing [phases] table ([phases.matrix], [phases.fiber])");
  io::check_keys(*phases, "phases", {"matrix", "fiber"});
  const auto* matrix_table = (*phases)["matrix"].as_table();
  if (!matrix_table) throw InputError("phases.matrix", "", "missing");
  RveSceneSetup s;
  s.matrix = build_material(io::parse_material(*matrix_table, "phases.matrix"));
  const auto* fiber_table = (*phases)["fiber"].as_table();
  s.fiber = fiber_table ? build_material(io::parse_material(*fiber_table, "phases.fiber")) : s.matrix;
  s.image = build_phase_image(*micro, s.target_vf, s.geometry_note);
  if (s.target_vf > 0.0 && !fiber_table) throw InputError("phases.fiber", "", "missing (the cell has fibers)");
  s.fiber_angle_deg = io::get_number_or(*micro, "fiber_angle_deg", "microstructure", 0.0);
  if (with_load) {
    const auto* load_table = scene["load"].as_table();
    if (!load_table) throw InputError("load", "", "missing [load] table");
    s.control = io::parse_load(*load_table, "load");
  }
  std::filesystem::path wisdom;
  s.solver = parse_fft_solver_options(scene, wisdom);
  return s;
}

}  // namespace softhom::studies
