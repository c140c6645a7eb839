#pragma once
// Periodic cells of straight, continuous, parallel fibers and their voxel images.
//
// Cell frame ("grid frame"): y1, y2 span the fiber cross-section, y3 is the fiber axis. For straight
// continuous fibers nothing varies along y3, so a cross-section image describes the whole cell; a 3D
// image is the section extruded over n3 layers.
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace softhom::rve {

enum class SectionShape { circle, rectangle };
enum class Arrangement { square, hexagonal, random };

/// What the user asks for (scene [microstructure] table).
struct FiberCellSpec {
  SectionShape shape = SectionShape::circle;
  double radius = 0.0;                 ///< circle: fiber radius (fiber size)
  double width = 0.0, height = 0.0;    ///< rectangle: side lengths along y1, y2 before rotation
  double section_rotation_deg = 0.0;   ///< in-section rotation of each rectangle
  Arrangement arrangement = Arrangement::square;
  double volume_fraction = 0.0;        ///< target fiber volume fraction (0, packing limit)
  /// Exactly one of fiber size (radius / width,height above) or cell size may be given; the other is
  /// derived from the volume fraction. cell_size is the side of the square cell (square arrangement),
  /// the y1 side (hexagonal: y2 side = √3 y1), or the side of the square random cell.
  std::optional<double> cell_size;
  int fiber_count = 1;                 ///< random arrangement: number of fibers in the cell
  double min_gap = 0.0;                ///< random arrangement: minimum surface-to-surface gap
  std::uint64_t seed = 1;              ///< random arrangement: reproducible placement
};

/// One fiber's cross-section in the periodic cell.
struct FiberSection {
  Eigen::Vector2d center;
  SectionShape shape = SectionShape::circle;
  double radius = 0.0;
  double width = 0.0, height = 0.0;
  double rotation_deg = 0.0;
};

/// A generated periodic section: cell [0, L1) × [0, L2) in the y1–y2 plane.
struct Section {
  double L1 = 1.0, L2 = 1.0;
  std::vector<FiberSection> fibers;
  double volume_fraction = 0.0;   ///< exact (analytic) area fraction achieved
};

/// Builds the section; throws softhom::InputError naming the field on impossible requests
/// (volume fraction above the packing limit of the arrangement, overlap, no room for random fibers
/// with the requested gap, non-positive sizes).
Section generate_section(const FiberCellSpec& spec, const std::string& field_prefix = "microstructure");

/// Voxel image of the fiber phase. Index of voxel (i1, i2, i3): i1 + n1 * (i2 + n2 * i3).
struct PhaseImage {
  std::array<int, 3> n{1, 1, 1};
  std::array<double, 3> size{1.0, 1.0, 1.0};  ///< cell dimensions (L1, L2, L3)
  std::vector<double> fiber_fraction;        ///< fiber volume fraction of each voxel, in [0, 1]
  /// Unit interface normal (grid frame, pointing out of the fiber) of composite voxels
  /// (0 < fraction < 1); zero vector elsewhere. Used by the laminate rule.
  std::vector<Eigen::Vector3d> normal;
  /// Optional per-voxel fiber direction (grid frame) for imported images; empty = y3 everywhere.
  std::vector<Eigen::Vector3d> fiber_direction;
  double volume_fraction() const;
  std::size_t voxels() const { return std::size_t(n[0]) * n[1] * n[2]; }
  /// Mean fiber axis (grid frame, unit): y3 without per-voxel directions, else the principal axis of the
  /// fiber-fraction-weighted orientation tensor Σ φ d⊗d (sign-free, as ±d is the same fiber), signed so
  /// that its largest component is positive. The solvers measure the fiber rotation along it.
  Eigen::Vector3d mean_fiber_direction() const;
};

/// Pixelises the section on an n1 × n2 grid (n3 = 1, L3 = L1 / n1 so voxels are cubes), with each
/// pixel's true fiber area fraction (sub-pixel accurate: exact or adaptive quadrature to 1e-6) and the
/// interface normal of composite pixels.
PhaseImage voxelize_section(const Section& section, int n1, int n2);

/// Extrudes a section image to n3 layers along y3 (for 3D solves on the same section grid).
PhaseImage extrude(const PhaseImage& section_image, int n3);

}  // namespace softhom::rve
