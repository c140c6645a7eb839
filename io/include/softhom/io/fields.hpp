#pragma once
// Fields for ParaView: one HDF5 file with the heavy data and an XDMF sidecar describing a time series.
// Both are written under temporary names and renamed on close(); an unfinished writer leaves nothing.
// HDF5's automatic error printing is off: every HDF5 call is checked and failures become exceptions.
#include <array>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace softhom::io {

/// A regular voxel grid (XDMF 3DCoRectMesh). Cell data are stored with x fastest: index
/// i + n[0] * (j + n[1] * k).
struct VoxelGrid {
  std::array<int, 3> cells{1, 1, 1};
  std::array<double, 3> spacing{1.0, 1.0, 1.0};
  std::array<double, 3> origin{0.0, 0.0, 0.0};
  /// The frame the grid is shown in: row-major 3×3 whose column j is grid axis j in that frame
  /// (x = axes · (origin + i ⊙ spacing)). Not the identity: the writer stores the voxel corners so turned
  /// (/mesh/coordinates, dims z y x 3, and /mesh/grid_axes) and describes a curvilinear grid (XDMF 3DSMesh),
  /// so that ParaView shows the cell in that frame; the data keep the grid's z y x layout.
  std::array<double, 9> axes{1, 0, 0, 0, 1, 0, 0, 0, 1};
};

enum class CellType { line2, line3, triangle3, triangle6, quad4, tetra4, tetra10, hexa8 };

/// An unstructured mesh: node coordinates (x, y, z per node) and connectivity (nodes per cell, all
/// cells of one type).
struct UnstructuredMesh {
  std::vector<double> coordinates;   ///< 3 × nodes
  std::vector<long> connectivity;    ///< nodes_per_cell × cells, 0-based
  CellType cell_type = CellType::hexa8;
};

enum class Centering { cell, node };

/// The HDF5 group of output step k (from 0): "step_000012". Zero-padded to 6 digits so that h5ls, h5py
/// and ParaView's tree list the steps in time order (step_10 after step_9, not after step_1).
std::string step_group_name(int k);

class FieldWriter {
 public:
  /// `stem` is DIR/name: writes DIR/name.h5 and DIR/name.xdmf.
  FieldWriter(const std::filesystem::path& stem, const VoxelGrid& grid);
  FieldWriter(const std::filesystem::path& stem, const UnstructuredMesh& mesh);
  ~FieldWriter();  // without close(): removes the temporaries
  FieldWriter(const FieldWriter&) = delete;
  FieldWriter& operator=(const FieldWriter&) = delete;

  /// Starts step k (datasets under /step_group_name(k)/). The mesh itself is fixed: give the deformed shape as a
  /// node-centred 3-component field named "displacement" (ParaView: Warp By Vector).
  void begin_step(double time);
  /// `components` is 1 (scalar), 3 (vector) or 9 (tensor, row-major); data has components × count.
  /// A non-empty `unit` is stored as the dataset's string attribute "unit" (e.g. "MPa", "1").
  void add(const std::string& name, std::span<const double> data, int components, Centering centering,
           const std::string& unit = "");
  void add(const std::string& name, std::span<const int> data, Centering centering);
  /// The dataset of add(), written in pieces of whole planes (its slowest dimension) one after the other:
  /// `next_piece()` returns the next piece (components × entities, in the order of the full array), or
  /// an empty span after the last; the pieces must add up to the field. For fields gathered from MPI
  /// ranks slab by slab: the caller holds one piece at a time, not the field.
  void add_in_pieces(const std::string& name, int components, Centering centering,
                     const std::function<std::span<const double>()>& next_piece, const std::string& unit = "");
  void end_step();
  /// A string attribute on the file's root (e.g. "frame"). Every file already carries
  /// "softhom_version", "units", "tensor_component_order" and "layout"; every step group a
  /// float64 attribute "time" (s).
  void set_attribute(const std::string& name, const std::string& value);
  /// Finishes both files and renames them into place. Write failures throw io::WriteError naming
  /// DIR/name.h5 (files.hpp); the temporary is removed and an earlier DIR/name.h5 stays as it was.
  void close();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// One named 1D array of an array file (write_array_file): float64 or float32 values, one of the two
/// spans non-empty (or both empty: a dataset of length 0).
struct ArrayToWrite {
  std::string name;
  std::span<const double> f64;
  std::span<const float> f32;
};
/// Writes 1D datasets at the root of the HDF5 file `path`, atomically like FieldWriter (a temporary
/// next to it, fsync, rename): a reader, or a kill -9, sees the old file or the complete new one.
/// Read back with read_dataset (float32 values convert exactly). Throws WriteError naming `path`.
void write_array_file(const std::filesystem::path& path, const std::vector<ArrayToWrite>& arrays);

/// Turns HDF5's automatic error-stack printing off for the whole process (main() calls it first):
/// every HDF5 call of softhom checks its result and reports a failure as one message.
void silence_hdf5_errors();

/// Reads an HDF5 dataset as doubles (any numeric type converted) with its dimensions (C order), whether
/// it is stored as integers, and its numeric attributes (name → values, flattened).
struct Dataset {
  std::vector<double> values;
  std::vector<std::size_t> dims;
  bool integer = false;
  std::map<std::string, std::vector<double>> attributes;
};
/// Throws std::runtime_error naming the file and dataset when the file is missing, not HDF5, has no
/// such dataset, or the dataset is not numeric.
Dataset read_dataset(const std::filesystem::path& file, const std::string& dataset);
/// The same for the planes [first, first + count) of the first (slowest) dimension only, taken
/// periodically (first may be negative, and a plane is read twice when count exceeds dims[0]): `values`
/// holds those planes in that order, `dims` the whole dataset's. count = 0 reads dims, type and
/// attributes only. What one rank of a distributed cell reads of an image: O(voxels / ranks).
Dataset read_dataset_planes(const std::filesystem::path& file, const std::string& dataset, long first, long count);

/// One dataset of a voxel image: `components` (1 or 3) values per voxel, x fastest; stored as uint8
/// when `as_uint8` (values must be integers in [0, 255]), else as float64.
struct VoxelImageDataset {
  std::string name;
  std::vector<double> values;
  int components = 1;
  bool as_uint8 = false;
};
/// Writes a static voxel image (no time steps) for ParaView and for re-import: stem.h5 with each
/// dataset at the root, C-order dims [n3][n2][n1] (+ [components]), every dataset carrying the
/// attributes `voxel_size` and `cell_size` (x, y, z order) and `permute_order = "zyx"` (the layout tag
/// FANS reads, so a uint8 phase dataset is a FANS microstructure as is), and an XDMF sidecar stem.xdmf. Atomic like
/// FieldWriter (temporary names, renamed when complete).
void write_voxel_image(const std::filesystem::path& stem, const VoxelGrid& grid,
                       const std::vector<VoxelImageDataset>& datasets);

}  // namespace softhom::io
