#pragma once
// Material cards for other FE codes from a Gent + HGO (+ QLV) material (spec §2, §4): a FEBio 4
// <Material> block (material.feb) and an Abaqus keyword fragment (material.inp), written by
// `softhom calibrate` next to material.toml (docs/material-cards.md).
//
// FEBio has every ingredient in its own terms:
//   uncoupled solid mixture { Gent (G, Jm); per fiber family: Holzapfel-Gasser-Ogden (c = 0,
//   k1/2, k2, kappa, gamma = 0, mat_axis a = a0) } with k = K, pressure_model = "NIKE3D"
//   (U = K/4 (J² − 1 − 2 ln J) = softhom's W_V exactly), wrapped in "uncoupled viscoelastic"
//   (g0 = g∞, g_i, t_i: the same deviatoric relaxation and exponential update as spec §4).
//   Its HGO fibers use the isochoric invariants (the GOH E = κ(Ī1 − 3) + (1 − 3κ)(Ī4 − 1), switched
//   off for E < 0), i.e. softhom's fiber_invariant = "isochoric"; a "full" model differs by O(σ/K).
//   γ = 0 puts both of the material's two fibers (±γ) along a0, hence k1/2.
// Abaqus has no Gent law: the matrix is a 3-term Yeoh fitted to Gent's dW/dĪ1 over the range of Ī1
// the calibration curves reach, the fibers a HOLZAPFEL material (isochoric Ī4, uncoupled), meant for
// superposed elements on the same nodes; both carry the Prony series (*VISCOELASTIC, TIME=PRONY).
// The cards' stress differences on the calibration load paths are evaluated with the material-point
// driver and written into the cards' comments.
#include <filesystem>
#include <string>
#include <vector>

#include "softhom/materials/library.hpp"
#include "softhom/studies/calibration.hpp"

namespace softhom::studies {

/// Yeoh W = Σ C_i (Ī1 − 3)^i fitted to the Gent matrix on Ī1 ∈ [3, 3 + range]: dW/dĪ1 of both
/// (which sets the whole isochoric stress 2 J⁻¹ dev(B̄) dW/dĪ1 on any path) matched in relative least
/// squares, C1 = G/2 kept (same initial shear modulus).
struct YeohFit {
  double C1 = 0.0, C2 = 0.0, C3 = 0.0;
  double I1_range = 0.0;           ///< fit range of Ī1 − 3
  double max_rel_W1_error = 0.0;   ///< max |W1_Yeoh / W1_Gent − 1| on the range (= matrix stress error)
};
YeohFit fit_yeoh_to_gent(double G, double Jm, double I1_range);

/// Largest Ī1 − 3 reached on the converged steps of a driver run.
double max_isochoric_I1_minus_3(const PointRunResult& run);

/// The material FEBio's card describes, in softhom's terms: the same law with fiber_invariant =
/// "isochoric" (FEBio's uncoupled HGO; Gent and U(J) are identical).
MaterialSpec febio_equivalent_spec(const MaterialSpec& spec);
/// The material the Abaqus card describes: Yeoh(C1..C3, K) matrix + isochoric fiber families
/// (HOLZAPFEL) with the spec's Prony series; the Yeoh volumetric (J − 1)²/D1 is replaced by W_V
/// (the difference is O((J − 1)³) K, < 1e-10 relative here).
MaterialPtr abaqus_equivalent_material(const MaterialSpec& spec, const YeohFit& yeoh);

/// Difference of a card's material from the softhom model on one curve's load path.
struct CardCurveDifference {
  std::string curve;
  bool ok = false;
  std::string error;
  std::string quantity;        ///< the curve's y (e.g. "P11")
  double max_rel = 0.0;        ///< max_steps |y_card − y_model| / max_steps |y_model|
  double max_rel_all_P = 0.0;  ///< same over all nine P components (relative to max |P|)
};
struct CardComparison {
  std::vector<CardCurveDifference> febio, abaqus;
  YeohFit yeoh;
  std::vector<std::string> warnings;  ///< a card that could not be written, and why
};
/// Runs every curve's control (fit and holdout) with the softhom model at `values` and with each
/// card's material.
CardComparison compare_cards(const CalibrationInput& input, const std::vector<double>& values);

/// FEBio 4 <Material> block (one <material id="1" name=...>) with an XML comment holding the mapping
/// and `comment` lines. Requires a Gent + HGO spec (InputError otherwise). Fiber directions are in
/// the material's local frame (element mat_axis in a structure).
std::string febio_material_block(const MaterialSpec& spec, const std::string& name = "softhom",
                                 const std::vector<std::string>& comment = {});
/// Abaqus keyword fragment: *MATERIAL NAME=<name>-MATRIX (Yeoh) and, with fibers, <name>-FIBERS
/// (HOLZAPFEL, LOCAL DIRECTIONS = families) plus an *ORIENTATION template; '**' comment lines.
std::string abaqus_material_fragment(const MaterialSpec& spec, const YeohFit& yeoh, const std::string& name = "SOFTHOM",
                                     const std::vector<std::string>& comment = {});

/// Writes DIR/material.feb and DIR/material.inp for a calibration result (differences on the
/// calibration curves in the comments). Returns the comparison. A model a card cannot express (more
/// than 6 Prony terms for FEBio, ...) leaves that card unwritten with a warning, never fails the run.
CardComparison write_material_cards(const std::filesystem::path& dir, const CalibrationInput& input,
                                    const CalibrationResult& result);

}  // namespace softhom::studies
