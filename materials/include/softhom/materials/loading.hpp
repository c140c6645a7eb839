#pragma once
// Macroscopic mixed control shared by the material-point driver and the RVE engines: each of the nine
// components of the (load-frame) deformation gradient is either prescribed as a function of time, or
// left free with the matching first Piola stress component prescribed (zero by default).
#include <array>
#include <string>
#include <vector>

#include "softhom/materials/tensor.hpp"

namespace softhom {

/// Piecewise-linear function of time through (t_k, v_k), constant beyond the last point.
struct PiecewiseLinear {
  std::vector<double> t{0.0};
  std::vector<double> v{0.0};
  static PiecewiseLinear constant(double value) { return {{0.0}, {value}}; }
  double operator()(double time) const;
  double end_time() const { return t.back(); }
};

enum class ControlKind { deformation, stress };

struct MixedControl {
  /// Load frame: column a of `frame` is load axis a in global coordinates (e1 = load direction for
  /// uniaxial presets). All prescribed values, outputs and fiber angles are in this frame.
  Mat3 frame = Mat3::Identity();
  std::array<ControlKind, 9> kind{};        ///< per component 3*i + j
  std::array<PiecewiseLinear, 9> value{};   ///< F_ij(t) or P_ij(t)
  std::vector<double> times;                ///< output times, increasing, first > 0
  std::string name = "mixed";               ///< preset name for logs

  /// Throws InputError (field "load...") when the control leaves a rigid rotation free (both F_ij
  /// and F_ji free for some i ≠ j) or times are not increasing.
  void validate() const;
  /// F at time t with the free components taken from `free_guess`.
  Mat3 prescribed_F(double time, const Mat3& free_guess) const;
};

/// Presets. `stretch` is λ(t) of the load axis (γ(t) for simple shear).
/// uniaxial: F11 = λ, F12 = F13 = F23 = 0; P21 = P22 = P31 = P32 = P33 = 0 (P23 = 0 then follows from
///           the symmetry of σ) → σ = σ11 e1⊗e1.
MixedControl uniaxial_control(const PiecewiseLinear& stretch, const Vec3& direction = Vec3::UnitX(),
                              const Vec3& in_plane = Vec3::UnitY());
/// equibiaxial: F11 = F22 = λ, F12 = F21 = F13 = F23 = 0; P31 = P32 = P33 = 0 (σ33 = 0).
MixedControl equibiaxial_control(const PiecewiseLinear& stretch, const Mat3& frame = Mat3::Identity());
/// pure shear: F11 = λ, F22 = 1, F12 = F21 = F13 = F23 = 0; P31 = P32 = P33 = 0.
MixedControl pure_shear_control(const PiecewiseLinear& stretch, const Mat3& frame = Mat3::Identity());
/// simple shear: F = I + γ e1⊗e2 fully prescribed.
MixedControl simple_shear_control(const PiecewiseLinear& gamma, const Mat3& frame = Mat3::Identity());

/// Load frame whose first axis is `direction` and second axis lies in span(direction, in_plane).
Mat3 load_frame(const Vec3& direction, const Vec3& in_plane = Vec3::UnitY());

/// Current in-plane fiber angle in degrees (spec §7): angle of a = F a0 (load frame) measured from the
/// in-plane axis perpendicular to the load (e2) toward the load axis (e1), folded into (−90°, 90°].
double fiber_angle_deg(const Mat3& F, const Vec3& a0);

}  // namespace softhom
