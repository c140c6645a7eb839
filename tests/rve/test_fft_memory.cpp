// Storage of the FFT RVE solver (rve/src/fft_storage.hpp): bytes per voxel of the default Newton–Krylov
// solve, the arrays a scene does not need left out, and the size estimate that refuses too-big grids
// following the storage as it is allocated.
#include <gtest/gtest.h>

#include <omp.h>

#include <cstdio>
#include <map>

#include "rve/rve_test_helpers.hpp"
#include "softhom/materials/laws.hpp"
#include "softhom/rve/fft_solver.hpp"

using namespace softhom;
using namespace softhom::rve;
using softhom::rve::testing::circle_image;
using softhom::rve::testing::neo_hookean;
using softhom::rve::testing::ecoflex;
using softhom::rve::testing::glass;

namespace {

std::map<std::string, std::size_t> by_array(const FftRveSolver& s) {
  std::map<std::string, std::size_t> m;
  for (const auto& [name, bytes] : s.memory_breakdown()) m[name] = bytes;
  return m;
}

PhaseImage extruded(const PhaseImage& section, int n3) {
  PhaseImage cube = section;
  cube.n[2] = n3;
  cube.size[2] = n3 * section.size[2];
  for (int k = 1; k < n3; ++k) {
    cube.fiber_fraction.insert(cube.fiber_fraction.end(), section.fiber_fraction.begin(), section.fiber_fraction.end());
    cube.normal.insert(cube.normal.end(), section.normal.begin(), section.normal.end());
  }
  return cube;
}

FftSolverOptions quick() {
  FftSolverOptions o;
  o.plan.rigor = fft::PlanRigor::estimate;
  return o;
}

}  // namespace

// Bytes per voxel of the default solve (rotated, stencil Krylov operator, compact float tangents, float
// Green table, CG without a stored z). The accounting is exact arithmetic on the array sizes, so the
// bounds are tight: each margin (< 3 B) is below one 3-component spectral vector (25.5 B per voxel on a
// 32² section, 27 B on 16³) and below any one of the cuts, and above the composite voxels' arrays'
// dependence on the image (< 1 B). 32² ecoflex/glass section (mixed (u, p) arrays, composite voxels)
// 375.2 B measured (1148 → 785 → 636.1 → 497.1 → 381.6 B before; then the phase image in 4 B per voxel
// (phase or composite index), the 3-field transform in place (its real fields inside the spectra), one
// pressure linearization instead of two with its slopes recomputed from the compact records, 108 → 24 B
// per point; then the Green table of the real symmetric K0⁻¹, 9 → 6 floats per mode, 19.1 → 12.8 B; then
// the streamed evaluation, no 9-field buffer, −72 B, and the step's residual as CG's r, −25.5 B): 277.7 B
// + the streamed passes' scratch (three slice stores per thread: 4.5 B per thread on 32², 13.5 B on 16³,
// shrinking as 1/n with the grid), ≤ 300 B with up to 4 threads; 16³ compressible neo-Hookean cell (no
// pressure arrays) 285.6 B + scratch (547.9 → 422 → 391.3 → 384.6 B before).
TEST(FftRveMemory, BytesPerVoxelOfTheDefaultSolve) {
  const PhaseImage section = circle_image(32, 0.27);
  FftRveSolver eco(section, ecoflex(), glass(), 45.0, Mat3::Identity(), quick());
  const double eco_bpv = double(eco.memory_bytes()) / double(section.voxels());
  const auto eco_arrays = by_array(eco);
  // The streamed passes' scratch: three stores of a row of 32 voxels (6 stress values each) per thread.
  const std::size_t threads = std::size_t(omp_get_max_threads());
  EXPECT_EQ(eco_arrays.at("stream_scratch"), threads * 18u * 32u * 8u);
  const double eco_scratch_bpv = double(eco_arrays.at("stream_scratch")) / double(section.voxels());
  EXPECT_LE(eco_bpv - eco_scratch_bpv, 280.0);
  if (threads <= 4) { EXPECT_LE(eco_bpv, 300.0); }
  EXPECT_EQ(eco_arrays.count("history"), 0u);  // elastic phases: no internal variables
  EXPECT_GT(eco_arrays.count("mixed_pressure"), 0u);
  EXPECT_GT(eco_arrays.count("composites"), 0u);
  // ∇ũ and P only inside the streamed passes: no 9-field buffer. The mixed arrays 24 B per point: one
  // linearization's offset (its slopes follow from the compact records' F), the pressures of the last
  // evaluation and the committed state and its increment (float), the residual correction's factor.
  EXPECT_EQ(eco_arrays.count("fft_buffers"), 0u);
  EXPECT_EQ(eco_arrays.at("mixed_pressure"), 24u * section.voxels());
  EXPECT_EQ(eco_arrays.at("compact_tangents"), 14u * 4u * section.voxels());
  EXPECT_EQ(eco_arrays.at("phase_image"), 4u * section.voxels());
  EXPECT_EQ(eco_arrays.at("fft3_buffers"), 3u * 16u * (32u / 2u + 1u) * 32u);  // in place: spectra only
  // K0(k) real symmetric: its inverse 6 floats per mode.
  EXPECT_EQ(eco_arrays.at("reference_green"), 6u * 4u * (32u / 2u + 1u) * 32u);
  // Without compact tangents the slopes are stored: + 9 floats per point.
  FftSolverOptions stored = quick();
  stored.compact_tangent = false;
  FftRveSolver eco_stored(section, ecoflex(), glass(), 45.0, Mat3::Identity(), stored);
  EXPECT_EQ(by_array(eco_stored).at("mixed_pressure"), 60u * section.voxels());
  // CG's p only (its r is the step's residual, z recomputed from r, Ap in fft3's buffer) next to ũ,
  // committed ũ, residual, step.
  EXPECT_EQ(eco_arrays.at("spectral_vectors"), 5u * 3u * 16u * (32u / 2u + 1u) * 32u);
  // The stored path (stream_evaluation off) keeps the 9 real fields per point.
  FftSolverOptions stored_fields = quick();
  stored_fields.stream_evaluation = false;
  FftRveSolver eco_fields(section, ecoflex(), glass(), 45.0, Mat3::Identity(), stored_fields);
  EXPECT_EQ(by_array(eco_fields).at("fft_buffers"), 9u * 8u * section.voxels());
  EXPECT_EQ(by_array(eco_fields).count("stream_scratch"), 0u);

  const PhaseImage cube = extruded(circle_image(16, 0.27), 16);
  FftRveSolver nh(cube, neo_hookean(1.0, 10.0), glass(), 45.0, Mat3::Identity(), quick());
  const double nh_bpv = double(nh.memory_bytes()) / double(cube.voxels());
  const auto nh_arrays = by_array(nh);
  EXPECT_EQ(nh_arrays.at("stream_scratch"), threads * 27u * 16u * 16u * 8u);  // planes of 16 × 16 voxels
  EXPECT_LE(nh_bpv - double(nh_arrays.at("stream_scratch")) / double(cube.voxels()), 288.0);
  EXPECT_EQ(nh_arrays.count("fft_buffers"), 0u);
  EXPECT_EQ(nh_arrays.count("mixed_pressure"), 0u);  // K/G = 10 < mixed_pressure_ratio
  EXPECT_EQ(nh_arrays.count("history"), 0u);
  // Compact tangents (both laws isotropic in (I1, J)): F and 5 scalars, 14 floats per point, and no
  // stored 9×9 tangent except the composite points' (in "composites"); float Green table: 6 values of
  // 4 bytes per mode (the upper triangle of the real symmetric K0⁻¹).
  EXPECT_EQ(nh_arrays.count("tangents"), 0u);
  EXPECT_EQ(nh_arrays.at("compact_tangents"), 14u * 4u * cube.voxels());
  EXPECT_EQ(nh_arrays.at("reference_green"), 6u * 4u * (16u / 2u + 1u) * 16u * 16u);

  // Hex (8 points per voxel): the 72 real fields stay, their spectra (72 · 16 · 9/16 = 648 B per voxel
  // on 16³) are gone.
  FftSolverOptions hex = quick();
  hex.discretization = fft::Discretization::hex;
  FftRveSolver nh_hex(cube, neo_hookean(1.0, 10.0), glass(), 45.0, Mat3::Identity(), hex);
  EXPECT_EQ(by_array(nh_hex).at("fft_buffers"), 72u * 8u * cube.voxels());
  EXPECT_EQ(by_array(nh_hex).at("reference_green"), 6u * 4u * (16u / 2u + 1u) * 16u * 16u);  // real K0 too
  std::printf("[ info     ] bytes/voxel (%zu threads): 32^2 ecoflex/glass %.1f, 16^3 neo-Hooke %.1f, 16^3 neo-Hooke hex %.1f\n",
              threads, eco_bpv, nh_bpv, double(nh_hex.memory_bytes()) / double(cube.voxels()));
  for (const auto& [name, bytes] : eco.memory_breakdown())
    std::printf("[ info     ]   32^2 %-18s %8.1f B/voxel\n", name.c_str(), double(bytes) / double(section.voxels()));
}

// The estimate checked before allocation is the allocated storage up to the composite voxels' arrays
// (not known before the image is scanned), for the Newton–Krylov and the fixed-point schemes and both
// Krylov operators; the memory held after a run is the one counted before it.
TEST(FftRveMemory, PlannedBytesFollowTheStorage) {
  // 16²: rows of whole batches, so the default solve is streamed; variant 5 the stored 9 fields.
  const PhaseImage section = circle_image(16, 0.27);
  for (int variant = 0; variant < 6; ++variant) {
    FftSolverOptions o = quick();
    if (variant == 4) o.compact_tangent = false;
    if (variant == 5) o.stream_evaluation = false;
    if (variant == 1) o.krylov_operator = KrylovOperator::fourier;
    if (variant == 2) o.scheme = FftScheme::moulinec_suquet;
    if (variant == 3) o.tangent_precision = TangentPrecision::double_precision;
    FftRveSolver s(section, ecoflex(), glass(), 30.0, Mat3::Identity(), o);
    const auto arrays = by_array(s);
    const std::size_t composites = arrays.count("composites") ? arrays.at("composites") : 0;
    EXPECT_EQ(s.memory_bytes(), s.planned_memory_bytes() + composites) << "variant " << variant;
  }
}

// The compact tangents change the stored operator by float rounding only: the same converged stress as
// the stored 9×9 float tangents to the Newton tolerance (both stop at a relative residual of 1e-8; the
// stress difference is bounded by a modest multiple of it, as in MixedPressureIterationSameSolution),
// on an ecoflex (K/G = 1.2e5, mixed (u, p)) + glass section with composite voxels (full tangents there).
TEST(FftRveMemory, CompactTangentsSameSolution) {
  const PhaseImage im = circle_image(12, 0.27);
  const MixedControl control = softhom::rve::testing::uniaxial_ramp(1.2, 2);
  FftSolverOptions o = quick();
  o.tolerance = 1e-8;
  FftRveSolver compact(im, ecoflex(), glass(), 45.0, control.frame, o);
  o.compact_tangent = false;
  FftRveSolver full(im, ecoflex(), glass(), 45.0, control.frame, o);
  EXPECT_GT(by_array(compact).count("compact_tangents"), 0u);
  EXPECT_EQ(by_array(full).count("compact_tangents"), 0u);
  const RveRunResult rc = compact.run(control), rf = full.run(control);
  ASSERT_TRUE(rc.completed && rf.completed) << rc.error << rf.error;
  const Mat3 Pc = rc.steps.back().P, Pf = rf.steps.back().P;
  EXPECT_LT((Pc - Pf).norm() / Pf.norm(), 1e-6);
  EXPECT_GT(Pc(0, 0), 0.0);
  std::printf("[ info     ] compact: Newton %d Krylov %d; full: Newton %d Krylov %d; P11 %.10f / %.10f\n",
              int(rc.newton_iterations), int(rc.krylov_iterations), int(rf.newton_iterations), int(rf.krylov_iterations),
              Pc(0, 0), Pf(0, 0));
}
