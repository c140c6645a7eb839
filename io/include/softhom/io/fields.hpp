#pragma once
// Fields for ParaView: one HDF5 file with the heavy data and an XDMF sidecar describing a time series.
// Both are written under temporary names and renamed on close(); an unfinished writer leaves nothing.
#include <array>
#include <filesystem>
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
};

enum class CellType { triangle3, triangle6, quad4, tetra4, tetra10, hexa8 };

/// An unstructured mesh: node coordinates (x, y, z per node) and connectivity (nodes per cell, all
/// cells of one type).
struct UnstructuredMesh {
  std::vector<double> coordinates;   ///< 3 × nodes
  std::vector<long> connectivity;    ///< nodes_per_cell × cells, 0-based
  CellType cell_type = CellType::hexa8;
};

enum class Centering { cell, node };

class FieldWriter {
 public:
  /// `stem` is DIR/name: writes DIR/name.h5 and DIR/name.xdmf.
  FieldWriter(const std::filesystem::path& stem, const VoxelGrid& grid);
  FieldWriter(const std::filesystem::path& stem, const UnstructuredMesh& mesh);
  ~FieldWriter();  // without close(): removes the temporaries
  FieldWriter(const FieldWriter&) = delete;
  FieldWriter& operator=(const FieldWriter&) = delete;

  /// Starts step k (datasets under /step_<k>/). The mesh itself is fixed: give the deformed shape as a
  /// node-centred 3-component field named "displacement" (ParaView: Warp By Vector).
  void begin_step(double time);
  /// `components` is 1 (scalar), 3 (vector) or 9 (tensor, row-major); data has components × count.
  void add(const std::string& name, std::span<const double> data, int components, Centering centering);
  void add(const std::string& name, std::span<const int> data, Centering centering);
  void end_step();
  /// Finishes both files and renames them into place.
  void close();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Reads an HDF5 dataset as doubles (any numeric type converted) with its dimensions (C order).
struct Dataset {
  std::vector<double> values;
  std::vector<std::size_t> dims;
};
Dataset read_dataset(const std::filesystem::path& file, const std::string& dataset);

}  // namespace softhom::io
