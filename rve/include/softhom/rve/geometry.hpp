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
///
/// A whole image (slab = false) holds all n3 planes. A slab image, what one rank of a distributed FFT
/// cell holds (extrude_planes(), slab_of()), holds only the planes i3 ∈ [plane_begin, plane_begin +
/// plane_count) it owns and `halo` neighbour planes on each side (periodic in i3; none for a rank without
/// planes, plane_count = 0, which FFTW-MPI's block distribution can leave): its arrays have
/// held_voxels() = n1 n2 (plane_count + 2 halo) entries, in the order of the held planes
/// plane_begin − halo, …, plane_begin + plane_count + halo − 1. n and size stay those of the whole cell.
/// The halo serves −∇φ normal estimates of composite voxels (one plane each side).
struct PhaseImage {
  std::array<int, 3> n{1, 1, 1};
  std::array<double, 3> size{1.0, 1.0, 1.0};  ///< cell dimensions (L1, L2, L3)
  bool slab = false;
  int plane_begin = 0, plane_count = 0, halo = 0;  ///< slab images only
  std::vector<double> fiber_fraction;        ///< fiber volume fraction of each voxel, in [0, 1]
  /// Unit interface normal (grid frame, pointing out of the fiber) of composite voxels
  /// (0 < fraction < 1); zero vector elsewhere. Used by the laminate rule.
  std::vector<Eigen::Vector3d> normal;
  /// Optional per-voxel fiber direction (grid frame) for imported images; empty = y3 everywhere.
  std::vector<Eigen::Vector3d> fiber_direction;
  /// Fiber volume fraction of the owned voxels (a slab image: of its own planes only; the cell's fraction
  /// is then the owned_fiber_sum() of all slabs over voxels()).
  double volume_fraction() const;
  /// Voxels of the whole cell.
  std::size_t voxels() const { return std::size_t(n[0]) * n[1] * n[2]; }
  bool is_slab() const { return slab; }
  /// Entries of the per-voxel arrays: voxels() for a whole image, n1 n2 (plane_count + 2 halo) for a slab.
  std::size_t held_voxels() const;
  /// Voxels of the owned planes (all voxels of a whole image) and the position of the first in the arrays.
  std::size_t owned_voxels() const;
  std::size_t owned_offset() const;
  /// Position in the arrays of voxel (i1, i2, i3) of the whole grid, each index taken periodically; for a
  /// slab, i3 must be a held plane (std::out_of_range otherwise).
  std::size_t index_of(int i1, int i2, int i3) const;
  /// Σ φ over the owned voxels.
  double owned_fiber_sum() const;
  /// Σ φ d⊗d over the owned voxels with per-voxel directions (zero without them).
  Eigen::Matrix3d owned_orientation_sum() const;
  /// Mean fiber axis (grid frame, unit): y3 without per-voxel directions, else the principal axis of the
  /// fiber-fraction-weighted orientation tensor Σ φ d⊗d (sign-free, as ±d is the same fiber), signed so
  /// that its largest component is positive. The solvers measure the fiber rotation along it. For a slab
  /// image, of its own planes (the cell's: principal_fiber_axis() of the orientation sums of all slabs).
  Eigen::Vector3d mean_fiber_direction() const;
};

/// The principal axis of an orientation sum Σ φ d⊗d as mean_fiber_direction() defines it (y3 when zero).
Eigen::Vector3d principal_fiber_axis(const Eigen::Matrix3d& orientation_sum);

/// Pixelises the section on an n1 × n2 grid (n3 = 1, L3 = L1 / n1 so voxels are cubes), with each
/// pixel's true fiber area fraction (sub-pixel accurate: exact or adaptive quadrature to 1e-6) and the
/// interface normal of composite pixels.
PhaseImage voxelize_section(const Section& section, int n1, int n2);

/// The section image of a cell without fibers: n1 × n2 pixels of fraction 0, L1 = 1, square pixels.
/// Refused like voxelize_section's (InputError naming microstructure.grid) when it cannot be held.
PhaseImage matrix_only_section(int n1, int n2);

/// Refuses (InputError(field, value, "needs about X GiB, ...")) a phase image of `voxels` voxels that
/// cannot be held with `extra_bytes_per_voxel` more per voxel (a read buffer), before it is allocated.
void refuse_oversized_image(double voxels, double extra_bytes_per_voxel, const std::string& field, const std::string& value);

/// Extrudes a section image to n3 layers along y3 (for 3D solves on the same section grid).
PhaseImage extrude(const PhaseImage& section_image, int n3);

/// The slab image (planes [begin, begin + count) and `halo` neighbour planes each side) of the section
/// extruded to n3 layers: extrude(section_image, n3) restricted to those planes, built without the whole
/// image (memory O(n1 n2 (count + 2 halo))). Straight fibers: every plane is the section.
PhaseImage extrude_planes(const PhaseImage& section_image, int n3, int begin, int count, int halo);

/// The same slab cut from a whole image.
PhaseImage slab_of(const PhaseImage& whole, int begin, int count, int halo);

}  // namespace softhom::rve
