// RVE scene tables → FFT solver inputs, declared key by key (softhom/core/keys.hpp); see rve_scene.hpp.
#include "softhom/studies/rve_scene.hpp"

#include <cmath>
#include <cstdlib>
#include <functional>

#include "softhom/io/fields.hpp"
#include "softhom/io/files.hpp"
#include "softhom/core/keys.hpp"
#include "softhom/core/mpi.hpp"
#include "softhom/materials/errors.hpp"
#include "softhom/materials/library.hpp"
#include "softhom/materials/scene_keys.hpp"
#include "softhom/rve/fft_solver_keys.hpp"
#include "softhom/rve/slab_image.hpp"

namespace softhom::studies {
namespace {

std::string dims_string(const std::vector<std::size_t>& d) {
  std::string s = "[";
  for (std::size_t i = 0; i < d.size(); ++i) s += (i ? ", " : "") + std::to_string(d[i]);
  return s + "]";
}

/// Voxel v of the image's arrays (a slab image's: counted from its first held plane) in whole-grid indices.
std::string voxel_string(const rve::PhaseImage& im, std::size_t v) {
  const std::size_t n1 = std::size_t(im.n[0]), n2 = std::size_t(im.n[1]);
  long i3 = long(v / (n1 * n2));
  if (im.is_slab()) i3 = ((i3 + im.plane_begin - im.halo) % im.n[2] + im.n[2]) % im.n[2];
  return "voxel (i1, i2, i3) = (" + std::to_string(v % n1) + ", " + std::to_string((v / n1) % n2) + ", " +
         std::to_string(i3) + ")";
}

/// A number or a list of three positive numbers (x, y, z order) → 3 values; `field` names errors.
std::array<double, 3> triple_of(const toml::node& node, const std::string& field) {
  const std::vector<double> v = keys::read_numbers(node, field, keys::above(0.0), 1, 3, true);
  if (v.size() == 2) throw InputError(field, keys::describe_value(node), "give one number or three (x, y, z)");
  return {v[0], v.size() == 3 ? v[1] : v[0], v.size() == 3 ? v[2] : v[0]};
}

/// The same for a dataset attribute (already numbers).
std::array<double, 3> triple_of(const std::vector<double>& v, const std::string& field) {
  if (v.size() != 1 && v.size() != 3) throw InputError(field, std::to_string(v.size()) + " values", "give one number or three (x, y, z)");
  std::array<double, 3> out{v[0], v.size() == 3 ? v[1] : v[0], v.size() == 3 ? v[2] : v[0]};
  for (double x : out)
    if (!(std::isfinite(x) && x > 0.0)) throw InputError(field, format_number(x), "must be finite and > 0");
  return out;
}

/// Reads one dataset of the image file, turning I/O failures into InputErrors on `field`.
io::Dataset read_image_dataset(const std::filesystem::path& file, const std::string& name, const std::string& field) {
  try {
    return io::read_dataset(file, name);
  } catch (const std::runtime_error& e) {
    throw InputError(field, name, e.what());
  }
}

/// The planes of `dataset` an image holds: all of them, or a slab image's own planes and halo.
io::Dataset read_held_planes(const std::filesystem::path& file, const std::string& name, const std::string& field,
                             const rve::PhaseImage& im) {
  if (!im.is_slab()) return read_image_dataset(file, name, field);
  try {
    return io::read_dataset_planes(file, name, long(im.plane_begin) - im.halo, long(im.plane_count) + 2L * im.halo);
  } catch (const std::runtime_error& e) {
    throw InputError(field, name, e.what());
  }
}

/// Reads a per-voxel vector dataset (dims = image dims + [3]) into unit vectors, zero vectors kept where
/// `zero_ok(v)`; `what` names the vectors in messages. Throws InputError on `field`.
std::vector<Eigen::Vector3d> read_vector_field(const std::filesystem::path& file, const std::string& name,
                                               const std::string& field, const std::vector<std::size_t>& image_dims,
                                               const rve::PhaseImage& im, const std::function<bool(std::size_t)>& zero_ok,
                                               const std::string& where_required) {
  const io::Dataset d = read_held_planes(file, name, field, im);
  std::vector<std::size_t> want = image_dims;
  want.push_back(3);
  if (d.dims != want) throw InputError(field, name + " " + dims_string(d.dims), "expected dims " + dims_string(want) + " (image dims + 3 components)");
  std::vector<Eigen::Vector3d> out(im.held_voxels());
  bool any_nonzero = false;
  for (std::size_t v = 0; v < out.size(); ++v) {
    const Eigen::Vector3d a(d.values[3 * v], d.values[3 * v + 1], d.values[3 * v + 2]);
    const double len = a.norm();
    if (!std::isfinite(len)) throw InputError(field, name, "non-finite vector at " + voxel_string(im, v));
    any_nonzero |= len > 0.0;
    if (len > 0.0) out[v] = a / len;
    else if (zero_ok(v)) out[v].setZero();
    else if (!any_nonzero && !im.is_slab() && std::all_of(d.values.begin(), d.values.end(), [](double x) { return x == 0.0; }))
      throw InputError(field, name, "every vector is zero (they are required " + where_required + ")");
    else throw InputError(field, name, "zero vector at " + voxel_string(im, v) + " (fiber fraction " + format_number(im.fiber_fraction[v]) + "; required " + where_required + ")");
  }
  return out;
}

// --- [microstructure] -------------------------------------------------------------------------------

/// The generated-section keys: FiberCellSpec plus the shape's name (square = rectangle with height =
/// width by default).
enum class ShapeName { circle, rectangle, square };

const keys::Choices<ShapeName>& shape_choices() {
  static const keys::Choices<ShapeName> c{{{"circle", ShapeName::circle}, {"rectangle", ShapeName::rectangle}, {"square", ShapeName::square}}, {}};
  return c;
}

struct CellKeys {
  rve::FiberCellSpec spec;
  ShapeName shape = ShapeName::circle;
  std::optional<double> height;
};

const keys::Choices<rve::Arrangement>& arrangement_choices() {
  static const keys::Choices<rve::Arrangement> c{
      {{"square", rve::Arrangement::square}, {"hexagonal", rve::Arrangement::hexagonal}, {"random", rve::Arrangement::random}}, {}};
  return c;
}

/// Random sequential addition is quadratic in the fiber count: beyond 1e4 fibers placement alone takes
/// minutes, and no grid this code can hold resolves them.
constexpr int kMaxFibers = 10000;
/// A fiber must cover at least this many pixels of the section grid to be resolved at all.
constexpr double kMinPixelsPerFiber = 4.0;

const keys::KeyTable<rve::FiberCellSpec>& fiber_cell_keys() {
  using S = rve::FiberCellSpec;
  static const keys::KeyTable<rve::FiberCellSpec> t = [] {
    keys::KeyTable<rve::FiberCellSpec> k("microstructure", "");
    k.choice("arrangement", &S::arrangement, arrangement_choices(), "fiber arrangement in the cell")
        .number("volume_fraction", &S::volume_fraction, keys::right_open(0.0, 1.0), "-",
                "target fiber volume fraction (0: matrix only; below the arrangement's packing limit)")
        .number("radius", &S::radius, keys::at_least(0.0), "length", "circle: fiber radius (0: from cell_size and the fraction)")
        .number("width", &S::width, keys::at_least(0.0), "length", "rectangle: side along y1 (0: from cell_size)")
        .number("cell_size", &S::cell_size, keys::above(0.0), "length",
                "cell side (square; y1 side of hexagonal; random cell) instead of the fiber size")
        .number("section_rotation_deg", &S::section_rotation_deg, keys::any_value(), "deg", "in-section rotation of each rectangle")
        .integer("fiber_count", &S::fiber_count, keys::closed_range(1, kMaxFibers), "-",
                 "random: fibers in the cell (at most 1e4, and each must cover >= 4 pixels of the grid)")
        .number("min_gap", &S::min_gap, keys::at_least(0.0), "length", "random: minimum surface-to-surface gap")
        .integer("seed", &S::seed, keys::at_least(0), "-", "random: placement seed (reproducible)");
    return k;
  }();
  return t;
}

const keys::KeyTable<CellKeys>& cell_keys() {
  static const keys::KeyTable<CellKeys> t = [] {
    keys::KeyTable<CellKeys> k("microstructure", "");
    k.custom("shape", "choice", "fiber cross-section (square: a rectangle with height = width)",
             [](const toml::node& n, const std::string& f, CellKeys& c) {
               c.shape = keys::read_choice(n, f, shape_choices());
               c.spec.shape = c.shape == ShapeName::circle ? rve::SectionShape::circle : rve::SectionShape::rectangle;
             },
             "\"circle\"", "\"circle\", \"rectangle\", \"square\"")
        .include(fiber_cell_keys(), &CellKeys::spec)
        .number("height", &CellKeys::height, keys::at_least(0.0), "length", "rectangle: side along y2 (0: from cell_size)")
        .default_text("width for a square, else 0");
    return k;
  }();
  return t;
}

rve::FiberCellSpec cell_spec(CellKeys c) {
  c.spec.height = c.height ? *c.height : (c.shape == ShapeName::square ? c.spec.width : 0.0);
  return c.spec;
}

struct MicroKeys {
  CellKeys cell;
  std::vector<int> grid{64, 64};
  double fiber_angle_deg = 0.0;
  const toml::node* image = nullptr;
  bool plate = false;
};

/// Per-axis bound of grid sizes: 65536² is already 4e9 points, far beyond any memory here.
constexpr int kMaxGridPoints = 65536;

const keys::KeyTable<MicroKeys>& micro_keys() {
  static const keys::KeyTable<MicroKeys> t = [] {
    keys::KeyTable<MicroKeys> k("microstructure", "the periodic cell: a generated fiber section or an imported voxel image");
    k.include(cell_keys(), &MicroKeys::cell)
        .custom("grid", "integer or list of 2-3 integers",
                "FFT grid: n (n x n section), [n1, n2] or [n1, n2, n3] (an extruded 3D cell); taken from an image",
                [](const toml::node& n, const std::string& f, MicroKeys& m) {
                  const keys::Range r = keys::closed_range(1, kMaxGridPoints);
                  if (n.is_array()) {
                    m.grid = keys::read_ints<int>(n, f, r, 2, 3);
                  } else {
                    const int g = keys::read_int<int>(n, f, r);
                    m.grid = {g, g};
                  }
                },
                "64", "each in [1, 65536]")
        .number("fiber_angle_deg", &MicroKeys::fiber_angle_deg, keys::any_value(), "deg",
                "fiber axis in the 1-2 plane of the load frame, from e2 toward e1 (spec §7)")
        .choice("cell", &MicroKeys::plate, keys::Choices<bool>{{{"periodic", false}, {"plate", true}}, {}},
                "\"periodic\": periodic in y1 and y2 (the bulk composite); \"plate\": one layer of fibers, periodic along "
                "y1 only, its faces y2 = 0, L2 (normal e3 of the load frame) traction-free, thickness the cell side L2 "
                "(FE engine, section mesh; the load must leave F13, F23, F33 free with P13 = P23 = P33 = 0)")
        .custom("image", "table", "[microstructure.image]: an HDF5 voxel image instead of a generated section",
                [](const toml::node& n, const std::string& f, MicroKeys& m) { m.image = &keys::read_table(n, f); }, "none");
    return k;
  }();
  return t;
}

struct ImageKeys {
  std::string file;
  std::string dataset = "/phase";
  std::optional<long long> matrix_id, fiber_id;
  std::string normal_dataset, direction_dataset;
  const toml::node* voxel_size = nullptr;
  const toml::node* cell_size = nullptr;
};

const keys::KeyTable<ImageKeys>& image_keys() {
  using I = ImageKeys;
  static const keys::KeyTable<ImageKeys> t = [] {
    keys::KeyTable<ImageKeys> k("microstructure.image", "a voxel image from HDF5 (C order [n2][n1] or [n3][n2][n1])");
    auto id = [](std::optional<long long> I::*member) {
      return [member](const toml::node& n, const std::string& f, I& i) { i.*member = keys::read_int<long long>(n, f); };
    };
    auto node_of = [](const toml::node* I::*member) { return [member](const toml::node& n, const std::string&, I& i) { i.*member = &n; }; };
    k.text("file", &I::file, "HDF5 file, relative to the scene file").required()
        .text("dataset", &I::dataset, "integer dataset: phase ids; floating point: fiber fractions in [0, 1]")
        .custom("matrix_id", "integer", "phase id of the matrix (integer datasets)", id(&I::matrix_id), "0")
        .custom("fiber_id", "integer", "phase id of the fiber (integer datasets)", id(&I::fiber_id), "1")
        .text("normal_dataset", &I::normal_dataset, "interface normals (dims + [3]); non-zero in composite voxels")
        .default_text("\"\" (estimated from the fractions)")
        .text("direction_dataset", &I::direction_dataset, "per-voxel fiber direction (grid frame, dims + [3]); non-zero in fiber")
        .default_text("\"\" (y3)")
        .custom("voxel_size", "number or [x, y, z]", "voxel size", node_of(&I::voxel_size), "the dataset attribute, else L1 = 1", "> 0", "length")
        .custom("cell_size", "number or [x, y, z]", "cell size (a number: L1, cubic voxels)", node_of(&I::cell_size),
                "the dataset attribute, else L1 = 1", "> 0", "length")
        .renamed("size");
    return k;
  }();
  return t;
}

/// The image's HDF5 file: relative paths are relative to the scene file (when the scene came from a file).
std::filesystem::path image_file(const ImageKeys& keys, const toml::table& img, const std::string& p) {
  std::filesystem::path file = keys.file;
  if (file.empty()) throw InputError(p + ".file", "\"\"", "missing: the HDF5 file of the phase image");
  if (file.is_relative() && img.source().path && !img.source().path->empty())
    file = std::filesystem::path(*img.source().path).parent_path() / file;
  io::check_input_file(file, p + ".file", io::kDataFile);
  return file;
}

/// The grid of the image from the dataset's dims (C order: [n3][n2][n1] or [n2][n1] → i1 fastest, as
/// in PhaseImage), and the planes this rank holds when a 3D cell is distributed.
void set_image_grid(rve::PhaseImage& im, const io::Dataset& d, const std::string& dataset, const std::string& p,
                    bool distributed) {
  for (std::size_t k : d.dims)
    if (k == 0 || k > std::size_t(kMaxGridPoints))
      throw InputError(p + ".dataset", dataset + " " + dims_string(d.dims), "dimensions must lie in [1, 65536]");
  if (d.dims.size() == 2) im.n = {int(d.dims[1]), int(d.dims[0]), 1};
  else if (d.dims.size() == 3) im.n = {int(d.dims[2]), int(d.dims[1]), int(d.dims[0])};
  else throw InputError(p + ".dataset", dataset + " " + dims_string(d.dims), "must be 2D [n2][n1] (a section) or 3D [n3][n2][n1]");
  if (const std::optional<rve::SlabPlanes> planes = distributed && im.n[2] > 1 ? rve::distributed_planes(im.n) : std::nullopt) {
    im.slab = true;
    im.plane_begin = planes->begin;
    im.plane_count = planes->count;
    im.halo = planes->count > 0 ? rve::kSlabImageHalo : 0;  // a rank without planes holds none
  }
}

/// Fiber fractions from the held values: integer datasets hold phase ids, floating-point datasets
/// fiber volume fractions in [0, 1].
void set_fiber_fractions(rve::PhaseImage& im, const io::Dataset& d, const ImageKeys& keys, const std::string& p) {
  im.fiber_fraction.resize(d.values.size());
  if (d.integer) {
    const long long matrix_id = keys.matrix_id.value_or(0), fiber_id = keys.fiber_id.value_or(1);
    if (matrix_id == fiber_id) throw InputError(p + ".fiber_id", std::to_string(fiber_id), "must differ from matrix_id");
    for (std::size_t v = 0; v < d.values.size(); ++v) {
      const double id = d.values[v];
      if (id == double(matrix_id)) im.fiber_fraction[v] = 0.0;
      else if (id == double(fiber_id)) im.fiber_fraction[v] = 1.0;
      else
        throw InputError(p + ".dataset", "phase id " + format_number(id) + " at " + voxel_string(im, v),
                         "unknown phase id (matrix_id = " + std::to_string(matrix_id) + ", fiber_id = " +
                             std::to_string(fiber_id) + ")");
    }
    return;
  }
  if (keys.matrix_id || keys.fiber_id)
    throw InputError(p + (keys.matrix_id ? ".matrix_id" : ".fiber_id"), keys.dataset,
                     "phase ids need an integer dataset (this one holds floating-point fiber fractions)");
  for (std::size_t v = 0; v < d.values.size(); ++v) {
    const double f = d.values[v];
    if (!(f >= 0.0 && f <= 1.0))
      throw InputError(p + ".dataset", format_number(f) + " at " + voxel_string(im, v),
                       "fiber fractions must lie in [0, 1] (store phase ids as an integer dataset)");
    im.fiber_fraction[v] = f;
  }
}

/// Voxel size: scene key voxel_size or cell_size, else the dataset's attribute of the same names (as
/// written by `softhom rve` with microstructure_only), else cubic voxels with L1 = 1.
void set_image_size(rve::PhaseImage& im, const io::Dataset& d, const ImageKeys& keys, const std::string& p) {
  if (keys.voxel_size && keys.cell_size) throw InputError(p + ".cell_size", "", "give either voxel_size or cell_size, not both");
  std::array<double, 3> h{1.0 / im.n[0], 1.0 / im.n[0], 1.0 / im.n[0]};
  auto from_cell = [&](const std::array<double, 3>& L) {
    for (int k = 0; k < 3; ++k) h[k] = L[k] / im.n[k];
  };
  if (keys.voxel_size) {
    h = triple_of(*keys.voxel_size, p + ".voxel_size");
  } else if (keys.cell_size) {
    if (keys.cell_size->is_array()) from_cell(triple_of(*keys.cell_size, p + ".cell_size"));
    else {
      const double L1 = keys::read_number(*keys.cell_size, p + ".cell_size", keys::above(0.0));
      h = {L1 / im.n[0], L1 / im.n[0], L1 / im.n[0]};  // L1; cubic voxels
    }
  } else if (auto it = d.attributes.find("voxel_size"); it != d.attributes.end()) {
    h = triple_of(it->second, p + ".dataset attribute voxel_size");
  } else if (auto it2 = d.attributes.find("cell_size"); it2 != d.attributes.end()) {
    from_cell(triple_of(it2->second, p + ".dataset attribute cell_size"));
  }
  for (int k = 0; k < 3; ++k) im.size[k] = h[k] * im.n[k];
}

}  // namespace

rve::PhaseImage import_phase_image(const toml::table& img, const std::string& p, std::string& geometry_note, bool distributed) {
  ImageKeys keys;
  image_keys().read(img, p, keys);
  const std::filesystem::path file = image_file(keys, img, p);
  const std::string& dataset = keys.dataset;
  // Dims, type and attributes first: a distributed 3D cell then reads only its slab's planes.
  io::Dataset d;
  try {
    d = io::read_dataset_planes(file, dataset, 0, 0);
  } catch (const std::runtime_error& e) {
    throw InputError(p + ".dataset", dataset, e.what());
  }
  rve::PhaseImage im;
  set_image_grid(im, d, dataset, p, distributed);
  // Refused from its shape before reading: the values as read (8 B a voxel), the image, and per vector
  // dataset its values and unit vectors (48 B a voxel).
  const double vector_bytes = 48.0 * double(!keys.normal_dataset.empty() + !keys.direction_dataset.empty());
  rve::refuse_oversized_image(double(im.held_voxels()), 8.0 + vector_bytes, p + ".dataset", dataset + " " + dims_string(d.dims));
  d.values = read_held_planes(file, dataset, p + ".dataset", im).values;
  set_fiber_fractions(im, d, keys, p);
  set_image_size(im, d, keys, p);

  // Interface normals of composite voxels (optional; without them the solver estimates −∇φ). The
  // laminate rule needs a normal in every composite voxel (0 < fraction < 1).
  if (!keys.normal_dataset.empty()) {
    if (d.integer) throw InputError(p + ".normal_dataset", keys.normal_dataset, "normals apply to fiber-fraction images only");
    im.normal = read_vector_field(file, keys.normal_dataset, p + ".normal_dataset", d.dims, im,
                                  [&](std::size_t v) { return im.fiber_fraction[v] == 0.0 || im.fiber_fraction[v] == 1.0; },
                                  "in every composite voxel, 0 < fraction < 1");
  }
  // Per-voxel fiber direction (grid frame): required non-zero wherever there is fiber.
  if (!keys.direction_dataset.empty())
    im.fiber_direction = read_vector_field(file, keys.direction_dataset, p + ".direction_dataset", d.dims, im,
                                           [&](std::size_t v) { return im.fiber_fraction[v] == 0.0; }, "wherever there is fiber");
  geometry_note = "imported " + file.string() + ":" + dataset + (d.integer ? " (phase ids)" : " (fiber fractions)");
  return im;
}

namespace {

/// A random cell's fibers must each cover kMinPixelsPerFiber pixels of the section grid.
void check_fiber_count(const rve::FiberCellSpec& spec, const std::vector<int>& n, const std::string& p) {
  if (spec.arrangement != rve::Arrangement::random) return;
  const double pixels = spec.volume_fraction * double(n[0]) * double(n[1]) / spec.fiber_count;
  if (pixels < kMinPixelsPerFiber)
    throw InputError(p + ".fiber_count", std::to_string(spec.fiber_count),
                     "too many fibers for the grid: each would cover " + format_number(pixels) + " pixels of the " +
                         std::to_string(n[0]) + " x " + std::to_string(n[1]) + " section, at least 4 are needed (at most " +
                         std::to_string(int(spec.volume_fraction * n[0] * n[1] / kMinPixelsPerFiber)) + " fibers)");
}

/// Keys of the generated cell that contradict its shape or arrangement are refused (they were ignored):
/// a circle's width, height or section rotation, a rectangle's radius, a square's height other than its
/// width, and the random-placement keys of a regular arrangement. Matrix-only cells (volume_fraction = 0)
/// may keep the fiber keys of the scene they were made from: the reference curve of a composite scene
/// is that scene at fraction 0.
void refuse_contradictory_cell_keys(const toml::table& t, const CellKeys& c, const std::string& p) {
  if (c.spec.volume_fraction == 0.0) return;
  const std::string shape = "shape = \"" + shape_choices().name_of(c.shape) + "\"";
  auto refuse_given = [&](const char* key, const std::string& why) {
    if (const toml::node* n = t.get(key)) throw InputError(p + "." + key, keys::describe_value(*n), why);
  };
  if (c.shape == ShapeName::circle)
    for (const char* key : {"width", "height", "section_rotation_deg"})
      refuse_given(key, "applies to rectangle and square fibers, not to " + shape + " (give radius)");
  else refuse_given("radius", "applies to circular fibers, not to " + shape + " (give width and height)");
  if (c.shape == ShapeName::square && c.height && *c.height != c.spec.width)
    refuse_given("height", "a square's height is its width (" + format_number(c.spec.width) + "): use shape = \"rectangle\"");
  if (c.spec.arrangement != rve::Arrangement::random)
    for (const char* key : {"fiber_count", "min_gap", "seed"})
      refuse_given(key, "applies to arrangement = \"random\" only, not to arrangement = \"" +
                            arrangement_choices().name_of(c.spec.arrangement) + "\"");
}

/// The fiber fraction of the whole cell: a slab image's owned sums added over the ranks.
double cell_volume_fraction(const rve::PhaseImage& im) {
  if (!im.is_slab() || !mpi::active()) return im.volume_fraction();
  double sum = im.owned_fiber_sum();
  MPI_Allreduce(MPI_IN_PLACE, &sum, 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
  return sum / double(im.voxels());
}

/// The phase image (grid frame) of [microstructure]; `target_vf` is the requested fraction. `distributed`:
/// a 3D cell is held as this rank's slab image only (rve::distributed_planes()): a generated one is
/// voxelized per slab, an imported one read per slab.
rve::PhaseImage phase_image_of(const toml::table& t, const MicroKeys& m, bool grid_given, double& target_vf,
                               std::string& geometry_note, bool distributed = false) {
  const std::string p = "microstructure";
  const std::vector<int>& n = m.grid;
  if (m.image) {
    rve::PhaseImage im = import_phase_image(*m.image->as_table(), p + ".image", geometry_note, distributed);
    // An explicit grid must agree with the image (it is otherwise taken from the image).
    if (grid_given) {
      const std::array<int, 3> g{n[0], n[1], n.size() == 3 ? n[2] : 1};
      if (g != im.n)
        throw InputError(p + ".grid", keys::describe_value(*t.get("grid")),
                         "contradicts the image grid [" + std::to_string(im.n[0]) + ", " + std::to_string(im.n[1]) + ", " +
                             std::to_string(im.n[2]) + "] (omit grid with an image)");
    }
    target_vf = cell_volume_fraction(im);
    return im;
  }
  refuse_contradictory_cell_keys(t, m.cell, p);
  const rve::FiberCellSpec spec = cell_spec(m.cell);
  target_vf = spec.volume_fraction;
  // Straight fibers: a 3D cell is its section extruded, the whole cell or (distributed) this rank's planes.
  const int n3 = n.size() == 3 ? n[2] : 1;
  const std::optional<rve::SlabPlanes> planes = distributed && n3 > 1 ? rve::distributed_planes({n[0], n[1], n3}) : std::nullopt;
  auto extruded = [&](const rve::PhaseImage& section) {
    if (planes) return rve::extrude_planes(section, n3, planes->begin, planes->count, rve::kSlabImageHalo);
    return n3 > 1 ? rve::extrude(section, n3) : section;
  };
  if (target_vf == 0.0) {
    geometry_note = "matrix only";
    return extruded(rve::matrix_only_section(n[0], n[1]));
  }
  check_fiber_count(spec, n, p);
  const rve::Section section = rve::generate_section(spec, p);
  rve::PhaseImage im;
  try {
    im = extruded(rve::voxelize_section(section, n[0], n[1]));
  } catch (const std::invalid_argument& e) {
    throw InputError(p + ".grid", keys::describe_value(*t.get("grid")), e.what());
  }
  geometry_note = shape_choices().name_of(m.cell.shape) + " fibers, " + arrangement_choices().name_of(spec.arrangement) + " arrangement, cell " +
                  format_number(section.L1) + " x " + format_number(section.L2);
  return im;
}

MicroKeys read_micro(const toml::table& t, bool& grid_given) {
  MicroKeys m;
  grid_given = micro_keys().read(t, "microstructure", m).count("grid") > 0;
  return m;
}

/// The FFT engine's phase images are periodic in every direction: a plate cell is refused.
void refuse_plate_for_fft(const MicroKeys& m) {
  if (m.plate)
    throw InputError("microstructure.cell", "\"plate\"",
                     "the plate cell (free faces y2 = 0, L2) is an FE cell: set [solver] engine = \"fe\" (the FFT engine's "
                     "cells are periodic in every direction)");
}

}  // namespace

rve::FiberCellSpec parse_fiber_cell_spec(const toml::table& t, const std::string& p, std::string& label) {
  CellKeys c;
  cell_keys().read_declared(t, p, c);  // the caller refuses keys of no declaration
  refuse_contradictory_cell_keys(t, c, p);
  label = shape_choices().name_of(c.shape) + " fibers, " + arrangement_choices().name_of(c.spec.arrangement) + " arrangement";
  return cell_spec(c);
}

double microstructure_fiber_angle(const toml::table& t) {
  bool grid_given = false;
  return read_micro(t, grid_given).fiber_angle_deg;
}

bool microstructure_is_plate(const toml::table& t) {
  bool grid_given = false;
  return read_micro(t, grid_given).plate;
}

rve::PhaseImage build_phase_image(const toml::table& t, double& target_vf, std::string& geometry_note) {
  bool grid_given = false;
  const MicroKeys m = read_micro(t, grid_given);
  refuse_plate_for_fft(m);
  return phase_image_of(t, m, grid_given, target_vf, geometry_note);
}

// --- Files a run writes -------------------------------------------------------------------------------

std::filesystem::path user_cache_dir() {
  const char* xdg = std::getenv("XDG_CACHE_HOME");
  if (xdg && *xdg && std::filesystem::path(xdg).is_absolute()) return std::filesystem::path(xdg) / "softhom";
  const char* home = std::getenv("HOME");
  return std::filesystem::path(home && *home ? home : "/tmp") / ".cache" / "softhom";
}

namespace {

bool inside(const std::filesystem::path& p, const std::filesystem::path& dir) {
  const auto rel = p.lexically_relative(dir);
  return !rel.empty() && *rel.begin() != "..";
}

}  // namespace

std::filesystem::path resolve_run_file(const std::string& written, const std::filesystem::path& out, const std::string& field) {
  if (written.empty()) return {};
  const std::filesystem::path cache = user_cache_dir().lexically_normal();
  const std::filesystem::path base = out.empty() ? cache : std::filesystem::absolute(out).lexically_normal();
  const std::filesystem::path p(written);
  const std::string where = out.empty() ? "the cache " + cache.string()
                                        : "--out (" + base.string() + ") or the cache " + cache.string();
  if (p.is_relative()) {
    const std::filesystem::path resolved = (base / p).lexically_normal();
    if (!inside(resolved, base))
      throw InputError(field, "\"" + written + "\"", "escapes " + base.string() + " (files a run writes stay under " + where + ")");
    return resolved;
  }
  const std::filesystem::path normal = p.lexically_normal();
  if (inside(normal, cache) || (!out.empty() && inside(normal, base))) return normal;
  throw InputError(field, "\"" + written + "\"", "outside " + where + " (files a run writes stay there; a relative path is relative to " +
                                                     (out.empty() ? std::string("the cache") : std::string("--out")) + ")");
}

rve::FftSolverOptions parse_fft_solver_options(const toml::table& scene, std::filesystem::path& wisdom,
                                               const std::filesystem::path& out) {
  rve::FftSolverOptions o;
  rve::fft_solver_keys().read_optional(scene.get("solver"), "solver", o);
  wisdom = resolve_run_file(o.plan.wisdom_file.string(), out, "solver.fftw_wisdom");
  o.plan.wisdom_file = wisdom;
  return o;
}

// --- [output] ---------------------------------------------------------------------------------------

namespace {

const keys::KeyTable<RveOutputSettings>& output_keys() {
  static const keys::KeyTable<RveOutputSettings> t = [] {
    keys::KeyTable<RveOutputSettings> k("output", "what a run writes besides response.csv and summary.json");
    k.custom("fields", "choice or list of times",
             "full fields (XDMF/HDF5): \"none\", \"last\" (the final step), \"all\" or a list of output times of the load path",
             [](const toml::node& n, const std::string& f, RveOutputSettings& o) {
               if (n.is_array()) {
                 o.fields_mode = "times";
                 o.field_times = keys::read_numbers(n, f, keys::at_least(0.0));
                 return;
               }
               static const keys::Choices<int> modes{{{"none", 0}, {"last", 1}, {"all", 2}}, {}};
               o.fields_mode = modes.name_of(keys::read_choice(n, f, modes));
             },
             "\"last\"", "\"none\", \"last\", \"all\" or [t, ...]")
        .flag("microstructure_only", &RveOutputSettings::microstructure_only,
              "write the cell (microstructure.h5/.xdmf, or the FE mesh) and stop; [load] is not needed");
    return k;
  }();
  return t;
}

}  // namespace

RveOutputSettings parse_rve_output(const toml::table& scene, const MixedControl* control) {
  RveOutputSettings o;
  output_keys().read_optional(scene.get("output"), "output", o);
  if (control && o.fields_mode == "times") {
    const double t_end = control->times.back();
    for (std::size_t i = 0; i < o.field_times.size(); ++i) {
      const double t = o.field_times[i];
      const std::string f = keys::index_field("output.fields", i);
      if (t > t_end * (1.0 + 1e-12))
        throw InputError(f, format_number(t), "after the end of the load path (t_end = " + format_number(t_end) + ")");
      double nearest = 0.0;
      for (double s : control->times)
        if (std::abs(s - t) < std::abs(nearest - t)) nearest = s;
      if (std::abs(nearest - t) > 1e-9 * std::max(1.0, t_end))
        throw InputError(f, format_number(t), "not an output time of the load path (nearest: " + format_number(nearest) + ")");
    }
  }
  return o;
}

// --- The scene ----------------------------------------------------------------------------------------

namespace {

struct RveTop {
  std::string description;
  const toml::table* microstructure = nullptr;
  const toml::table* phases = nullptr;
  const toml::table* load = nullptr;
};

const keys::KeyTable<RveTop>& rve_top_keys() {
  static const keys::KeyTable<RveTop> t = [] {
    keys::KeyTable<RveTop> k("", "the tables of an RVE scene");
    auto table_of = [](const toml::table* RveTop::*member) {
      return [member](const toml::node& n, const std::string& f, RveTop& r) { r.*member = &keys::read_table(n, f); };
    };
    auto any_table = [](const toml::node& n, const std::string& f, RveTop&) { keys::read_table(n, f); };
    k.text("description", &RveTop::description, "what the scene is for (copied to summary.json)")
        .custom("microstructure", "table", "[microstructure]: the cell", table_of(&RveTop::microstructure), "required")
        .custom("phases", "table", "[phases.matrix], [phases.fiber]: material tables", table_of(&RveTop::phases), "required")
        .custom("load", "table", "[load]: the load path (not with microstructure_only)", table_of(&RveTop::load), "required")
        .custom("solver", "table", "[solver]: engine and its settings", any_table, "defaults")
        .custom("output", "table", "[output]: fields and microstructure output", any_table, "defaults");
    return k;
  }();
  return t;
}

struct PhaseKeys {
  const toml::table* matrix = nullptr;
  const toml::table* fiber = nullptr;
};

const keys::KeyTable<PhaseKeys>& phase_keys() {
  static const keys::KeyTable<PhaseKeys> t = [] {
    keys::KeyTable<PhaseKeys> k("phases", "the two phases (material tables, see [material] of softhom point)");
    k.custom("matrix", "table", "[phases.matrix]: the matrix material",
             [](const toml::node& n, const std::string& f, PhaseKeys& p) { p.matrix = &keys::read_table(n, f); }, "required")
        .custom("fiber", "table", "[phases.fiber]: the fiber material (required when the cell has fibers)",
                [](const toml::node& n, const std::string& f, PhaseKeys& p) { p.fiber = &keys::read_table(n, f); }, "the matrix");
    return k;
  }();
  return t;
}

}  // namespace

RvePhases parse_rve_phases(const toml::table& scene) {
  RveTop top;
  rve_top_keys().read(scene, "", top);
  if (!top.phases) throw InputError("phases", "", "missing [phases] table ([phases.matrix], [phases.fiber])");
  PhaseKeys keys;
  phase_keys().read(*top.phases, "phases", keys);
  if (!keys.matrix) throw InputError("phases.matrix", "", "missing");
  RvePhases p;
  p.matrix = build_material(parse_material(*keys.matrix, "phases.matrix"));
  p.has_fiber = keys.fiber != nullptr;
  p.fiber = keys.fiber ? build_material(parse_material(*keys.fiber, "phases.fiber")) : p.matrix;
  return p;
}

const toml::table& rve_microstructure(const toml::table& scene) {
  RveTop top;
  rve_top_keys().read(scene, "", top);
  if (!top.microstructure) throw InputError("microstructure", "", "missing [microstructure] table");
  return *top.microstructure;
}

MixedControl parse_rve_load(const toml::table& scene) {
  RveTop top;
  rve_top_keys().read(scene, "", top);
  if (!top.load) throw InputError("load", "", "missing [load] table");
  return parse_load(*top.load, "load");
}

RveSceneSetup parse_rve_scene(const toml::table& scene, bool with_load, const std::filesystem::path& out, bool distributed) {
  const toml::table& micro = rve_microstructure(scene);
  RveSceneSetup s;
  const RvePhases phases = parse_rve_phases(scene);
  s.matrix = phases.matrix;
  s.fiber = phases.fiber;
  bool grid_given = false;
  const MicroKeys m = read_micro(micro, grid_given);
  refuse_plate_for_fft(m);
  s.image = phase_image_of(micro, m, grid_given, s.target_vf, s.geometry_note, distributed);
  if (s.target_vf > 0.0 && !phases.has_fiber) throw InputError("phases.fiber", "", "missing (the cell has fibers)");
  // Per-voxel fiber directions only steer the fiber-rotation measure: the solver has no per-voxel
  // material frames, so phases with fiber families of their own would silently ignore them.
  if (!s.image.fiber_direction.empty() && (!s.matrix->fiber_directions().empty() || !s.fiber->fiber_directions().empty()))
    throw InputError("microstructure.image.direction_dataset", "", "per-voxel fiber directions need isotropic phases (a phase has fiber families)");
  if (distributed) s.image = rve::rank_image(std::move(s.image));  // a section image: extruded whole, kept as a slab
  s.fiber_angle_deg = m.fiber_angle_deg;
  if (with_load) s.control = parse_rve_load(scene);
  s.output = parse_rve_output(scene, with_load ? &s.control : nullptr);
  std::filesystem::path wisdom;
  s.solver = parse_fft_solver_options(scene, wisdom, out);
  return s;
}

std::vector<keys::TableDoc> rve_common_tables() {
  std::vector<keys::TableDoc> t{rve_top_keys().describe()};
  t.front().path = "(top level)";
  t.push_back(micro_keys().describe());
  t.push_back(image_keys().describe());
  t.push_back(phase_keys().describe());
  for (auto& d : material_tables("phases.<name>")) t.push_back(d);
  for (auto& d : load_tables("load")) t.push_back(d);
  t.push_back(output_keys().describe());
  return t;
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

}  // namespace softhom::studies
