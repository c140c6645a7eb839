// RVE scene tables → FFT solver inputs (moved from apps/cmd_rve.cpp; see rve_scene.hpp).
#include "softhom/studies/rve_scene.hpp"

#include <cmath>
#include <functional>

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

std::string dims_string(const std::vector<std::size_t>& d) {
  std::string s = "[";
  for (std::size_t i = 0; i < d.size(); ++i) s += (i ? ", " : "") + std::to_string(d[i]);
  return s + "]";
}

std::string voxel_string(const rve::PhaseImage& im, std::size_t v) {
  const std::size_t n1 = std::size_t(im.n[0]), n2 = std::size_t(im.n[1]);
  return "voxel (i1, i2, i3) = (" + std::to_string(v % n1) + ", " + std::to_string((v / n1) % n2) + ", " +
         std::to_string(v / (n1 * n2)) + ")";
}

/// A number or a list of three positive numbers (x, y, z order) → 3 values; `field` names errors.
std::array<double, 3> triple_of(const std::vector<double>& v, const std::string& field) {
  if (v.size() != 1 && v.size() != 3) throw InputError(field, std::to_string(v.size()) + " values", "give one number or three (x, y, z)");
  std::array<double, 3> out{v[0], v.size() == 3 ? v[1] : v[0], v.size() == 3 ? v[2] : v[0]};
  for (double x : out)
    if (!(std::isfinite(x) && x > 0.0)) throw InputError(field, std::to_string(x), "must be finite and > 0");
  return out;
}

std::vector<double> numbers_of(const toml::node& node, const std::string& field) {
  std::vector<double> v;
  if (const auto x = node.value<double>()) return {*x};
  const auto* arr = node.as_array();
  if (!arr) throw InputError(field, "", "must be a number or an array of numbers");
  for (const auto& e : *arr) {
    const auto x = e.value<double>();
    if (!x) throw InputError(field, "", "must be a number or an array of numbers");
    v.push_back(*x);
  }
  return v;
}

/// Reads one dataset of the image file, turning I/O failures into InputErrors on `field`.
io::Dataset read_image_dataset(const std::filesystem::path& file, const std::string& name, const std::string& field) {
  try {
    return io::read_dataset(file, name);
  } catch (const std::runtime_error& e) {
    throw InputError(field, name, e.what());
  }
}

/// Reads a per-voxel vector dataset (dims = image dims + [3]) into unit vectors (zero vectors kept
/// where `zero_ok(v)`), or throws InputError on `field`.
std::vector<Eigen::Vector3d> read_vector_field(const std::filesystem::path& file, const std::string& name,
                                               const std::string& field, const std::vector<std::size_t>& image_dims,
                                               const rve::PhaseImage& im, const std::function<bool(std::size_t)>& zero_ok) {
  const io::Dataset d = read_image_dataset(file, name, field);
  std::vector<std::size_t> want = image_dims;
  want.push_back(3);
  if (d.dims != want) throw InputError(field, name + " " + dims_string(d.dims), "expected dims " + dims_string(want) + " (image dims + 3 components)");
  std::vector<Eigen::Vector3d> out(im.voxels());
  for (std::size_t v = 0; v < out.size(); ++v) {
    const Eigen::Vector3d a(d.values[3 * v], d.values[3 * v + 1], d.values[3 * v + 2]);
    const double len = a.norm();
    if (!std::isfinite(len)) throw InputError(field, name, "non-finite vector at " + voxel_string(im, v));
    if (len > 0.0) out[v] = a / len;
    else if (zero_ok(v)) out[v].setZero();
    else throw InputError(field, name, "zero vector at " + voxel_string(im, v) + " (fiber fraction " + std::to_string(im.fiber_fraction[v]) + ")");
  }
  return out;
}

}  // namespace

rve::PhaseImage import_phase_image(const toml::table& img, const std::string& p, std::string& geometry_note) {
  io::check_keys(img, p, {"file", "dataset", "matrix_id", "fiber_id", "normal_dataset", "direction_dataset", "voxel_size",
                          "cell_size", "size"});
  std::filesystem::path file = io::get_string_or(img, "file", p, "");
  if (file.empty()) throw InputError(p + ".file", "", "missing: the HDF5 file of the phase image");
  // Relative paths are relative to the scene file (when the scene came from a file).
  if (file.is_relative() && img.source().path && !img.source().path->empty())
    file = std::filesystem::path(*img.source().path).parent_path() / file;
  std::error_code ec;
  if (!std::filesystem::is_regular_file(file, ec)) throw InputError(p + ".file", file.string(), "no such file");
  const std::string dataset = io::get_string_or(img, "dataset", p, "/phase");
  const io::Dataset d = read_image_dataset(file, dataset, p + ".dataset");

  rve::PhaseImage im;
  // C order: [n3][n2][n1] or [n2][n1] → i1 fastest, as in PhaseImage.
  if (d.dims.size() == 2) im.n = {int(d.dims[1]), int(d.dims[0]), 1};
  else if (d.dims.size() == 3) im.n = {int(d.dims[2]), int(d.dims[1]), int(d.dims[0])};
  else throw InputError(p + ".dataset", dataset + " " + dims_string(d.dims), "must be 2D [n2][n1] (a section) or 3D [n3][n2][n1]");
  for (std::size_t k : d.dims)
    if (k == 0) throw InputError(p + ".dataset", dataset + " " + dims_string(d.dims), "has an empty dimension");

  // Integer datasets hold phase ids; floating-point datasets hold fiber volume fractions in [0, 1].
  im.fiber_fraction.resize(d.values.size());
  if (d.integer) {
    const double matrix_id = io::get_number_or(img, "matrix_id", p, 0.0), fiber_id = io::get_number_or(img, "fiber_id", p, 1.0);
    if (matrix_id == fiber_id) throw InputError(p + ".fiber_id", std::to_string(int(fiber_id)), "must differ from matrix_id");
    for (std::size_t v = 0; v < d.values.size(); ++v) {
      const double id = d.values[v];
      if (id == matrix_id) im.fiber_fraction[v] = 0.0;
      else if (id == fiber_id) im.fiber_fraction[v] = 1.0;
      else
        throw InputError(p + ".dataset", "phase id " + std::to_string(static_cast<long long>(id)) + " at " + voxel_string(im, v),
                         "unknown phase id (matrix_id = " + std::to_string(int(matrix_id)) + ", fiber_id = " +
                             std::to_string(int(fiber_id)) + ")");
    }
  } else {
    if (img.contains("matrix_id") || img.contains("fiber_id"))
      throw InputError(p + (img.contains("matrix_id") ? ".matrix_id" : ".fiber_id"), dataset,
                       "phase ids need an integer dataset (this one holds floating-point fiber fractions)");
    for (std::size_t v = 0; v < d.values.size(); ++v) {
      const double f = d.values[v];
      if (!(f >= 0.0 && f <= 1.0))
        throw InputError(p + ".dataset", std::to_string(f) + " at " + voxel_string(im, v),
                         "fiber fractions must lie in [0, 1] (store phase ids as an integer dataset)");
      im.fiber_fraction[v] = f;
    }
  }

  // Voxel size: scene key voxel_size or cell_size, else the dataset's attribute of the same names (as
  // written by `softhom rve` with microstructure_only), else cubic voxels with L1 = 1.
  const bool has_voxel = img.contains("voxel_size"), has_cell = img.contains("cell_size") || img.contains("size");
  if (has_voxel && has_cell) throw InputError(p + ".cell_size", "", "give either voxel_size or cell_size, not both");
  std::array<double, 3> h{1.0 / im.n[0], 1.0 / im.n[0], 1.0 / im.n[0]};
  auto from_cell = [&](const std::array<double, 3>& L) {
    for (int k = 0; k < 3; ++k) h[k] = L[k] / im.n[k];
  };
  if (has_voxel) h = triple_of(numbers_of(*img.get("voxel_size"), p + ".voxel_size"), p + ".voxel_size");
  else if (has_cell) {
    const std::string key = img.contains("cell_size") ? "cell_size" : "size";
    const std::vector<double> L = numbers_of(*img.get(key), p + "." + key);
    if (L.size() == 1) h = triple_of({L[0] / im.n[0]}, p + "." + key);  // L1; cubic voxels
    else from_cell(triple_of(L, p + "." + key));
  } else if (auto it = d.attributes.find("voxel_size"); it != d.attributes.end()) {
    h = triple_of(it->second, p + ".dataset attribute voxel_size");
  } else if (auto it2 = d.attributes.find("cell_size"); it2 != d.attributes.end()) {
    from_cell(triple_of(it2->second, p + ".dataset attribute cell_size"));
  }
  for (int k = 0; k < 3; ++k) im.size[k] = h[k] * im.n[k];

  // Interface normals of composite voxels (optional; without them the solver estimates −∇φ).
  if (const std::string normals = io::get_string_or(img, "normal_dataset", p, ""); !normals.empty()) {
    if (d.integer) throw InputError(p + ".normal_dataset", normals, "normals apply to fiber-fraction images only");
    im.normal = read_vector_field(file, normals, p + ".normal_dataset", d.dims, im, [](std::size_t) { return true; });
  }
  // Per-voxel fiber direction (grid frame): required non-zero wherever there is fiber.
  if (const std::string dirs = io::get_string_or(img, "direction_dataset", p, ""); !dirs.empty())
    im.fiber_direction = read_vector_field(file, dirs, p + ".direction_dataset", d.dims, im,
                                           [&](std::size_t v) { return im.fiber_fraction[v] == 0.0; });
  geometry_note = "imported " + file.string() + ":" + dataset + (d.integer ? " (phase ids)" : " (fiber fractions)");
  return im;
}

namespace {

/// The phase image (grid frame) of [microstructure]; `target_vf` is the requested fraction.
rve::PhaseImage build_phase_image_impl(const toml::table& t, double& target_vf, std::string& geometry_note) {
  const std::string p = "microstructure";
  io::check_keys(t, p, {"shape", "arrangement", "volume_fraction", "radius", "width", "height", "cell_size",
                        "section_rotation_deg", "fiber_count", "min_gap", "seed", "fiber_angle_deg", "grid", "image"});
  const std::vector<int> n = grid_of(t, p);
  if (const auto* img = t["image"].as_table()) {
    rve::PhaseImage im = import_phase_image(*img, p + ".image", geometry_note);
    // An explicit grid must agree with the image (it is otherwise taken from the image).
    if (t.contains("grid")) {
      const std::array<int, 3> g{n[0], n[1], n.size() == 3 ? n[2] : 1};
      if (g != im.n)
        throw InputError(p + ".grid", "[" + std::to_string(g[0]) + ", " + std::to_string(g[1]) + ", " + std::to_string(g[2]) + "]",
                         "contradicts the image grid [" + std::to_string(im.n[0]) + ", " + std::to_string(im.n[1]) + ", " +
                             std::to_string(im.n[2]) + "] (omit grid with an image)");
    }
    target_vf = im.volume_fraction();
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
                         "max_krylov_iterations", "max_fixed_point_iterations", "max_cutbacks", "max_continuation_iterations", "indefinite_solver", "minres_below", "minres_fallback", "krylov_operator", "tangent_precision", "fftw", "fftw_wisdom", "mixed_pressure"});
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
  o.max_continuation_iterations =
      int(io::get_number_or(*t, "max_continuation_iterations", p, o.max_continuation_iterations));
  if (o.max_continuation_iterations < 0)
    throw InputError(p + ".max_continuation_iterations", std::to_string(o.max_continuation_iterations), "must be >= 0");
  const std::string kop = io::get_string_or(*t, "krylov_operator", p, "stencil");
  if (kop == "stencil") o.krylov_operator = rve::KrylovOperator::stencil;
  else if (kop == "fourier") o.krylov_operator = rve::KrylovOperator::fourier;
  else throw InputError(p + ".krylov_operator", kop, "stencil or fourier");
  const std::string tp = io::get_string_or(*t, "tangent_precision", p, rve::to_string(o.tangent_precision));
  if (tp == "double") o.tangent_precision = rve::TangentPrecision::double_precision;
  else if (tp == "single") o.tangent_precision = rve::TangentPrecision::single_precision;
  else throw InputError(p + ".tangent_precision", tp, "double or single");
  const std::string ind = io::get_string_or(*t, "indefinite_solver", p, "minres");
  if (ind == "minres") o.indefinite_solver = rve::IndefiniteSolver::minres;
  else if (ind == "shift") o.indefinite_solver = rve::IndefiniteSolver::shift;
  else throw InputError(p + ".indefinite_solver", ind, "minres or shift");
  o.minres_below = io::get_number_or(*t, "minres_below", p, o.minres_below);
  o.minres_fallback = io::get_bool_or(*t, "minres_fallback", p, o.minres_fallback);
  if (!(o.minres_below >= 0.0)) throw InputError(p + ".minres_below", std::to_string(o.minres_below), "must be >= 0");
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
  // Per-voxel fiber directions only steer the fiber-rotation measure: the solver has no per-voxel
  // material frames, so phases with fiber families of their own would silently ignore them.
  if (!s.image.fiber_direction.empty() && (!s.matrix->fiber_directions().empty() || !s.fiber->fiber_directions().empty()))
    throw InputError("microstructure.image.direction_dataset", "", "per-voxel fiber directions need isotropic phases (a phase has fiber families)");
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
