#pragma once
// Composite voxels of the FFT engine (0 < fiber fraction φ < 1): the rank-one laminate rule with the
// voxel's interface normal n. The phases share the tangential part of F and jump by a vector a
// normal to the interface, F_f = F + (1−φ) a⊗n, F_m = F − φ a⊗n; a follows from traction continuity
// (P_f − P_m) n = 0, solved per point by Newton; P = φ P_f + (1−φ) P_m and the tangent by static
// condensation of a.
#include <cstddef>

#include "softhom/materials/material.hpp"
#include "softhom/rve/geometry.hpp"

namespace softhom::rve::detail {

/// The two phases at one composite material point (index 0 matrix, 1 fiber): laws and their
/// histories (null for elastic laws), and the largest bulk modulus (round-off floor of the traction).
struct LaminatePoint {
  const Material* phase[2] = {nullptr, nullptr};
  const double* state_old[2] = {nullptr, nullptr};
  double* state_new[2] = {nullptr, nullptr};
  double K_max = 0.0;
};

/// Laminate rule at F with fiber fraction f and unit normal n; `a` (in/out) is the jump vector,
/// warm-started from the last value. Returns P, the condensed tangent A (when non-null), and the
/// phase states Px, Fx; a failed material call or no traction continuity in 40 iterations fails.
MaterialStatus laminate_point(const LaminatePoint& pt, const Mat3& F, double f, const Vec3& n, Vec3& a, double dt,
                              Mat3& P, Mat9* A, Mat3 Px[2], Mat3 Fx[2]);

/// Normal of a composite voxel of an imported image without normals: −∇φ by central differences
/// (pointing out of the fiber); zero when the neighbourhood is flat (then the Voigt rule is used).
/// `v` is a voxel of the whole grid (of an owned plane of a slab image, whose halo holds the neighbours).
Vec3 estimate_interface_normal(const PhaseImage& im, std::size_t v);

}  // namespace softhom::rve::detail
