// The mixed (u, p) Newton iteration of the FFT solver's nearly incompressible phases: one pressure per
// material point (or per voxel with mean-dilatation kinematics), carried between Newton iterations
// linearized in the volume ratio, and the volumetric kinematics it is built on. The solver's passes
// over the grid call it per point; it owns the per-point arrays and nothing of the grid.
#pragma once

#include <optional>
#include <vector>

#include "softhom/materials/tensor.hpp"
#include "softhom/materials/volumetric.hpp"
#include "softhom/rve/fft_solver.hpp"
#include "compact_tangents.hpp"
#include "fft_mean_dilatation.hpp"

namespace softhom::rve::detail {

/// J, cof F, W_V′(J) and W_V″(J) of the volumetric energy (softhom/materials/volumetric.hpp) at F.
struct VolumetricState {
  double J, dU, ddU;
  Mat3 cof;
};
inline VolumetricState volumetric_state(double K, const Mat3& F) {
  VolumetricState s;
  s.J = F.determinant();
  s.cof = s.J * F.inverse().transpose();
  s.dU = volumetric_dU(K, s.J);
  s.ddU = volumetric_d2U(K, s.J);
  return s;
}
inline void cofactors(const MeanDilatationVoxel& md, Mat3* cof) {
  for (int q = 0; q < md.nq; ++q) cof[q] = md.J[q] * md.F[q].inverse().transpose();
}

/// The pressures of the mixed iteration at a phase x whose bulk modulus is far above its shear modulus
/// (FftSolverOptions::mixed_pressure). The law's volumetric stress W_V′(J) cof F is replaced by p cof F,
/// with p the pressure of the last accepted iterate F_k advanced by the linearized constraint:
///   p(F) = W_V′(J_k) + W_V″(J_k) cof F_k : (F − F_k)  (stored as p = s + c:F).
/// Condensing δp of the mixed Newton system gives the tangent A + (p − W_V′(J)) ∂cof/∂F (symmetric) and
/// the right-hand side −Div P_full, P_full the unmodified stress; the merit of the line search is Div P̂
/// with the corrected stress P̂. A finite rotation θ then no longer produces a K θ² pressure spike that
/// stalls the line search (K/G = 1.2e5 for ecoflex). At convergence p = W_V′(J), P̂ = P_full.
struct PressureIteration {
  bool mixed[2] = {false, false};  // per phase (0 matrix, 1 fiber)
  double K[2] = {0.0, 0.0};        // the phases' volumetric moduli (Material::volumetric_modulus())
  bool linearized = false;         // evaluate with p from the last linearization
  double predictor_ratio = -1.0;   // ≥ 0: the extrapolated predictor, p = p_committed + ratio · dp_last
  // Per point: the pressure of the last evaluation, and the committed one with its last increment,
  // which only place the extrapolated predictor (float). The evaluation's pressure is read only to
  // commit it (in float) and to diagnose a failure; its deviation q = p − W_V′(J) in the tangent is
  // passed on in double (the solver's compact record), so float loses nothing the iteration uses.
  std::vector<float> p_trial, p_committed, dp_last;
  std::optional<FftRveSolver::MixedPressures> pending;  // FftRveSolver::set_mixed_pressures(): the next run's start
  // One linearization per point, p(F) = s + c:F with c = W_V″(J_k) cof F_k (slope()) and s (double)
  // taken with that c, so that p(F_k) = W_V′(J_k) to double round-off and only the slope is perturbed
  // (≈ 6e-8 relative). correct() reads it at point p and overwrites it there with the linearization at
  // the evaluated F, so it holds that of the last evaluation: of the last accepted iterate once the line
  // search has accepted its trial (the accepted trial is the last one evaluated); the solver puts back
  // the accepted one (linearize()) before a trial follows a rejected one or a material failure that
  // stopped a pass half way. The slopes c: from the F of the compact tangent record (float F, written at
  // every evaluation: 36 B per point less), else stored (lin_c, 9 floats).
  std::vector<float> lin_c;
  std::vector<double> lin_s;
  // Per point: P_full − P̂ = −(p − W_V′(J)) cof F, a correction of the residual, is parallel to the slope
  // c of the same evaluation: stored as the factor (1 float instead of 9).
  std::vector<float> dP_ratio;

  bool active() const { return mixed[0] || mixed[1]; }

  /// The per-point arrays for `points` points; the slopes unless compact records hold the F they follow from.
  void allocate(std::size_t points, bool store_slopes) {
    if (!active()) return;
    lin_s.assign(points, 0.0);
    p_trial.assign(points, 0.0f);
    p_committed.assign(points, 0.0f);
    dp_last.assign(points, 0.0f);
    dP_ratio.assign(points, 0.0f);
    if (store_slopes) lin_c.assign(9 * points, 0.0f);
  }

  /// The slope c of the linearization held at pure point p of mixed phase x (that of the last
  /// evaluation at p, see lin_s): stored (lin_c), or W_V″(J) cof F recomputed from the float F of the
  /// compact record, which is what linearize() took it from.
  Mat3 slope(int x, std::size_t p, const CompactTangents* compact) const {
    Mat3 c;
    if (compact) {
      const VolumetricState vs = volumetric_state(K[x], compact->F(p));
      c = vs.ddU * vs.cof;
    } else {
      const float* l = &lin_c[9 * p];
      for (int k = 0; k < 9; ++k) c(k / 3, k % 3) = double(l[k]);
    }
    return c;
  }

  /// The linearization p(F') = s + c:F' at F (volumetric state vs) into point p: c rounded to float (the
  /// stored slope, or the compact record's F it is recomputed from), s with that c, so that
  /// p(F) = W_V′(J) to double round-off.
  void linearize(int x, std::size_t p, const Mat3& F, const VolumetricState& vs, CompactTangents* compact) {
    Mat3 c;
    if (compact) {
      compact->store_F(p, F);  // the solver's compact record writes it again with the tangent
      c = slope(x, p, compact);
    } else {
      float* l = &lin_c[9 * p];
      for (int k = 0; k < 9; ++k) {
        l[k] = float(vs.ddU * vs.cof(k / 3, k % 3));
        c(k / 3, k % 3) = double(l[k]);
      }
    }
    double s0 = vs.dU;
    for (int k = 0; k < 9; ++k) s0 -= c(k / 3, k % 3) * F(k / 3, k % 3);
    lin_s[p] = s0;
  }

  /// The mixed iteration at pure point p of mixed phase x at F: P (the law's stress) becomes P̂ and the
  /// tangent *A gains the geometric term; the point's linearization moves to F. Returns q = p − W_V′(J).
  double correct(int x, std::size_t p, const Mat3& F, Mat3& P, Mat9* A, CompactTangents* compact) {
    const VolumetricState vs = volumetric_state(K[x], F);
    double pr = vs.dU;
    if (predictor_ratio >= 0.0) {
      // Extrapolated predictor: the pressure is extrapolated itself. A linearly extrapolated F leaves
      // the curved J = 1 manifold by O(ΔF²), which W_V′(J) or any linearization turns into K ΔF²
      // (tens of MPa against a matrix G of 0.017 MPa); the pressure history is smooth instead.
      pr = double(p_committed[p]) + predictor_ratio * double(dp_last[p]);
    } else if (linearized) {
      const Mat3 c = slope(x, p, compact);  // of the last accepted iterate (read before it is overwritten)
      pr = lin_s[p];
      for (int k = 0; k < 9; ++k) pr += c(k / 3, k % 3) * F(k / 3, k % 3);
    }
    const double q = pr - vs.dU;
    p_trial[p] = float(pr);
    linearize(x, p, F, vs, compact);
    dP_ratio[p] = float(-q / vs.ddU);
    if (q == 0.0) return q;
    P += q * vs.cof;
    if (A) add_cofactor_derivative(q / vs.J, vs.cof, *A);
    return q;
  }

  /// The linearization of voxel v's pressure at its current F_q (mean dilatation, see correct_voxel()):
  /// the slopes rounded to float, s with those slopes, so that p(F_k) = W_V′(J̄_k) to double round-off.
  /// The slopes are always stored (lin_c): compact tangent records are off with mean dilatation.
  void linearize_voxel(int x, std::size_t v, const MeanDilatationVoxel& md, const Mat3* cof) {
    const std::size_t p0 = v * std::size_t(md.nq);
    const double ddU = volumetric_d2U(K[x], md.J_mean);
    double s0 = volumetric_dU(K[x], md.J_mean);
    for (int q = 0; q < md.nq; ++q) {
      float* l = &lin_c[9 * (p0 + std::size_t(q))];
      for (int k = 0; k < 9; ++k) {
        l[k] = float(ddU * cof[q](k / 3, k % 3));
        s0 -= md.w[q] * double(l[k]) * md.F[q](k / 3, k % 3);
      }
    }
    lin_s[p0] = s0;
  }

  /// The mixed iteration of a mean-dilatation voxel v of mixed phase x: its volumetric energy is
  /// W_V(J̄) (fft_mean_dilatation.hpp), so it carries one pressure p, linearized as at a pure point but
  /// in J̄ = Σ_q w_q J_q:
  ///   p(F) = W_V′(J̄_k) + W_V″(J̄_k) Σ_q w_q cof F_q,k : (F_q − F_q,k),
  /// held per point as the slope c_q = W_V″(J̄_k) cof F_q,k (lin_c) and per voxel as s (lin_s at the
  /// voxel's first point). With q = p − W_V′(J̄), the stress of point q gains q cof F_q (∂J̄/∂F_q = w_q
  /// cof F_q) and its tangent K_q the geometric term q ∂cof F_q/∂F_q (∂²J̄ is block-diagonal in the
  /// points): the voxel's bulk stiffness W_V″ ∂J̄ ⊗ ∂J̄ stays, the pressure W_V′(J̄) ∂²J̄ of a spike in J̄
  /// is replaced by the linearized one. dP_ratio = −q / W_V″ at every point takes P̂ back to the true
  /// stress in the residual.
  void correct_voxel(int x, std::size_t v, const MeanDilatationVoxel& md, MeanDilatationResponse& out, bool with_tangent) {
    const std::size_t p0 = v * std::size_t(md.nq);
    const double dU = volumetric_dU(K[x], md.J_mean), ddU = volumetric_d2U(K[x], md.J_mean);
    double pr = dU;
    if (predictor_ratio >= 0.0) {
      pr = double(p_committed[p0]) + predictor_ratio * double(dp_last[p0]);
    } else if (linearized) {
      pr = lin_s[p0];
      for (int q = 0; q < md.nq; ++q) pr += md.w[q] * ddot(slope(x, p0 + std::size_t(q), nullptr), md.F[q]);
    }
    const double qv = pr - dU;
    Mat3 cof[MeanDilatationVoxel::kMaxPoints];
    cofactors(md, cof);
    linearize_voxel(x, v, md, cof);
    for (int q = 0; q < md.nq; ++q) {
      p_trial[p0 + std::size_t(q)] = float(pr);
      dP_ratio[p0 + std::size_t(q)] = float(-qv / ddU);
      if (qv == 0.0) continue;
      out.P[q] += qv * cof[q];
      if (!with_tangent) continue;
      Mat9 G = Mat9::Zero();
      add_cofactor_derivative(qv / md.J[q], cof[q], G);
      out.K[q] += G;
      out.voxel_tangent += md.w[q] * G;
    }
  }

  /// The evaluated pressures become the committed ones; their increment places the next step's
  /// extrapolated predictor (zero when `track_increment` is false: a start state).
  void commit(bool track_increment) {
    if (!active()) return;
    for (std::size_t p = 0; p < p_trial.size(); ++p) {
      dp_last[p] = track_increment ? float(double(p_trial[p]) - double(p_committed[p])) : 0.0f;
      p_committed[p] = p_trial[p];
    }
  }
};

}  // namespace softhom::rve::detail
