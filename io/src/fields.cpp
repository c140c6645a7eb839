// Fields for ParaView: heavy data in HDF5 (C API), a hand-written XDMF 3 sidecar describing a temporal
// collection of grids. The XDMF is kept in memory and written only on close(), and the HDF5 file lives
// under a temporary name until then, so an interrupted run never leaves a file that looks complete.
#include "softhom/io/fields.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <set>
#include <stdexcept>
#include <system_error>

#include <fcntl.h>
#include <hdf5.h>
#include <sys/mman.h>
#include <unistd.h>

#include "softhom/io/files.hpp"
#include "softhom/io/summary.hpp"

namespace softhom::io {

namespace fs = std::filesystem;

namespace {

// HDF5 prints its whole error stack to stderr by default; we report errors as exceptions instead.
void silence_hdf5() { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); }

// A file written under a temporary name: removed on every exit path unless moved into place.
struct TemporaryFile {
  fs::path path;
  bool kept = false;
  ~TemporaryFile() {
    std::error_code ec;
    if (!kept) fs::remove(path, ec);
  }
};

// The API-level and the innermost message of the current HDF5 error stack, for exception texts.
std::string hdf5_error_detail() {
  struct Walk {
    std::string first, last;
  } w;
  auto cb = [](unsigned n, const H5E_error2_t* e, void* data) -> herr_t {
    auto* w = static_cast<Walk*>(data);
    const std::string desc = (e && e->desc) ? e->desc : "";
    if (n == 0) w->first = desc;
    w->last = desc;
    return 0;
  };
  H5Ewalk2(H5E_DEFAULT, H5E_WALK_DOWNWARD, cb, &w);
  if (w.first.empty()) return "unknown HDF5 error";
  return w.first == w.last ? w.first : w.first + ": " + w.last;
}

[[noreturn]] void hdf5_fail(const std::string& what) {
  throw std::runtime_error(what + " (HDF5: " + hdf5_error_detail() + ")");
}

// HDF5's file-driver messages embed the OS error as "errno = N"; 0 when the stack carries none.
int hdf5_errno() {
  int found = 0;
  auto cb = [](unsigned, const H5E_error2_t* e, void* data) -> herr_t {
    const char* desc = e ? e->desc : nullptr;
    const char* at = desc ? std::strstr(desc, "errno = ") : nullptr;
    if (at && *static_cast<int*>(data) == 0) *static_cast<int*>(data) = std::atoi(at + 8);
    return 0;
  };
  H5Ewalk2(H5E_DEFAULT, H5E_WALK_DOWNWARD, cb, &found);
  return found;
}

// A failed HDF5 write of `target`: a WriteError naming the file the user asked for and the OS reason
// (e.g. "No space left on device"), or HDF5's own short reason when the stack carries no errno.
[[noreturn]] void hdf5_write_fail(const fs::path& target, const std::string& what) {
  const int err = hdf5_errno();
  if (err != 0) throw WriteError(target, what, err);
  throw WriteError(target, what + " (HDF5: " + hdf5_error_detail() + ")", 0);
}

// Owns one HDF5 identifier and closes it with the matching H5?close.
class Handle {
 public:
  Handle() = default;
  Handle(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  Handle(Handle&& o) noexcept : id_(o.id_), close_(o.close_) { o.id_ = -1; }
  Handle& operator=(Handle&& o) noexcept {
    if (this != &o) {
      reset();
      std::swap(id_, o.id_);
      close_ = o.close_;
    }
    return *this;
  }
  ~Handle() { reset(); }
  hid_t get() const { return id_; }
  bool valid() const { return id_ >= 0; }
  hid_t release() {
    const hid_t id = id_;
    id_ = -1;
    return id;
  }
  // Returns false if HDF5 reported an error while closing (for a file: data may not be flushed).
  bool reset() {
    bool ok = true;
    if (id_ >= 0) ok = close_(id_) >= 0;
    id_ = -1;
    return ok;
  }

 private:
  hid_t id_ = -1;
  herr_t (*close_)(hid_t) = nullptr;
};

Handle checked(hid_t id, herr_t (*close)(hid_t), const std::string& what) {
  if (id < 0) hdf5_fail(what);
  return Handle(id, close);
}

Handle checked_write(hid_t id, herr_t (*close)(hid_t), const fs::path& target, const std::string& what) {
  if (id < 0) hdf5_write_fail(target, what);
  return Handle(id, close);
}

// Closes a file whose content is to be discarded (an unfinished or failed writer). A file that met a
// full disk cannot be closed: its closing flush fails again, the identifier stays open, and HDF5's
// exit handler then crashes closing it. So the file's descriptor is first pointed at an anonymous
// in-memory file (sparse: only the small closing writes take memory), where the flush succeeds.
void abandon_file(hid_t file) {
  void* handle = nullptr;
  if (H5Fget_vfd_handle(file, H5P_DEFAULT, &handle) >= 0 && handle) {
    const int fd = *static_cast<int*>(handle);
    const int scratch = ::memfd_create("softhom-abandoned-h5", MFD_CLOEXEC);
    if (scratch >= 0) {
      ::dup2(scratch, fd);
      ::close(scratch);
    }
  }
  H5Fclose(file);
}

herr_t abandon_close(hid_t file) {
  abandon_file(file);
  return 0;
}

// Flushes and closes a finished file (flush is where a full disk shows). On failure the file is
// abandoned and WriteError thrown, naming `target`.
void finish_file(Handle& file, const fs::path& target, const fs::path& tmp) {
  const std::string what = "cannot finish temporary '" + tmp.string() + "'";
  if (H5Fflush(file.get(), H5F_SCOPE_GLOBAL) < 0) {
    const int err = hdf5_errno();
    const std::string detail = hdf5_error_detail();
    abandon_file(file.release());
    throw WriteError(target, err ? what : what + " (HDF5: " + detail + ")", err);
  }
  const hid_t id = file.release();
  if (H5Fclose(id) < 0) {
    const int err = hdf5_errno();
    const std::string detail = hdf5_error_detail();
    abandon_file(id);
    throw WriteError(target, err ? what : what + " (HDF5: " + detail + ")", err);
  }
}

// A variable-length string attribute on `loc` (file, group or dataset).
void write_string_attribute(hid_t loc, const char* name, const std::string& value, const fs::path& target) {
  const std::string what = std::string("cannot write attribute '") + name + "'";
  Handle str = checked_write(H5Tcopy(H5T_C_S1), H5Tclose, target, what);
  if (H5Tset_size(str.get(), H5T_VARIABLE) < 0 || H5Tset_cset(str.get(), H5T_CSET_UTF8) < 0)
    hdf5_write_fail(target, what);
  Handle scalar = checked_write(H5Screate(H5S_SCALAR), H5Sclose, target, what);
  Handle attr = checked_write(H5Acreate2(loc, name, str.get(), scalar.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose,
                                 target, what);
  const char* text = value.c_str();
  if (H5Awrite(attr.get(), str.get(), &text) < 0) hdf5_write_fail(target, what);
}

void write_double_attribute(hid_t loc, const char* name, double value, const fs::path& target) {
  const std::string what = std::string("cannot write attribute '") + name + "'";
  Handle scalar = checked_write(H5Screate(H5S_SCALAR), H5Sclose, target, what);
  Handle attr = checked_write(H5Acreate2(loc, name, H5T_IEEE_F64LE, scalar.get(), H5P_DEFAULT, H5P_DEFAULT),
                                 H5Aclose, target, what);
  if (H5Awrite(attr.get(), H5T_NATIVE_DOUBLE, &value) < 0) hdf5_write_fail(target, what);
}

void write_dataset(hid_t loc, const std::string& name, hid_t file_type, hid_t mem_type, const void* data,
                   const std::vector<hsize_t>& dims, const fs::path& target, const std::string& unit = "") {
  const std::string what = "cannot write dataset '" + name + "'";
  if (write_failure_injected(target)) throw WriteError(target, what, ENOSPC);
  Handle space =
      checked_write(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr), H5Sclose, target, what);
  Handle set = checked_write(
      H5Dcreate2(loc, name.c_str(), file_type, space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Dclose, target,
      what);
  if (H5Dwrite(set.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0) hdf5_write_fail(target, what);
  if (!unit.empty()) write_string_attribute(set.get(), "unit", unit, target);
}

std::string number(double x) {
  char buf[32];
  return std::string(buf, std::to_chars(buf, buf + sizeof buf, x).ptr);
}

std::string join(const std::vector<hsize_t>& dims) {
  std::string s;
  for (std::size_t i = 0; i < dims.size(); ++i) {
    if (i) s += ' ';
    s += std::to_string(dims[i]);
  }
  return s;
}

std::string xml_escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&apos;"; break;
      default: out += c;
    }
  }
  return out;
}

// Field names become HDF5 link names and XML attribute values: keep them to a plain alphabet.
void check_name(const std::string& name) {
  const bool ok = !name.empty() && std::all_of(name.begin(), name.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.';
  });
  if (!ok)
    throw std::invalid_argument("FieldWriter: field name '" + name +
                                "' must be non-empty and use only letters, digits, '_', '-', '.'");
}

struct CellInfo {
  const char* xdmf;
  int nodes;
};
CellInfo cell_info(CellType t) {
  switch (t) {
    case CellType::line2: return {"Polyline", 2};
    case CellType::line3: return {"Edge_3", 3};
    case CellType::triangle3: return {"Triangle", 3};
    case CellType::triangle6: return {"Triangle_6", 6};
    case CellType::quad4: return {"Quadrilateral", 4};
    case CellType::tetra4: return {"Tetrahedron", 4};
    case CellType::tetra10: return {"Tetrahedron_10", 10};
    case CellType::hexa8: return {"Hexahedron", 8};
  }
  throw std::invalid_argument("FieldWriter: unknown cell type");
}

// rename() only moves directory entries: fsync first so the renamed file is complete after a crash.
// A failing fsync (EIO, ENOSPC on delayed allocation) means the data may not be on disk.
void fsync_file(const fs::path& p, const fs::path& target) {
  const int fd = ::open(p.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw WriteError(target, "cannot reopen temporary '" + p.string() + "' to sync it", errno);
  if (::fsync(fd) != 0) {
    const int err = errno;
    ::close(fd);
    throw WriteError(target, "fsync failed", err);
  }
  ::close(fd);
}

// The temporary of `target`, its directory created.
TemporaryFile temporary_for(const fs::path& target) {
  if (!target.parent_path().empty()) {
    std::error_code ec;
    fs::create_directories(target.parent_path(), ec);
    if (ec) throw WriteError(target, "cannot create directory '" + target.parent_path().string() + "'", ec.value());
  }
  return TemporaryFile{temporary_path(target)};
}

// fsync, then rename over `target`: the complete file or the previous one, even after a crash.
void move_into_place(TemporaryFile& temporary, const fs::path& target) {
  fsync_file(temporary.path, target);
  std::error_code ec;
  fs::rename(temporary.path, target, ec);
  if (ec) throw WriteError(target, "cannot rename temporary '" + temporary.path.string() + "' into place", ec.value());
  temporary.kept = true;
}

// Attributes every field file carries at its root, so that a file read on its own says what it holds.
void write_file_attributes(hid_t file, const fs::path& target, bool voxel) {
  write_string_attribute(file, "softhom_version", softhom_version(), target);
  write_string_attribute(file, "units", "length mm, stress MPa, time s (F, J, fractions dimensionless)", target);
  write_string_attribute(file, "tensor_component_order",
                         "row-major: 11 12 13 21 22 23 31 32 33 (index 3*i + j), last dataset dimension", target);
  const std::string steps =
      "one group /step_<k> per output step (k from 0, zero-padded to 6 digits) with attribute time [s]; ";
  write_string_attribute(file, "layout",
                         steps + (voxel ? "cell data of a voxel grid with dims z y x (x fastest)"
                                        : "cell data in the order of /mesh/connectivity, node data in the order of "
                                          "/mesh/coordinates"),
                         target);
}

}  // namespace

struct FieldWriter::Impl {
  fs::path h5_final, h5_tmp, xdmf_final;
  bool voxel = true;
  // Per-centering entity counts and the HDF5/XDMF dimensions of one component (slowest first).
  std::size_t n_cells = 0, n_nodes = 0;
  std::vector<hsize_t> cell_dims, node_dims;
  std::string mesh_xml;   // Topology + Geometry, identical in every step
  std::string steps_xml;  // finished steps
  Handle file, group;
  int step = 0;
  bool in_step = false, finished = false;
  double time = 0.0;
  std::string step_xml;
  std::set<std::string> step_names;

  ~Impl() {
    if (finished) return;
    // Unfinished writer: drop everything, so no half-written result is left behind.
    group.reset();
    if (file.valid()) abandon_file(file.release());
    std::error_code ec;
    fs::remove(h5_tmp, ec);
  }

  void open(const fs::path& stem) {
    silence_hdf5();
    h5_final = stem;
    h5_final += ".h5";
    xdmf_final = stem;
    xdmf_final += ".xdmf";
    h5_tmp = temporary_path(h5_final);
    std::error_code ec;
    if (!h5_final.parent_path().empty()) {
      fs::create_directories(h5_final.parent_path(), ec);
      if (ec) throw WriteError(h5_final, "cannot create directory '" + h5_final.parent_path().string() + "'", ec.value());
    }
    if (write_failure_injected(h5_final)) throw WriteError(h5_final, "cannot create temporary", ENOSPC);
    file = checked_write(H5Fcreate(h5_tmp.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose, h5_final,
                         "cannot create temporary '" + h5_tmp.string() + "'");
    write_file_attributes(file.get(), h5_final, voxel);
  }

  // The voxel corners in the frame of grid.axes, written one plane z = const at a time (a plane of
  // corners in memory, not the grid: 1024³ cells would need 26 GB), and the grid described by them.
  void write_turned_corners(const VoxelGrid& grid) {
    const auto [nx, ny, nz] = grid.cells;
    const std::string what = "cannot write dataset '/mesh/coordinates'";
    Handle g = checked_write(H5Gcreate2(file.get(), "mesh", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose, h5_final,
                             "cannot create group /mesh");
    write_dataset(g.get(), "grid_axes", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, grid.axes.data(), {3, 3}, h5_final);
    std::vector<hsize_t> dims = node_dims;
    dims.push_back(3);
    Handle space = checked_write(H5Screate_simple(4, dims.data(), nullptr), H5Sclose, h5_final, what);
    Handle set = checked_write(H5Dcreate2(g.get(), "coordinates", H5T_IEEE_F64LE, space.get(), H5P_DEFAULT,
                                          H5P_DEFAULT, H5P_DEFAULT),
                               H5Dclose, h5_final, what);
    write_string_attribute(set.get(), "unit", "mm", h5_final);
    std::vector<double> plane(3 * std::size_t(nx + 1) * std::size_t(ny + 1));
    const hsize_t extent[4] = {1, dims[1], dims[2], 3};
    Handle memory = checked_write(H5Screate_simple(4, extent, nullptr), H5Sclose, h5_final, what);
    for (int k = 0; k <= nz; ++k) {
      std::size_t at = 0;
      for (int j = 0; j <= ny; ++j)
        for (int i = 0; i <= nx; ++i) {
          const double y[3] = {grid.origin[0] + i * grid.spacing[0], grid.origin[1] + j * grid.spacing[1],
                               grid.origin[2] + k * grid.spacing[2]};
          for (int r = 0; r < 3; ++r)
            plane[at++] = grid.axes[3 * r] * y[0] + grid.axes[3 * r + 1] * y[1] + grid.axes[3 * r + 2] * y[2];
        }
      const hsize_t start[4] = {hsize_t(k), 0, 0, 0};
      if (H5Sselect_hyperslab(space.get(), H5S_SELECT_SET, start, nullptr, extent, nullptr) < 0 ||
          H5Dwrite(set.get(), H5T_NATIVE_DOUBLE, memory.get(), space.get(), H5P_DEFAULT, plane.data()) < 0)
        hdf5_write_fail(h5_final, what);
    }
    mesh_xml = "        <Topology TopologyType=\"3DSMesh\" Dimensions=\"" + join(node_dims) + "\"/>\n" +
               "        <Geometry GeometryType=\"XYZ\">\n          <DataItem Dimensions=\"" + join(dims) +
               "\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" + href("/mesh/coordinates") +
               "</DataItem>\n        </Geometry>\n";
  }

  std::string href(const std::string& dataset) const {
    // Relative to the XDMF file (same directory), so the pair can be moved together.
    return xml_escape(h5_final.filename().string()) + ":" + dataset;
  }

  void require_open(const char* call) const {
    if (finished) throw std::logic_error(std::string("FieldWriter::") + call + ": writer is closed");
  }
  void require_step(const char* call) const {
    require_open(call);
    if (!in_step) throw std::logic_error(std::string("FieldWriter::") + call + ": no step begun");
  }

  // Validates the common part of add() and returns the dataset dimensions.
  std::vector<hsize_t> dims_for(const std::string& name, std::size_t size, int components, Centering c) {
    require_step("add");
    check_name(name);
    if (step_names.count(name))
      throw std::invalid_argument("FieldWriter: field '" + name + "' added twice in step " + std::to_string(step));
    if (components != 1 && components != 3 && components != 9)
      throw std::invalid_argument("FieldWriter: field '" + name + "' has " + std::to_string(components) +
                                  " components; expected 1, 3 or 9");
    const std::size_t count = c == Centering::cell ? n_cells : n_nodes;
    if (size != count * static_cast<std::size_t>(components))
      throw std::invalid_argument("FieldWriter: field '" + name + "' has " + std::to_string(size) +
                                  " values, expected " + std::to_string(count * components) + " (" +
                                  std::to_string(count) + (c == Centering::cell ? " cells" : " nodes") +
                                  " x " + std::to_string(components) + ")");
    auto dims = c == Centering::cell ? cell_dims : node_dims;
    if (components > 1) dims.push_back(static_cast<hsize_t>(components));
    return dims;
  }

  void add_attribute(const std::string& name, const std::vector<hsize_t>& dims, int components, Centering c,
                     const char* number_type, int precision) {
    const char* type = components == 1 ? "Scalar" : components == 3 ? "Vector" : "Tensor";
    step_xml += "        <Attribute Name=\"" + name + "\" AttributeType=\"" + type + "\" Center=\"" +
                (c == Centering::cell ? "Cell" : "Node") + "\">\n";
    step_xml += "          <DataItem Dimensions=\"" + join(dims) + "\" NumberType=\"" + number_type +
                "\" Precision=\"" + std::to_string(precision) + "\" Format=\"HDF\">" +
                href("/" + step_group_name(step) + "/" + name) + "</DataItem>\n";
    step_xml += "        </Attribute>\n";
    step_names.insert(name);
  }
};

FieldWriter::FieldWriter(const std::filesystem::path& stem, const VoxelGrid& grid)
    : impl_(std::make_unique<Impl>()) {
  for (int d = 0; d < 3; ++d) {
    if (grid.cells[d] < 1)
      throw std::invalid_argument("FieldWriter: voxel grid cells[" + std::to_string(d) + "] = " +
                                  std::to_string(grid.cells[d]) + " must be >= 1");
    if (!(std::isfinite(grid.spacing[d]) && grid.spacing[d] > 0.0))
      throw std::invalid_argument("FieldWriter: voxel grid spacing[" + std::to_string(d) + "] must be finite and > 0");
    if (!std::isfinite(grid.origin[d]))
      throw std::invalid_argument("FieldWriter: voxel grid origin[" + std::to_string(d) + "] must be finite");
  }
  if (!std::all_of(grid.axes.begin(), grid.axes.end(), [](double a) { return std::isfinite(a); }))
    throw std::invalid_argument("FieldWriter: voxel grid axes must be finite");
  auto& m = *impl_;
  m.voxel = true;
  const auto [nx, ny, nz] = grid.cells;
  m.n_cells = std::size_t(nx) * ny * nz;
  m.n_nodes = std::size_t(nx + 1) * (ny + 1) * (nz + 1);
  // XDMF (like C-order HDF5) lists the slowest index first: z y x. x is fastest in our storage.
  m.cell_dims = {hsize_t(nz), hsize_t(ny), hsize_t(nx)};
  m.node_dims = {hsize_t(nz + 1), hsize_t(ny + 1), hsize_t(nx + 1)};
  // ORIGIN_DXDYDZ values are read in the same z y x order (ParaView reverses them into x y z).
  m.mesh_xml = "        <Topology TopologyType=\"3DCoRectMesh\" Dimensions=\"" + join(m.node_dims) + "\"/>\n" +
               "        <Geometry GeometryType=\"ORIGIN_DXDYDZ\">\n"
               "          <DataItem Name=\"Origin\" Dimensions=\"3\" NumberType=\"Float\" Precision=\"8\" "
               "Format=\"XML\">" +
               number(grid.origin[2]) + " " + number(grid.origin[1]) + " " + number(grid.origin[0]) +
               "</DataItem>\n"
               "          <DataItem Name=\"Spacing\" Dimensions=\"3\" NumberType=\"Float\" Precision=\"8\" "
               "Format=\"XML\">" +
               number(grid.spacing[2]) + " " + number(grid.spacing[1]) + " " + number(grid.spacing[0]) +
               "</DataItem>\n"
               "        </Geometry>\n";
  m.open(stem);
  if (grid.axes != VoxelGrid{}.axes) m.write_turned_corners(grid);
}

FieldWriter::FieldWriter(const std::filesystem::path& stem, const UnstructuredMesh& mesh)
    : impl_(std::make_unique<Impl>()) {
  const CellInfo info = cell_info(mesh.cell_type);
  if (mesh.coordinates.empty() || mesh.coordinates.size() % 3 != 0)
    throw std::invalid_argument("FieldWriter: mesh coordinates size " + std::to_string(mesh.coordinates.size()) +
                                " is not a positive multiple of 3");
  if (std::any_of(mesh.coordinates.begin(), mesh.coordinates.end(), [](double x) { return !std::isfinite(x); }))
    throw std::invalid_argument("FieldWriter: mesh coordinates contain a non-finite value");
  const std::size_t nodes = mesh.coordinates.size() / 3;
  if (mesh.connectivity.empty() || mesh.connectivity.size() % info.nodes != 0)
    throw std::invalid_argument("FieldWriter: mesh connectivity size " + std::to_string(mesh.connectivity.size()) +
                                " is not a positive multiple of " + std::to_string(info.nodes) + " (" +
                                info.xdmf + ")");
  for (long n : mesh.connectivity)
    if (n < 0 || static_cast<std::size_t>(n) >= nodes)
      throw std::invalid_argument("FieldWriter: mesh connectivity refers to node " + std::to_string(n) +
                                  " of " + std::to_string(nodes));
  auto& m = *impl_;
  m.voxel = false;
  m.n_nodes = nodes;
  m.n_cells = mesh.connectivity.size() / info.nodes;
  m.cell_dims = {hsize_t(m.n_cells)};
  m.node_dims = {hsize_t(m.n_nodes)};
  m.open(stem);

  // The mesh is written once; every step's grid refers to the same two datasets.
  const fs::path& file = m.h5_final;
  Handle g = checked_write(H5Gcreate2(m.file.get(), "mesh", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose, file,
                           "cannot create group /mesh");
  write_dataset(g.get(), "coordinates", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, mesh.coordinates.data(),
                {hsize_t(nodes), 3}, file, "mm");
  write_dataset(g.get(), "connectivity", H5T_STD_I64LE, H5T_NATIVE_LONG, mesh.connectivity.data(),
                {hsize_t(m.n_cells), hsize_t(info.nodes)}, file);
  m.mesh_xml = "        <Topology TopologyType=\"" + std::string(info.xdmf) + "\" NumberOfElements=\"" +
               std::to_string(m.n_cells) + "\" NodesPerElement=\"" + std::to_string(info.nodes) + "\">\n" +
               "          <DataItem Dimensions=\"" + std::to_string(m.n_cells) + " " + std::to_string(info.nodes) +
               "\" NumberType=\"Int\" Precision=\"8\" Format=\"HDF\">" + m.href("/mesh/connectivity") +
               "</DataItem>\n"
               "        </Topology>\n"
               "        <Geometry GeometryType=\"XYZ\">\n"
               "          <DataItem Dimensions=\"" +
               std::to_string(nodes) + " 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" +
               m.href("/mesh/coordinates") +
               "</DataItem>\n"
               "        </Geometry>\n";
}

std::string step_group_name(int k) {
  const std::string digits = std::to_string(k);
  return "step_" + std::string(digits.size() < 6 ? 6 - digits.size() : 0, '0') + digits;
}

FieldWriter::~FieldWriter() = default;  // Impl's destructor removes the temporaries if not closed

void FieldWriter::begin_step(double time) {
  auto& m = *impl_;
  m.require_open("begin_step");
  if (m.in_step) throw std::logic_error("FieldWriter::begin_step: step " + std::to_string(m.step) + " not ended");
  if (!std::isfinite(time)) throw std::invalid_argument("FieldWriter::begin_step: time is not finite");
  const std::string name = step_group_name(m.step);
  m.group = checked_write(H5Gcreate2(m.file.get(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose,
                          m.h5_final, "cannot create group /" + name);
  write_double_attribute(m.group.get(), "time", time, m.h5_final);
  m.in_step = true;
  m.time = time;
  m.step_xml.clear();
  m.step_names.clear();
}

void FieldWriter::set_attribute(const std::string& name, const std::string& value) {
  auto& m = *impl_;
  m.require_open("set_attribute");
  check_name(name);
  write_string_attribute(m.file.get(), name.c_str(), value, m.h5_final);
}

void FieldWriter::add(const std::string& name, std::span<const double> data, int components, Centering centering,
                      const std::string& unit) {
  auto& m = *impl_;
  const auto dims = m.dims_for(name, data.size(), components, centering);
  for (std::size_t i = 0; i < data.size(); ++i)
    if (!std::isfinite(data[i]))
      throw std::invalid_argument("FieldWriter: field '" + name + "' has a non-finite value at index " +
                                  std::to_string(i));
  write_dataset(m.group.get(), name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, data.data(), dims, m.h5_final, unit);
  m.add_attribute(name, dims, components, centering, "Float", 8);
}

void FieldWriter::add_in_pieces(const std::string& name, int components, Centering centering,
                                const std::function<std::span<const double>()>& next_piece, const std::string& unit) {
  auto& m = *impl_;
  const std::size_t count = centering == Centering::cell ? m.n_cells : m.n_nodes;
  const auto dims = m.dims_for(name, count * static_cast<std::size_t>(components), components, centering);
  const std::string what = "cannot write dataset '" + name + "'";
  if (write_failure_injected(m.h5_final)) throw WriteError(m.h5_final, what, ENOSPC);
  Handle space = checked_write(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr), H5Sclose,
                               m.h5_final, what);
  Handle set = checked_write(H5Dcreate2(m.group.get(), name.c_str(), H5T_IEEE_F64LE, space.get(), H5P_DEFAULT,
                                        H5P_DEFAULT, H5P_DEFAULT),
                             H5Dclose, m.h5_final, what);
  const std::size_t total = count * static_cast<std::size_t>(components), per_plane = total / dims[0];
  std::size_t done = 0;
  for (std::span<const double> piece = next_piece(); !piece.empty(); piece = next_piece()) {
    if (piece.size() % per_plane != 0 || done + piece.size() > total)
      throw std::invalid_argument("FieldWriter: a piece of field '" + name + "' is not whole planes of the field");
    for (std::size_t i = 0; i < piece.size(); ++i)
      if (!std::isfinite(piece[i]))
        throw std::invalid_argument("FieldWriter: field '" + name + "' has a non-finite value at index " +
                                    std::to_string(done + i));
    std::vector<hsize_t> start(dims.size(), 0), extent = dims;
    start[0] = done / per_plane;
    extent[0] = piece.size() / per_plane;
    Handle memory = checked_write(H5Screate_simple(static_cast<int>(extent.size()), extent.data(), nullptr), H5Sclose,
                                  m.h5_final, what);
    if (H5Sselect_hyperslab(space.get(), H5S_SELECT_SET, start.data(), nullptr, extent.data(), nullptr) < 0 ||
        H5Dwrite(set.get(), H5T_NATIVE_DOUBLE, memory.get(), space.get(), H5P_DEFAULT, piece.data()) < 0)
      hdf5_write_fail(m.h5_final, what);
    done += piece.size();
  }
  if (done != total)
    throw std::invalid_argument("FieldWriter: field '" + name + "' got " + std::to_string(done) + " of " +
                                std::to_string(total) + " values in pieces");
  if (!unit.empty()) write_string_attribute(set.get(), "unit", unit, m.h5_final);
  m.add_attribute(name, dims, components, centering, "Float", 8);
}

void FieldWriter::add(const std::string& name, std::span<const int> data, Centering centering) {
  auto& m = *impl_;
  const auto dims = m.dims_for(name, data.size(), 1, centering);
  write_dataset(m.group.get(), name, H5T_STD_I32LE, H5T_NATIVE_INT, data.data(), dims, m.h5_final);
  m.add_attribute(name, dims, 1, centering, "Int", 4);
}

void FieldWriter::end_step() {
  auto& m = *impl_;
  m.require_step("end_step");
  if (!m.group.reset()) hdf5_write_fail(m.h5_final, "cannot close group /" + step_group_name(m.step));
  m.steps_xml += "      <Grid Name=\"" + step_group_name(m.step) + "\" GridType=\"Uniform\">\n" +
                 "        <Time Value=\"" + number(m.time) + "\"/>\n" + m.mesh_xml + m.step_xml + "      </Grid>\n";
  m.in_step = false;
  ++m.step;
}

void FieldWriter::close() {
  auto& m = *impl_;
  m.require_open("close");
  if (m.in_step) throw std::logic_error("FieldWriter::close: step " + std::to_string(m.step) + " not ended");
  const std::string xdmf = "<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n  <Domain>\n"
                           "    <Grid Name=\"" + xml_escape(m.xdmf_final.stem().string()) +
                           "\" GridType=\"Collection\" CollectionType=\"Temporal\">\n" +
                           m.steps_xml + "    </Grid>\n  </Domain>\n</Xdmf>\n";
  finish_file(m.file, m.h5_final, m.h5_tmp);
  fsync_file(m.h5_tmp, m.h5_final);
  std::error_code ec;
  fs::rename(m.h5_tmp, m.h5_final, ec);
  if (ec) throw WriteError(m.h5_final, "cannot rename temporary '" + m.h5_tmp.string() + "' into place", ec.value());
  // From here on the temporary is gone; the XDMF goes last so it never refers to a missing file.
  m.finished = true;
  write_file_atomic(m.xdmf_final, xdmf);
}

void silence_hdf5_errors() { silence_hdf5(); }

namespace {

/// Planes [first, first + count) of the first dimension, periodic; null: the whole dataset.
struct PlaneRange {
  long first = 0, count = 0;
};

/// Room for `count` values read by `what`: a dataset too large for memory is an error naming it and its
/// size, not std::bad_alloc (callers check the shape first; this is the last guard).
void allocate_values(std::vector<double>& values, std::size_t count, const std::string& what) {
  try {
    values.resize(count);
  } catch (const std::exception&) {  // std::bad_alloc, std::length_error
    throw std::runtime_error(what + ": " + std::to_string(count) + " values do not fit in memory");
  }
}

Dataset read_dataset_impl(const std::filesystem::path& file, const std::string& dataset, const PlaneRange* planes) {
  silence_hdf5();
  std::error_code ec;
  if (!fs::is_regular_file(file, ec)) throw std::runtime_error("read_dataset: no such file '" + file.string() + "'");
  Handle f = checked(H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose,
                     "read_dataset: cannot open '" + file.string() + "' as HDF5");
  const hid_t d_id = H5Dopen2(f.get(), dataset.c_str(), H5P_DEFAULT);
  if (d_id < 0) throw std::runtime_error("read_dataset: no dataset '" + dataset + "' in '" + file.string() + "'");
  Handle d(d_id, H5Dclose);
  const std::string what = "read_dataset: cannot read dataset '" + dataset + "' in '" + file.string() + "'";
  Handle type = checked(H5Dget_type(d.get()), H5Tclose, what);
  const H5T_class_t cls = H5Tget_class(type.get());
  if (cls != H5T_INTEGER && cls != H5T_FLOAT)
    throw std::runtime_error("read_dataset: dataset '" + dataset + "' in '" + file.string() + "' is not numeric");
  Handle space = checked(H5Dget_space(d.get()), H5Sclose, what);
  const int rank = H5Sget_simple_extent_ndims(space.get());
  if (rank < 0) hdf5_fail(what);
  std::vector<hsize_t> dims(static_cast<std::size_t>(rank));
  if (rank > 0 && H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr) < 0) hdf5_fail(what);
  const hssize_t n = H5Sget_simple_extent_npoints(space.get());
  if (n < 0) hdf5_fail(what);
  Dataset out;
  out.dims.assign(dims.begin(), dims.end());
  out.integer = cls == H5T_INTEGER;
  // Numeric attributes of the dataset (e.g. voxel_size); others (strings, compounds) are skipped.
  auto read_attr = [](hid_t loc, const char* name, const H5A_info_t*, void* data) -> herr_t {
    auto* attrs = static_cast<std::map<std::string, std::vector<double>>*>(data);
    const hid_t a = H5Aopen(loc, name, H5P_DEFAULT);
    if (a < 0) return 0;
    Handle attr(a, H5Aclose);
    const hid_t t = H5Aget_type(attr.get());
    if (t < 0) return 0;
    Handle atype(t, H5Tclose);
    const H5T_class_t c = H5Tget_class(atype.get());
    if (c != H5T_INTEGER && c != H5T_FLOAT) return 0;
    const hid_t sp = H5Aget_space(attr.get());
    if (sp < 0) return 0;
    Handle aspace(sp, H5Sclose);
    const hssize_t count = H5Sget_simple_extent_npoints(aspace.get());
    if (count <= 0) return 0;
    std::vector<double> v(static_cast<std::size_t>(count));
    if (H5Aread(attr.get(), H5T_NATIVE_DOUBLE, v.data()) >= 0) (*attrs)[name] = std::move(v);
    return 0;
  };
  hsize_t attr_index = 0;
  H5Aiterate2(d.get(), H5_INDEX_NAME, H5_ITER_NATIVE, &attr_index, read_attr, &out.attributes);
  if (!planes) {
    allocate_values(out.values, static_cast<std::size_t>(n), what);
    // HDF5 converts any integer or float type to native double on read.
    if (n > 0 && H5Dread(d.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.values.data()) < 0)
      hdf5_fail(what);
    return out;
  }
  if (planes->count == 0) return out;  // dims, type and attributes only
  if (rank < 1 || planes->count < 0) throw std::runtime_error(what + ": planes need a dataset of rank >= 1");
  const long n0 = long(dims[0]);
  const std::size_t per_plane = n0 > 0 ? std::size_t(n) / std::size_t(n0) : 0;
  allocate_values(out.values, per_plane * std::size_t(planes->count), what);
  if (per_plane == 0) return out;
  // One hyperslab per run of consecutive planes (a periodic range wraps at most a few times).
  std::vector<hsize_t> start(dims.size(), 0), count(dims);
  double* to = out.values.data();
  for (long k = planes->first; k < planes->first + planes->count;) {
    const long p0 = ((k % n0) + n0) % n0;
    const long run = std::min(n0 - p0, planes->first + planes->count - k);
    start[0] = hsize_t(p0);
    count[0] = hsize_t(run);
    if (H5Sselect_hyperslab(space.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr) < 0) hdf5_fail(what);
    Handle memory = checked(H5Screate_simple(rank, count.data(), nullptr), H5Sclose, what);
    if (H5Dread(d.get(), H5T_NATIVE_DOUBLE, memory.get(), space.get(), H5P_DEFAULT, to) < 0) hdf5_fail(what);
    to += per_plane * std::size_t(run);
    k += run;
  }
  return out;
}

}  // namespace

Dataset read_dataset(const std::filesystem::path& file, const std::string& dataset) {
  return read_dataset_impl(file, dataset, nullptr);
}

Dataset read_dataset_planes(const std::filesystem::path& file, const std::string& dataset, long first, long count) {
  const PlaneRange planes{first, count};
  return read_dataset_impl(file, dataset, &planes);
}

}  // namespace softhom::io

namespace softhom::io {

namespace {

void write_attribute(hid_t loc, const char* name, const std::array<double, 3>& v, const std::string& what, const fs::path& target) {
  const hsize_t n = 3;
  Handle space = checked_write(H5Screate_simple(1, &n, nullptr), H5Sclose, target, what);
  Handle attr = checked_write(H5Acreate2(loc, name, H5T_IEEE_F64LE, space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose, target, what);
  if (H5Awrite(attr.get(), H5T_NATIVE_DOUBLE, v.data()) < 0) hdf5_write_fail(target, what);
}

/// A dataset of a voxel image checked: a new name, 1 or 3 components, one value per cell and component.
void check_voxel_dataset(const VoxelImageDataset& ds, std::size_t n_cells, std::set<std::string>& names) {
  check_name(ds.name);
  if (!names.insert(ds.name).second)
    throw std::invalid_argument("write_voxel_image: dataset '" + ds.name + "' given twice");
  if (ds.components != 1 && ds.components != 3)
    throw std::invalid_argument("write_voxel_image: dataset '" + ds.name + "' must have 1 or 3 components");
  if (ds.values.size() != n_cells * std::size_t(ds.components))
    throw std::invalid_argument("write_voxel_image: dataset '" + ds.name + "' has " + std::to_string(ds.values.size()) +
                                " values, expected " + std::to_string(n_cells * ds.components));
}

/// The values of a voxel dataset: bytes (integers in [0, 255]) or finite float64.
void write_voxel_values(hid_t file, const VoxelImageDataset& ds, const std::vector<hsize_t>& dims,
                        const fs::path& target) {
  if (ds.as_uint8) {
    std::vector<unsigned char> bytes(ds.values.size());
    for (std::size_t i = 0; i < bytes.size(); ++i) {
      const double v = ds.values[i];
      if (!(v >= 0.0 && v <= 255.0 && v == std::floor(v)))
        throw std::invalid_argument("write_voxel_image: dataset '" + ds.name + "' value " + number(v) + " at index " +
                                    std::to_string(i) + " is not an integer in [0, 255]");
      bytes[i] = static_cast<unsigned char>(v);
    }
    write_dataset(file, ds.name, H5T_STD_U8LE, H5T_NATIVE_UCHAR, bytes.data(), dims, target);
  } else {
    for (std::size_t i = 0; i < ds.values.size(); ++i)
      if (!std::isfinite(ds.values[i]))
        throw std::invalid_argument("write_voxel_image: dataset '" + ds.name + "' has a non-finite value at index " +
                                    std::to_string(i));
    write_dataset(file, ds.name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, ds.values.data(), dims, target);
  }
}

/// The attributes of a written voxel dataset: voxel and cell size, and the layout tag in the
/// convention of FANS (variable-length string; "zyx": file dims z, y, x).
void write_voxel_attributes(hid_t file, const std::string& name, const VoxelGrid& grid, const std::array<double, 3>& cell,
                            const fs::path& target, const std::string& what) {
  Handle set = checked_write(H5Dopen2(file, name.c_str(), H5P_DEFAULT), H5Dclose, target, what);
  write_attribute(set.get(), "voxel_size", grid.spacing, what, target);
  write_attribute(set.get(), "cell_size", cell, what, target);
  Handle str = checked_write(H5Tcopy(H5T_C_S1), H5Tclose, target, what);
  if (H5Tset_size(str.get(), H5T_VARIABLE) < 0) hdf5_write_fail(target, what);
  Handle scalar = checked_write(H5Screate(H5S_SCALAR), H5Sclose, target, what);
  Handle attr = checked_write(H5Acreate2(set.get(), "permute_order", str.get(), scalar.get(), H5P_DEFAULT, H5P_DEFAULT),
                              H5Aclose, target, what);
  const char* zyx = "zyx";
  if (H5Awrite(attr.get(), str.get(), &zyx) < 0) hdf5_write_fail(target, what);
}

/// The XDMF of a voxel image: a co-rectilinear grid of the cells with one attribute per dataset.
std::string voxel_xdmf(const fs::path& xdmf_final, const VoxelGrid& grid, const std::string& attrs_xml) {
  const std::vector<hsize_t> node_dims{hsize_t(grid.cells[2] + 1), hsize_t(grid.cells[1] + 1), hsize_t(grid.cells[0] + 1)};
  return "<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n  <Domain>\n    <Grid Name=\"" +
         xml_escape(xdmf_final.stem().string()) + "\" GridType=\"Uniform\">\n" +
         "      <Topology TopologyType=\"3DCoRectMesh\" Dimensions=\"" + join(node_dims) + "\"/>\n" +
         "      <Geometry GeometryType=\"ORIGIN_DXDYDZ\">\n"
         "        <DataItem Name=\"Origin\" Dimensions=\"3\" NumberType=\"Float\" Precision=\"8\" Format=\"XML\">" +
         number(grid.origin[2]) + " " + number(grid.origin[1]) + " " + number(grid.origin[0]) + "</DataItem>\n" +
         "        <DataItem Name=\"Spacing\" Dimensions=\"3\" NumberType=\"Float\" Precision=\"8\" Format=\"XML\">" +
         number(grid.spacing[2]) + " " + number(grid.spacing[1]) + " " + number(grid.spacing[0]) + "</DataItem>\n" +
         "      </Geometry>\n" + attrs_xml + "    </Grid>\n  </Domain>\n</Xdmf>\n";
}

}  // namespace

void write_voxel_image(const std::filesystem::path& stem, const VoxelGrid& grid,
                       const std::vector<VoxelImageDataset>& datasets) {
  silence_hdf5();
  std::array<double, 3> cell{};
  for (int d = 0; d < 3; ++d) {
    if (grid.cells[d] < 1 || !(std::isfinite(grid.spacing[d]) && grid.spacing[d] > 0.0))
      throw std::invalid_argument("write_voxel_image: grid needs cells >= 1 and finite spacing > 0");
    cell[d] = grid.cells[d] * grid.spacing[d];
  }
  const std::size_t n_cells = std::size_t(grid.cells[0]) * grid.cells[1] * grid.cells[2];
  fs::path h5_final = stem, xdmf_final = stem;
  h5_final += ".h5";
  xdmf_final += ".xdmf";
  TemporaryFile temporary = temporary_for(h5_final);
  const fs::path& h5_tmp = temporary.path;
  const std::string href_file = xml_escape(h5_final.filename().string());
  std::string attrs_xml;
  {
    // Closed by finish_file() when complete; an exception before that abandons it (abandon_file).
    Handle file = checked_write(H5Fcreate(h5_tmp.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), abandon_close,
                                h5_final, "cannot create temporary '" + h5_tmp.string() + "'");
    write_string_attribute(file.get(), "softhom_version", softhom_version(), h5_final);
    std::set<std::string> names;
    for (const VoxelImageDataset& ds : datasets) {
      check_voxel_dataset(ds, n_cells, names);
      std::vector<hsize_t> dims{hsize_t(grid.cells[2]), hsize_t(grid.cells[1]), hsize_t(grid.cells[0])};
      if (ds.components > 1) dims.push_back(hsize_t(ds.components));
      const std::string what = "write_voxel_image: cannot write '" + ds.name + "' to '" + h5_tmp.string() + "'";
      write_voxel_values(file.get(), ds, dims, h5_final);
      write_voxel_attributes(file.get(), ds.name, grid, cell, h5_final, what);
      const char* type = ds.components == 1 ? "Scalar" : "Vector";
      attrs_xml += "      <Attribute Name=\"" + ds.name + "\" AttributeType=\"" + type + "\" Center=\"Cell\">\n" +
                   "        <DataItem Dimensions=\"" + join(dims) + "\" NumberType=\"" +
                   (ds.as_uint8 ? "UChar\" Precision=\"1" : "Float\" Precision=\"8") + "\" Format=\"HDF\">" + href_file +
                   ":/" + ds.name + "</DataItem>\n      </Attribute>\n";
    }
    finish_file(file, h5_final, h5_tmp);
  }
  move_into_place(temporary, h5_final);
  write_file_atomic(xdmf_final, voxel_xdmf(xdmf_final, grid, attrs_xml));
}

void write_array_file(const std::filesystem::path& path, const std::vector<ArrayToWrite>& arrays) {
  silence_hdf5();
  TemporaryFile temporary = temporary_for(path);
  const fs::path& tmp = temporary.path;
  {
    Handle file = checked_write(H5Fcreate(tmp.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), abandon_close, path,
                                "cannot create temporary '" + tmp.string() + "'");
    write_string_attribute(file.get(), "softhom_version", softhom_version(), path);
    for (const ArrayToWrite& a : arrays) {
      check_name(a.name);
      if (!a.f64.empty() && !a.f32.empty())
        throw std::invalid_argument("write_array_file: array '" + a.name + "' given as float64 and float32");
      static const double nothing = 0.0;  // the buffer of an empty selection (HDF5 wants one)
      if (!a.f32.empty())
        write_dataset(file.get(), a.name, H5T_IEEE_F32LE, H5T_NATIVE_FLOAT, a.f32.data(), {hsize_t(a.f32.size())}, path);
      else
        write_dataset(file.get(), a.name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, a.f64.empty() ? &nothing : a.f64.data(),
                      {hsize_t(a.f64.size())}, path);
    }
    finish_file(file, path, tmp);
  }
  move_into_place(temporary, path);
}

}  // namespace softhom::io
