#pragma once
// Material-point driver (`softhom point`): homogeneous deformation under mixed control, Newton on the
// free components of F, sub-stepping with the shared loop of step_control.hpp (halving cut-backs, growth
// after successes, wall-time budget, stop on signal; Gent locking at a converged state stops at once).
#include <functional>
#include <string>
#include <vector>

#include "softhom/materials/loading.hpp"
#include "softhom/materials/material.hpp"
#include "softhom/materials/step_control.hpp"

namespace softhom {

struct PointSolverOptions {
  double tolerance = 1e-10;      ///< on max |P_free − P_target| relative to max(|P|, G0 * 1e-6)
  int max_iterations = 25;
  int max_cutbacks = 12;         ///< a step may be halved this many times
  double max_step_seconds = 0.0;
  /// A converged state with Material::limit_margin below this is refused like a failed material call
  /// (Gent: Ī1 − 3 within 0.1 % of Jm): the run stops at the locking stretch with a clear message.
  double limit_margin = 1e-3;
};

struct PointState {
  double t = 0.0;
  Mat3 F = Mat3::Identity();   ///< load frame
  Mat3 P = Mat3::Zero();
  Mat3 sigma = Mat3::Zero();
  std::vector<double> fiber_angle_deg;  ///< one per fiber family (spec §7)
  int newton_iterations = 0;  ///< total over the sub-steps of this output step
  int substeps = 1;
};

struct PointRunResult {
  std::vector<PointState> steps;  ///< converged output steps (t = 0 row first)
  bool completed = false;
  std::string error;              ///< why the run stopped early (empty when completed)
  IntervalStatus stop = IntervalStatus::reached;  ///< how the last output interval ended
  int total_newton_iterations = 0;
  int cutbacks = 0;
  std::vector<std::string> log;   ///< cut-backs and warnings, human readable
};

/// Runs the control in the load frame. `material` is expressed in the global frame; it is rotated into
/// the load frame internally. `on_step` (optional) is called after each converged output step.
PointRunResult run_material_point(const Material& material, const MixedControl& control,
                                  const PointSolverOptions& options = {},
                                  const std::function<void(const PointState&)>& on_step = {});

}  // namespace softhom
