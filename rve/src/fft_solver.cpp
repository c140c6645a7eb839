// Newton–Krylov and Moulinec–Suquet FFT solvers for periodic fiber cells (see fft_solver.hpp): the
// solver's construction, its storage accounting and its public interface (its parts: fft_solver_impl.hpp).
#include "fft_solver_impl.hpp"

#include "fft_local_bulk.hpp"
#include "laminate.hpp"
#include "memory_budget.hpp"

namespace softhom::rve {

const char* to_string(FftScheme s) { return s == FftScheme::newton_cg ? "newton-cg" : "moulinec-suquet"; }
const char* to_string(ReferenceMedium r) {
  return r == ReferenceMedium::mean_tangent ? "mean-tangent" : r == ReferenceMedium::geometric ? "geometric" : "isotropic";
}
const char* to_string(KrylovOperator k) { return k == KrylovOperator::stencil ? "stencil" : "fourier"; }
const char* to_string(TangentPrecision t) { return t == TangentPrecision::single_precision ? "single" : "double"; }
const char* to_string(Preconditioner p) {
  return p == Preconditioner::jacobi_green       ? "jacobi-green"
         : p == Preconditioner::green_local_bulk ? "green-local-bulk"
         : p == Preconditioner::automatic        ? "auto"
                                                 : "green";
}
const char* to_string(VolumetricKinematics v) {
  return v == VolumetricKinematics::mean_dilatation ? "mean-dilatation" : "pointwise";
}

Mat3 grid_rotation(double fiber_angle_deg) {
  const double a = fiber_angle_deg * 3.14159265358979323846 / 180.0;
  Mat3 R;
  R.col(0) = Vec3(std::cos(a), -std::sin(a), 0.0);
  R.col(2) = Vec3(std::sin(a), std::cos(a), 0.0);
  R.col(1) = R.col(2).cross(R.col(0));
  return R;
}

FftRveSolver::Impl::Impl(const PhaseImage& image, MaterialPtr matrix, MaterialPtr fiber, double angle,
                         const Mat3& frame, const FftSolverOptions& o)
    : opt(o),
      grid{image.n, image.size},
      op(grid, o.discretization),
      dist(detail::make_slabs(grid, o.distributed, grid_text(image.n))),
      nq(op.points()),
      N(dist ? dist->local_voxels() : grid.voxels()),
      NM(dist ? dist->local_modes() : grid.modes()),
      NP(N * std::size_t(op.points())) {
  Ntot = grid.voxels();
  if (dist) {
    op.restrict_to_planes(dist->slab().begin, dist->slab().count);
    v0 = dist->voxel_offset();
  }
  set_up_phases(image, matrix, fiber, angle, frame);
  choose_formulation();
  // Refuse a grid that cannot fit before anything of its size is allocated.
  detail::refuse_if_too_big(planned_bytes(), "microstructure.grid", grid_text(grid.n));
  read_fractions(image);
  allocate_history();
  create_transforms();
  allocate_solver_storage();
}

void FftRveSolver::Impl::set_up_phases(const PhaseImage& image, const MaterialPtr& matrix, const MaterialPtr& fiber,
                                       double angle, const Mat3& frame) {
  R = grid_rotation(angle);
  T_load = detail::rotation_operator(R);
  detail::check_slab_image(image, dist.get());
  // y3 unless the image gives per-voxel directions (a slab image: the orientation sums of all slabs)
  Eigen::Matrix3d orientation = image.owned_orientation_sum();
  if (dist && image.is_slab()) dist->sum(orientation.data(), 9);
  a0_load = R * principal_fiber_axis(orientation);
  // global → load: frameᵀ; load → grid: Rᵀ.
  const Mat3 Q = R.transpose() * frame.transpose();
  mat[0] = MaterialPtr(matrix->rotated(Q));
  mat[1] = MaterialPtr(fiber->rotated(Q));
  for (int x = 0; x < 2; ++x) state_size[x] = mat[x]->state_size();
  const double G0 = mat[0]->initial_shear_modulus(), G1 = mat[1]->initial_shear_modulus();
  const double K0 = mat[0]->initial_bulk_modulus(), K1 = mat[1]->initial_bulk_modulus();
  G_min = std::min(G0, G1);
  G_max = std::max(G0, G1);
  K_max = std::max(K0, K1);
  // Moulinec–Suquet reference: arithmetic mean of the extreme Lamé moduli (the classic choice).
  mu_ref = 0.5 * (G0 + G1);
  lambda_ref = 0.5 * ((K0 - 2.0 / 3.0 * G0) + (K1 - 2.0 / 3.0 * G1));
}

void FftRveSolver::Impl::choose_formulation() {
  const double G0 = mat[0]->initial_shear_modulus(), G1 = mat[1]->initial_shear_modulus();
  const double K0 = mat[0]->initial_bulk_modulus(), K1 = mat[1]->initial_bulk_modulus();
  mean_dilatation = check_mean_dilatation(opt, op);
  if (opt.preconditioner == Preconditioner::automatic) opt.preconditioner = automatic_preconditioner(opt, op, G0, G1, K0, K1);
  local_bulk = check_local_bulk(opt, op);
  for (int x = 0; x < 2; ++x) {
    pressures.K[x] = mat[x]->volumetric_modulus();
    const double G = mat[x]->initial_shear_modulus();
    pressures.mixed[x] = opt.scheme == FftScheme::newton_cg && opt.mixed_pressure && pressures.K[x] > 0.0 &&
                         pressures.K[x] >= opt.mixed_pressure_ratio * G;
  }
}

void FftRveSolver::Impl::read_fractions(const PhaseImage& image) {
  if (image.fiber_fraction.size() != image.held_voxels())
    throw InputError("microstructure", "", "phase image has " + std::to_string(image.fiber_fraction.size()) +
                                               " values for " + std::to_string(image.held_voxels()) + " voxels");
  // Every rank checks the image it holds (whole or its slab); the first bad value of any rank is the
  // InputError on every rank. Each keeps the fractions of its planes.
  std::optional<double> bad;
  for (double f : image.fiber_fraction)
    if (!(f >= 0.0 && f <= 1.0) && !bad) bad = f;
  if (dist && image.is_slab()) bad = detail::first_bad_fraction(*dist, bad);
  if (bad) throw InputError("microstructure", format_number(*bad), "fiber fraction outside [0, 1]");
  const std::size_t first = image.is_slab() ? image.owned_offset() : v0;  // this rank's voxel v0 in the arrays
  comp_id.assign(N, kMatrixVoxel);
  double vf = 0.0;
  for (std::size_t v = 0; v < N; ++v) {
    double f = image.fiber_fraction[first + v];
    if (f < kPhaseEps) f = 0.0;
    if (f > 1.0 - kPhaseEps) f = 1.0;
    vf += f;
    if (f == 1.0) comp_id[v] = kFiberVoxel;
    if (f > 0.0 && f < 1.0) {
      comp_id[v] = int(comp_normal.size());
      comp_phi.push_back(f);
      Vec3 n = image.normal.size() == image.held_voxels() ? image.normal[first + v] : Vec3::Zero();
      if (!(n.norm() > 0.5)) n = detail::estimate_interface_normal(image, v0 + v);
      comp_normal.push_back(n.norm() > 0.0 ? Vec3(n.normalized()) : Vec3::Zero());
    }
  }
  if (dist) vf = dist->sum(vf);
  achieved_vf = vf / double(Ntot);
}

void FftRveSolver::Impl::allocate_history() {
  lam_a.assign(comp_normal.size() * nq * 3, 0.0);
  lam_a_trial = lam_a;
  for (int x = 0; x < 2; ++x)
    if (state_size[x] > 0) {
      hist_old[x].assign(NP * state_size[x], 0.0);
      for (std::size_t p = 0; p < NP; ++p) mat[x]->init_state(hist_old[x].data() + p * state_size[x]);
      hist_new[x] = hist_old[x];
    }
}

void FftRveSolver::Impl::create_transforms() {
  // Section grids: the i3 columns of ∇ũ vanish and Div does not read them, so 6 of 9 fields per point
  // are transformed (the voxel loops treat those columns as zero).
  const bool with_stencil = opt.scheme == FftScheme::newton_cg && opt.krylov_operator == KrylovOperator::stencil &&
                            fft::StencilGradient::supported(op);
  // With the stencil operator ∇ũ and P stay in real space (transformed block by block through fft3,
  // gradient_to_real() and residual()): no spectrum of the 9·nq fields. Distributed: room for the
  // stencil store's lower halo plane after the fields (see stencil_store()).
  streamed = with_stencil && streams_evaluation();
  if (streamed)
    ;  // no 9-field buffer: ∇ũ and P live only inside the streamed passes
  else if (with_stencil)
    fft = std::make_unique<fft::FieldBuffer>(9 * nq, N, dist ? 24 * dist->plane_voxels() : 0);
  else if (dist)
    fft = std::make_unique<fft::SlabFFT>(*dist, 9 * nq, opt.plan, op.columns());
  else
    fft = std::make_unique<fft::BatchedFFT>(grid, 9 * nq, opt.plan, op.columns());
  if (with_stencil) {
    stencil = std::make_unique<fft::StencilGradient>(op);
    // Its per-voxel values (≤ 24) live in fft's real buffer (9·nq per voxel), unused during a solve.
    if (!streamed && stencil->stored_values() > 9 * nq) throw std::logic_error("stencil values do not fit the FFT buffer");
    if (dist) {
      stencil->restrict_to_slab(dist->slab().count);
      fft3 = std::make_unique<fft::SlabFFT>(*dist, 3, opt.plan, 3, 1);  // + the displacement's upper halo
      if (local_bulk) bulk_fft = std::make_unique<fft::SlabFFT>(*dist, 1, opt.plan);
    } else {
      // In place (the real fields in the spectrum buffer, rows padded): −24 B per voxel.
      fft3 = std::make_unique<fft::BatchedFFT>(grid, 3, opt.plan, 3, fft3_in_place());
      if (fft3->padded_rows()) stencil->set_padded_fields(fft3->real_row_pitch(), fft3->real_stride());
      if (local_bulk) bulk_fft = std::make_unique<fft::BatchedFFT>(grid, 1, opt.plan, 3, true);
    }
  }
}

void FftRveSolver::Impl::allocate_solver_storage() {
  // Stencil operator: tangents in blocks of 8 points (structure of arrays, fft::symmetric_product_batch()),
  // zero-padded to whole blocks; Fourier operator: per point.
  // Single precision (stencil only): tangent_f instead of tangent.
  if (opt.scheme == FftScheme::newton_cg) {
    if (stencil && opt.tangent_precision == TangentPrecision::single_precision) {
      if (compact_tangents_apply())
        compact = std::make_unique<detail::CompactTangents>(NP, comp_normal.size() * std::size_t(nq));
      else
        tangent_f.assign(45 * ((NP + 7) / 8 * 8), 0.0f);
      green.use_single_precision(true);  // the preconditioner's table too (fft::ReferenceGreen)
    } else {
      tangent.assign(45 * (stencil ? (NP + 7) / 8 * 8 : NP), 0.0);
    }
  }
  // The pressure slopes are stored unless the compact records hold the F they follow from.
  pressures.allocate(NP, !compact);
  if (mean_dilatation) md_coupling.resize(N, nq);
  if (local_bulk) bulk_w.assign(N, 0.0f);
  if (streamed) ensure_stream_scratch();
  u.assign(3 * NM, 0.0);
  u_committed = u;
  if (opt.scheme == FftScheme::newton_cg) {
    // CG work vectors once, here (pcg() reuses them), so that memory_bytes() is what a run holds.
    // Stencil operator: no z (CgSpace recomputes K0⁻¹ r in the direction update) and no Ap (fft3's buffer).
    // No CG residual of its own (the step's residual is the right-hand side and becomes CG's r, see
    // pcg()) except for the Jacobi–Green CG on nodal vectors.
    cg_p.u.assign(3 * NM, 0.0);
    if (jacobi_green()) cg_r.u.assign(3 * NM, 0.0);
    if (!stencil) cg_z.u.assign(3 * NM, 0.0);
    if (!stencil) cg_Ap.u.assign(3 * NM, 0.0);
  }
}

bool FftRveSolver::Impl::check_mean_dilatation(const FftSolverOptions& o, const fft::GradientOperator& op) {
  if (o.volumetric != VolumetricKinematics::mean_dilatation) return false;
  const char* v = to_string(o.volumetric);
  if (o.discretization != fft::Discretization::hex)
    throw InputError("solver.volumetric", v, "needs discretization = \"hex\" (got \"" + std::string(fft::to_string(o.discretization)) + "\")");
  if (o.scheme != FftScheme::newton_cg) throw InputError("solver.volumetric", v, "needs scheme = \"newton-cg\"");
  if (o.krylov_operator != KrylovOperator::stencil || !fft::StencilGradient::supported(op))
    throw InputError("solver.volumetric", v, "needs krylov_operator = \"stencil\" (and a grid with n1, n2 > 1)");
  return true;
}

Preconditioner FftRveSolver::Impl::automatic_preconditioner(const FftSolverOptions& o, const fft::GradientOperator& op,
                                                            double G0, double G1, double K0, double K1) {
  const bool applies = o.discretization == fft::Discretization::rotated && o.scheme == FftScheme::newton_cg &&
                       o.krylov_operator == KrylovOperator::stencil && fft::StencilGradient::supported(op);
  if (!applies || !(std::min(G0, G1) > 0.0) || !(std::min(K0, K1) > 0.0)) return Preconditioner::green;
  const double bulk_spread = std::max(K0, K1) / std::min(K0, K1), shear_spread = std::max(G0, G1) / std::min(G0, G1);
  return bulk_spread >= kLocalBulkSpreadRatio * shear_spread ? Preconditioner::green_local_bulk : Preconditioner::green;
}

bool FftRveSolver::Impl::check_local_bulk(const FftSolverOptions& o, const fft::GradientOperator& op) {
  if (o.preconditioner != Preconditioner::green_local_bulk) return false;
  const char* v = to_string(o.preconditioner);
  if (o.discretization != fft::Discretization::rotated)
    throw InputError("solver.preconditioner", v, "needs discretization = \"rotated\" (one point per voxel; got \"" +
                                                     std::string(fft::to_string(o.discretization)) + "\")");
  if (o.scheme != FftScheme::newton_cg) throw InputError("solver.preconditioner", v, "needs scheme = \"newton-cg\"");
  if (o.krylov_operator != KrylovOperator::stencil || !fft::StencilGradient::supported(op))
    throw InputError("solver.preconditioner", v, "needs krylov_operator = \"stencil\" (and a grid with n1, n2 > 1)");
  return true;
}

bool FftRveSolver::Impl::streams_evaluation() const {
  return opt.stream_evaluation && nq == 1 && !mean_dilatation &&
         opt.preconditioner != Preconditioner::jacobi_green && state_size[0] == 0 && state_size[1] == 0 &&
         fft::StencilGradient::streams(op);
}

detail::StorageSizes FftRveSolver::Impl::storage_sizes() const {
  detail::StorageSizes s;
  s.voxels = N;
  s.modes = NM;
  s.points = NP;
  s.fft_fields = fft ? std::size_t(fft->fields()) : 0;
  s.fft_spectra = fft && fft->transformed_fields() ? s.fft_fields : 0;
  s.stream_scratch_values = stream_scratch.size();
  s.fft3_fields = fft3 ? std::size_t(fft3->fields()) : 0;
  s.fft3_in_place = fft3 && fft3->padded_rows();
  const bool single = !tangent_f.empty() || compact;
  s.tangent_values = tangent_f.empty() ? tangent.size() : tangent_f.size();
  s.tangent_value_bytes = single ? sizeof(float) : sizeof(double);
  s.compact_values = compact ? compact->record_values() : 0;
  s.composite_tangent_values = compact ? compact->full_values() : 0;
  s.green_values = fft::ReferenceGreen::kValuesPerMode * NM;  // tabulated at the first solve
  s.green_value_bytes = single ? sizeof(float) : sizeof(double);
  s.jacobi_values = jacobi_green() ? 3 * N : 0;  // set with the reference medium
  s.local_bulk_voxels = bulk_w.size();
  s.local_bulk_in_place = bulk_fft && bulk_fft->padded_rows();
  s.history_values = hist_old[0].size() + hist_old[1].size();
  s.laminate_values = lam_a.size();
  s.composite_voxels = comp_normal.size();
  s.mixed_points = pressures.p_trial.size();
  s.mixed_slope_points = pressures.lin_c.size() / 9;
  s.mean_dilatation_values = md_coupling.memory_bytes() / sizeof(double);
  s.spectral_vectors = spectral_vectors();
  return s;
}

detail::StorageSizes FftRveSolver::Impl::planned_sizes() const {
  const bool newton = opt.scheme == FftScheme::newton_cg;
  const bool with_stencil = newton && opt.krylov_operator == KrylovOperator::stencil && fft::StencilGradient::supported(op);
  detail::StorageSizes s;
  s.voxels = N;
  s.modes = NM;
  s.points = NP;
  const bool streams = with_stencil && streams_evaluation();
  s.fft_fields = streams ? 0 : std::size_t(9 * nq);
  s.fft_spectra = with_stencil ? 0 : s.fft_fields;
  s.stream_scratch_values = streams ? fft::StencilGradient::stream_scratch_values(grid, omp_get_max_threads(), bool(dist)) : 0;
  s.fft3_fields = with_stencil ? 3 : 0;
  s.fft3_in_place = with_stencil && fft3_in_place();
  const bool single = with_stencil && opt.tangent_precision == TangentPrecision::single_precision;
  s.tangent_values = newton ? 45 * (with_stencil ? (NP + 7) / 8 * 8 : NP) : 0;
  if (single && compact_tangents_apply()) {  // composite points' full tangents: counted as none
    s.tangent_values = 0;
    s.compact_values = std::size_t(kCompactValues) * ((NP + 7) / 8 * 8);
  }
  s.tangent_value_bytes = single ? sizeof(float) : sizeof(double);
  s.green_values = fft::ReferenceGreen::kValuesPerMode * NM;
  s.green_value_bytes = single ? sizeof(float) : sizeof(double);
  s.jacobi_values = with_stencil && opt.preconditioner == Preconditioner::jacobi_green ? 3 * N : 0;
  s.local_bulk_voxels = local_bulk ? N : 0;
  s.local_bulk_in_place = local_bulk && !dist;
  s.history_values = NP * std::size_t(state_size[0] + state_size[1]);
  s.mixed_points = pressures.active() ? NP : 0;
  s.mixed_slope_points = pressures.active() && !(single && compact_tangents_apply()) ? NP : 0;
  s.mean_dilatation_values = opt.volumetric == VolumetricKinematics::mean_dilatation ? 18 * NP + N : 0;
  s.spectral_vectors = spectral_vectors(newton, with_stencil, with_stencil && opt.preconditioner == Preconditioner::jacobi_green);
  return s;
}

std::size_t FftRveSolver::Impl::planned_bytes() const {
  if (double(N) * 1e4 * double(nq) >= double(std::numeric_limits<std::size_t>::max()))
    return std::numeric_limits<std::size_t>::max();
  return detail::storage_total(detail::storage_list(planned_sizes()));
}

bool FftRveSolver::Impl::compact_tangents_apply() const {
  return opt.compact_tangent && opt.preconditioner != Preconditioner::jacobi_green &&
         opt.volumetric != VolumetricKinematics::mean_dilatation &&
         mat[0]->has_compact_linearization() && mat[1]->has_compact_linearization();
}

FftRveSolver::FftRveSolver(const PhaseImage& image, MaterialPtr matrix, MaterialPtr fiber, double fiber_angle_deg,
                           const Mat3& load_frame, const FftSolverOptions& options)
    : impl_(std::make_unique<Impl>(image, std::move(matrix), std::move(fiber), fiber_angle_deg, load_frame, options)) {}
FftRveSolver::~FftRveSolver() = default;

const fft::Grid& FftRveSolver::grid() const { return impl_->grid; }
int FftRveSolver::quadrature_points() const { return impl_->nq; }
Preconditioner FftRveSolver::preconditioner() const { return impl_->opt.preconditioner; }

std::string FftRveSolver::fft_description() const {
  // With the stencil operator every transform is fft3's (3 fields); fft holds real fields only.
  return impl_->stencil ? impl_->fft3->describe() : impl_->fft->describe();
}
double FftRveSolver::achieved_volume_fraction() const { return impl_->achieved_vf; }
double FftRveSolver::planning_seconds() const {
  return (impl_->fft ? impl_->fft->planning_seconds() : 0.0) + (impl_->fft3 ? impl_->fft3->planning_seconds() : 0.0);
}
std::vector<double> FftRveSolver::displacement() { return impl_->node_displacement(); }
const fft::SlabDecomposition* FftRveSolver::slabs() const { return impl_->dist.get(); }
std::size_t FftRveSolver::memory_bytes() const {
  return detail::storage_total(detail::storage_list(impl_->storage_sizes()));
}
std::vector<std::pair<std::string, std::size_t>> FftRveSolver::memory_breakdown() const {
  return detail::storage_list(impl_->storage_sizes());
}
std::size_t FftRveSolver::planned_memory_bytes() const { return impl_->planned_bytes(); }

FftRveState FftRveSolver::state() const {
  const Impl& m = *impl_;
  FftRveState s;
  s.F = m.Fbar_committed;
  s.u = m.u_committed;
  s.history_matrix = m.hist_old[0];
  s.history_fiber = m.hist_old[1];
  s.laminate = m.lam_a;
  s.du_last.assign(m.du_last.begin(), m.du_last.end());
  s.dF_last = m.dF_last;
  s.dt_last = m.dt_last;
  return s;
}

void FftRveSolver::set_state(const FftRveState& s) {
  Impl& m = *impl_;
  auto check = [](const char* what, std::size_t got, std::size_t want) {
    if (got != want)
      throw InputError("state", std::string(what) + " of " + std::to_string(got) + " values",
                       "this solver needs " + std::to_string(want) + " (a state of another grid or phases)");
  };
  check("u", s.u.size(), m.u.size());
  check("history_matrix", s.history_matrix.size(), m.hist_old[0].size());
  check("history_fiber", s.history_fiber.size(), m.hist_old[1].size());
  check("laminate", s.laminate.size(), m.lam_a.size());
  if (!s.du_last.empty()) check("du_last", s.du_last.size(), m.u.size());
  if (!s.F.allFinite() || !(s.F.determinant() > 0.0)) throw InputError("state.F", "", "not a deformation gradient (det F <= 0)");
  m.Fbar = m.Fbar_committed = s.F;
  m.u = m.u_committed = s.u;
  m.hist_old[0] = m.hist_new[0] = s.history_matrix;
  m.hist_old[1] = m.hist_new[1] = s.history_fiber;
  m.lam_a = m.lam_a_trial = s.laminate;
  m.du_last.assign(s.du_last.begin(), s.du_last.end());
  m.dF_last = s.dF_last;
  m.dt_last = s.dt_last;
}

FftRveSolver::MixedPressures FftRveSolver::mixed_pressures() const {
  const StateView v = state_view();
  return {{v.pressure.begin(), v.pressure.end()}, {v.pressure_increment.begin(), v.pressure_increment.end()}};
}

FftRveSolver::StateView FftRveSolver::state_view() const {
  const Impl& m = *impl_;
  StateView v;
  v.F = m.Fbar_committed;
  v.dF_last = m.dF_last;
  v.dt_last = m.dt_last;
  v.u = m.u_committed;
  v.du_last = m.du_last;
  v.history_matrix = m.hist_old[0];
  v.history_fiber = m.hist_old[1];
  v.laminate = m.lam_a;
  if (m.pressures.active()) {
    v.pressure = m.pressures.p_committed;
    v.pressure_increment = m.pressures.dp_last;
  }
  return v;
}

void FftRveSolver::set_mixed_pressures(MixedPressures p) {
  Impl& m = *impl_;
  const std::size_t want = m.pressures.active() ? m.pressures.p_committed.size() : 0;
  if (p.committed.empty() && p.increment.empty()) {
    // None saved (a state written without a mixed phase's pressures, e.g. before its kinematics had
    // one): the next run derives them at its start, as after a warm start.
    m.pressures.pending.reset();
    return;
  }
  if (p.committed.size() != want || p.increment.size() != want)
    throw InputError("state", "pressures of " + std::to_string(p.committed.size()) + " and " +
                                  std::to_string(p.increment.size()) + " points",
                     "this solver's mixed iteration has " + std::to_string(want));
  m.pressures.pending = std::move(p);
}

RveRunResult FftRveSolver::run(const MixedControl& control,
                               const std::function<void(const RveStep&, const RveFields*)>& on_step,
                               const std::function<bool(double)>& want_fields, double t_start) {
  control.validate();
  Impl& m = *impl_;
  const auto run_start = Impl::Clock::now();
  RveRunResult result;
  // The start state (t = 0: undeformed), evaluated so that phase sums and the reference are defined.
  m.pressures.linearized = false;
  if (m.evaluate_start() != MaterialStatus::ok)
    throw ConvergenceError(t_start == 0.0 ? "material call failed at F = I"
                                          : "material call failed at the start state (t = " + format_number(t_start) + ")");
  m.pressures.commit(false);
  if (m.pressures.pending) {
    // A continued run: the pressures the saved run carried, and the laminate vectors as committed (the
    // evaluation above iterated them once more from the committed ones).
    m.pressures.p_committed = std::move(m.pressures.pending->committed);
    m.pressures.dp_last = std::move(m.pressures.pending->increment);
    m.pressures.pending.reset();
    m.restore();
  }
  const double angle0 = fiber_angle_deg(Mat3::Identity(), m.a0_load);
  struct Engine {
    Impl& m;
    const MixedControl& control;
    double angle0;
    const std::function<void(const RveStep&, const RveFields*)>& on_step;
    const std::function<bool(double)>& want_fields;
    detail::SubstepOutcome step(double t_new, double dt) { return m.step(control, t_new, dt); }
    void commit(double dt) { m.commit(dt); }
    void restore() { m.restore(); }
    RveStep record(double t) const { return m.record(t, angle0); }
    void emit(const RveStep& s, double) {
      if (!on_step) return;
      if (want_fields && want_fields(s.t)) {
        const RveFields f = m.fields();
        on_step(s, &f);
      } else {
        on_step(s, nullptr);
      }
    }
  } engine{m, control, angle0, on_step, want_fields};
  m.krylov_seconds = 0.0;
  StepControlOptions steps;
  steps.max_cutbacks = m.opt.max_cutbacks;
  // Distributed: no wall-time budget (each rank's clock would decide the cut-backs on its own).
  steps.max_step_seconds = m.dist ? 0.0 : m.opt.max_step_seconds;
  detail::run_output_steps(control, steps, engine, result, run_start, t_start);
  result.krylov_seconds = m.krylov_seconds;
  return result;
}

}  // namespace softhom::rve
