// Material points, residuals and the streamed evaluation of the FFT solver (fft_solver_impl.hpp).
#include "fft_solver_impl.hpp"

#include "laminate.hpp"

namespace softhom::rve {

void FftRveSolver::Impl::store_compact(int x, std::size_t p, const Mat3& F, double q) {
  CompactLinearization L;
  mat[x]->compact_linearization(F, L);
  if (pressures.mixed[x]) add_pressure_stiffness(L, q, F.determinant());
  compact->store(p, F, L);
}

MaterialStatus FftRveSolver::Impl::laminate(const Mat3& F, double f, const Vec3& n, Vec3& a, std::size_t p, double dt,
                                            Mat3& P, Mat9* A, Mat3 Px[2], Mat3 Fx[2]) const {
  detail::LaminatePoint pt;
  for (int x = 0; x < 2; ++x) {
    pt.phase[x] = mat[x].get();
    pt.state_old[x] = state_size[x] ? hist_old[x].data() + p * state_size[x] : nullptr;
    pt.state_new[x] = state_size[x] ? const_cast<double*>(hist_new[x].data()) + p * state_size[x] : nullptr;
  }
  pt.K_max = K_max;
  return detail::laminate_point(pt, F, f, n, a, dt, P, A, Px, Fx);
}

void FftRveSolver::Impl::project_semidefinite(Mat9& A) {
  const Mat9 S = 0.5 * (A + A.transpose());
  if (Eigen::LLT<Mat9>(S).info() == Eigen::Success) return;
  Eigen::SelfAdjointEigenSolver<Mat9> es(S);
  const Vec9 e = es.eigenvalues().cwiseMax(0.0);
  A = es.eigenvectors() * e.asDiagonal() * es.eigenvectors().transpose();
}

void FftRveSolver::Impl::relinearize_pressures(const Mat3& Fbar_grid) {
  if (streamed) {
    displacement_to_real(u);
#pragma omp parallel
    stencil->gradient_pass(fft3->real(0), nullptr, [&](std::size_t p0, int count, const double* grad, double*) {
      for (int l = 0; l < count; ++l) {
        const std::size_t v = p0 + std::size_t(l);
        if (comp_id[v] >= 0 || !pressures.mixed[pure_phase(v)]) continue;
        const int x = pure_phase(v);
        const Mat3 F = lane_F(Fbar_grid, grad, l);
        pressures.linearize(x, v, F, detail::volumetric_state(pressures.K[x], F), compact.get());
      }
    });
    return;
  }
  gradient_to_real(u);
  if (mean_dilatation) {
#pragma omp parallel for schedule(static)
    for (std::size_t v = 0; v < N; ++v) {
      if (comp_id[v] >= 0 || !pressures.mixed[pure_phase(v)]) continue;
      detail::MeanDilatationVoxel md;
      if (!prepare_mean_dilatation(v, Fbar_grid, md)) continue;
      Mat3 cof[detail::MeanDilatationVoxel::kMaxPoints];
      detail::cofactors(md, cof);
      pressures.linearize_voxel(pure_phase(v), v, md, cof);
    }
    return;
  }
#pragma omp parallel for schedule(static)
  for (std::size_t v = 0; v < N; ++v) {
    if (comp_id[v] >= 0) continue;
    const int x = pure_phase(v);
    if (!pressures.mixed[x]) continue;
    for (int q = 0; q < nq; ++q) {
      const Mat3 F = point_F(Fbar_grid, v, q);
      pressures.linearize(x, v * nq + q, F, detail::volumetric_state(pressures.K[x], F), compact.get());
    }
  }
}

void FftRveSolver::Impl::store_tangent(std::size_t p, const Mat9& A) {
  if (compact) {  // pure points: store_compact()
    if (comp_id[p / nq] >= 0) compact->store_full(std::size_t(comp_id[p / nq]) * nq + p % nq, A);
    return;
  }
  if (!stencil) return detail::pack_symmetric(A, &tangent[45 * p]);
  double S[45];
  detail::pack_symmetric(A, S);
  if (!tangent_f.empty()) {
    float* block = &tangent_f[45 * (p - p % 8)] + p % 8;
    for (int idx = 0; idx < 45; ++idx) block[8 * idx] = float(S[idx]);
    return;
  }
  double* block = &tangent[45 * (p - p % 8)] + p % 8;
  for (int idx = 0; idx < 45; ++idx) block[8 * idx] = S[idx];
}

MaterialStatus FftRveSolver::Impl::evaluate_point(std::size_t v, int q, const Mat3& F, double dt, Mat3& P, Mat9* A,
                                                  PassSums& local) {
  const double invN = 1.0 / double(Ntot);
  const std::size_t p = v * nq + q;
  Mat3 Px[2], Fx[2];
  MaterialStatus s;
  const double f = fraction(v);
  const double w = op.quadrature()[q].weight * invN;
  if (comp_id[v] < 0) {
    const int x = pure_phase(v);
    s = mat[x]->evaluate(F, state_size[x] ? hist_old[x].data() + p * state_size[x] : nullptr,
                         state_size[x] ? hist_new[x].data() + p * state_size[x] : nullptr, dt, P, A);
    double q_p = 0.0;
    // Mean dilatation: one pressure per voxel, pressures.correct_voxel() once its points are evaluated.
    if (s == MaterialStatus::ok && pressures.mixed[x] && !mean_dilatation) q_p = pressures.correct(x, p, F, P, A, compact.get());
    if (s == MaterialStatus::ok && A && compact) store_compact(x, p, F, q_p);
    if (s == MaterialStatus::ok && A && opt.reference == ReferenceMedium::geometric) {
      local.phase_A[x] += w * (*A);
      local.phase_A_w[x] += w;
    }
    if (s == MaterialStatus::ok) {
      local.add_point(x, w, P, F);
      local.see_margin(x, mat[x]->limit_margin(F), v0 + v);
    }
  } else {
    const std::size_t c = std::size_t(comp_id[v]) * nq + q;
    const Vec3& n = comp_normal[comp_id[v]];
    if (n.squaredNorm() == 0.0) {
      // Voigt (equal strain) rule where no interface normal can be found.
      Mat9 A1, A0;
      s = mat[1]->evaluate(F, state_size[1] ? hist_old[1].data() + p * state_size[1] : nullptr,
                           state_size[1] ? hist_new[1].data() + p * state_size[1] : nullptr, dt, Px[1],
                           A ? &A1 : nullptr);
      if (s == MaterialStatus::ok)
        s = mat[0]->evaluate(F, state_size[0] ? hist_old[0].data() + p * state_size[0] : nullptr,
                             state_size[0] ? hist_new[0].data() + p * state_size[0] : nullptr, dt, Px[0],
                             A ? &A0 : nullptr);
      P = f * Px[1] + (1.0 - f) * Px[0];
      if (A && s == MaterialStatus::ok) *A = f * A1 + (1.0 - f) * A0;
      Fx[0] = Fx[1] = F;
    } else {
      Vec3 a(lam_a_trial[3 * c], lam_a_trial[3 * c + 1], lam_a_trial[3 * c + 2]);
      s = laminate(F, f, n, a, p, dt, P, A, Px, Fx);
      if (s == MaterialStatus::ok)
        for (int i = 0; i < 3; ++i) lam_a_trial[3 * c + i] = a[i];
    }
    if (s == MaterialStatus::ok && A && opt.composite_tangent == CompositeTangent::projected) project_semidefinite(*A);
    if (s == MaterialStatus::ok)
      for (int x = 0; x < 2; ++x) {
        local.add_point(x, w * (x == 1 ? f : 1.0 - f), Px[x], Fx[x]);
        local.see_margin(x, mat[x]->limit_margin(Fx[x]), v0 + v);
      }
  }
  return s;
}

MaterialStatus FftRveSolver::Impl::evaluate_points(const Mat3& Fbar_grid, double dt, bool with_tangent) {
  const double invN = 1.0 / double(Ntot);
  int failure = 0;
  PassSums total;
#pragma omp parallel
  {
    PassSums local;
    Mat9 A_point;
    detail::MeanDilatationVoxel md;
    std::unique_ptr<detail::MeanDilatationResponse> md_out;
    if (mean_dilatation) md_out = std::make_unique<detail::MeanDilatationResponse>();
#pragma omp for schedule(static)
    for (std::size_t v = 0; v < N; ++v) {
      int seen;
#pragma omp atomic read
      seen = failure;
      if (seen) continue;
      if (mean_dilatation && !prepare_mean_dilatation(v, Fbar_grid, md)) {
#pragma omp atomic write
        failure = int(MaterialStatus::inverted);
        continue;
      }
      for (int q = 0; q < nq; ++q) {
        const std::size_t p = v * nq + q;
        double* base = fft->real(9 * q) + v;
        const Mat3 F = mean_dilatation ? md.modified(q) : point_F(Fbar_grid, v, q);
        Mat3 P;
        Mat9* A = with_tangent ? &A_point : nullptr;
        const double w = op.quadrature()[q].weight * invN;
        const MaterialStatus s = evaluate_point(v, q, F, dt, P, A, local);
        if (s != MaterialStatus::ok || !P.allFinite()) {
          const int code = s == MaterialStatus::ok ? int(MaterialStatus::not_finite) : int(s);
#pragma omp atomic write
          failure = code;
          break;
        }
        if (mean_dilatation) {  // the voxel's stresses and tangents follow from all its points (below)
          md_out->P[q] = P;
          if (A) md_out->K[q] = *A;
          ++md.evaluated;
          continue;
        }
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j) base[std::size_t(3 * i + j) * N] = P(i, j);
        local.P += w * flatten(P);
        if (A) {
          local.A += w * (*A);
          store_tangent(p, *A);
        }
      }
      if (mean_dilatation && md.evaluated == nq) finish_mean_dilatation(v, md, *md_out, with_tangent, local);
    }
#pragma omp critical
    total.add(local);
  }
  sums = total;
  if (dist) {
    // A failure on any rank fails the pass on all (the same control flow everywhere).
    failure = dist->max(failure);
    if (!failure) detail::reduce_pass_sums(sums, *dist);
  }
  return MaterialStatus(failure);
}

bool FftRveSolver::Impl::prepare_mean_dilatation(std::size_t v, const Mat3& Fbar_grid, detail::MeanDilatationVoxel& md) const {
  double w[8];
  for (int q = 0; q < nq; ++q) {
    md.F[q] = point_F(Fbar_grid, v, q);
    w[q] = op.quadrature()[q].weight;
  }
  return md.prepare(nq, w);
}

void FftRveSolver::Impl::finish_mean_dilatation(std::size_t v, const detail::MeanDilatationVoxel& md,
                                                detail::MeanDilatationResponse& out, bool with_tangent, PassSums& local) {
  Mat3 Pbar[8];
  Mat9 Abar[8];
  for (int q = 0; q < nq; ++q) {
    Pbar[q] = out.P[q];
    if (with_tangent) Abar[q] = out.K[q];
  }
  detail::mean_dilatation_response(md, Pbar, with_tangent ? Abar : nullptr, out);
  if (comp_id[v] < 0 && pressures.mixed[pure_phase(v)]) pressures.correct_voxel(pure_phase(v), v, md, out, with_tangent);
  const double invN = 1.0 / double(Ntot);
  for (int q = 0; q < nq; ++q) {
    double* base = fft->real(9 * q) + v;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) base[std::size_t(3 * i + j) * N] = out.P[q](i, j);
    local.P += md.w[q] * invN * flatten(out.P[q]);
    if (with_tangent) store_tangent(v * nq + q, out.K[q]);
  }
  if (!with_tangent) return;
  local.A += invN * out.voxel_tangent;
  md_coupling.store(v, out);
}

void FftRveSolver::Impl::gradient_to_real(const std::vector<Complex>& uh) {
  if (!stencil) {
    op.gradient(uh.data(), fft->spectrum(0), false);
    fft->backward();
    return;
  }
  const int ncol = op.columns();
  if (ncol < 3) std::fill(fft3->spectrum(2), fft3->spectrum(2) + NM, Complex(0.0));  // defined values in the unused field
  for (int q = 0; q < nq; ++q)
    for (int i = 0; i < 3; ++i) {
      op.gradient_block(uh.data() + std::size_t(i) * NM, q, fft3->spectrum(0));
      fft3->backward();
      for (int j = 0; j < ncol; ++j) copy_from_real(*fft3, j, fft->real(9 * q + 3 * i + j));
    }
}

void FftRveSolver::Impl::copy_from_real(fft::FieldTransform& t, int field, double* to) const {
  const double* from = t.real(field);
  const std::size_t n1 = std::size_t(grid.n[0]), pitch = t.real_row_pitch(), rows = N / n1;
#pragma omp parallel for schedule(static)
  for (std::size_t r = 0; r < rows; ++r)
    for (std::size_t i = 0; i < n1; ++i) to[r * n1 + i] = from[r * pitch + i];
}

void FftRveSolver::Impl::copy_to_real(const double* from, fft::FieldTransform& t, int field) const {
  double* to = t.real(field);
  const std::size_t n1 = std::size_t(grid.n[0]), pitch = t.real_row_pitch(), rows = N / n1;
#pragma omp parallel for schedule(static)
  for (std::size_t r = 0; r < rows; ++r)
    for (std::size_t i = 0; i < n1; ++i) to[r * pitch + i] = from[r * n1 + i];
}

std::pair<fft::FieldTransform*, int> FftRveSolver::Impl::vector_to_real(const std::vector<Complex>& uh) {
  if (stencil) {
    std::copy(uh.begin(), uh.begin() + std::ptrdiff_t(3 * NM), fft3->spectrum(0));
    fft3->backward();
    return {fft3.get(), 1};
  }
  for (int i = 0; i < 3; ++i) std::copy(uh.begin() + i * NM, uh.begin() + (i + 1) * NM, fft->spectrum(3 * i));
  fft->backward();
  return {fft.get(), 3};
}

void FftRveSolver::Impl::residual(const std::array<bool, 9>& free, const Vec9& P_target, KVec& r) {
  if (stencil) {
    for (int q = 0; q < nq; ++q)
      for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < op.columns(); ++j) copy_to_real(fft->real(9 * q + 3 * i + j), *fft3, j);
        fft3->forward();
        op.divergence_block(fft3->spectrum(0), q, r.u.data() + std::size_t(i) * NM, 1.0 / double(Ntot), q > 0);
      }
  } else {
    fft->forward();
    op.divergence(fft->spectrum(0), r.u.data(), 1.0 / double(Ntot));
  }
  macro_residual(free, P_target, r);
}

double FftRveSolver::Impl::evaluate_residual(const std::array<bool, 9>& free, const Vec9& P_target, KVec& r) {
  residual(free, P_target, r);
  if (!pressures.active()) return residual_norm(r, free, P_target);
  residual_norm(r, free, P_target);
  const double merit_hat = merit;
  Vec9 mean = Vec9::Zero();
  const double invN = 1.0 / double(Ntot);
#pragma omp parallel
  {
    Vec9 local = Vec9::Zero();
#pragma omp for schedule(static)
    for (std::size_t v = 0; v < N; ++v)
      for (int q = 0; q < nq; ++q) {
        const std::size_t p = v * nq + q;
        const double ratio = pressures.dP_ratio[p];
        if (ratio == 0.0) continue;  // points without the pressure iteration, or q = 0
        // The slopes at p are those of this evaluation (PressureIteration::correct() wrote them).
        const Mat3 slope = pressures.slope(pure_phase(v), p, compact.get());
        double* base = fft->real(9 * q) + v;
        for (int c = 0; c < 9; ++c) {
          const double d = ratio * slope(c / 3, c % 3);
          base[std::size_t(c) * N] += d;
          local[c] += op.quadrature()[q].weight * d;
        }
      }
#pragma omp critical
    mean += local;
  }
  if (dist) dist->sum(mean.data(), 9);
  sums.P += invN * mean;
  residual(free, P_target, r);
  const double err = residual_norm(r, free, P_target);
  true_merit = merit;
  merit = merit_hat;
  return err;
}

void FftRveSolver::Impl::displacement_to_real(const std::vector<Complex>& uh) {
  std::copy(uh.begin(), uh.begin() + std::ptrdiff_t(3 * NM), fft3->spectrum(0));
  fft3->backward();
  fill_displacement_halo();
}

double FftRveSolver::Impl::spectral_norm2(const Complex* a, const Complex* b, double b_scale) const {
  double s = 0.0;
#pragma omp parallel for reduction(+ : s) schedule(static)
  for (std::size_t k = 0; k < NM; ++k) {
    const double lap = op.laplacian(op.mode_offset() + k);
    if (lap <= 0.0) continue;
    double e = 0.0;
    for (int c = 0; c < 3; ++c) e += std::norm(b ? a[c * NM + k] - b_scale * b[c * NM + k] : a[c * NM + k]);
    s += grid.mode_weight(k) * e / lap;
  }
  return global_sum(s);
}

MaterialStatus FftRveSolver::Impl::evaluate_streamed(const Mat3& Fbar_grid, double dt, bool with_tangent,
                                                     const std::array<bool, 9>& free, const Vec9& P_target, KVec& r,
                                                     double& err) {
  constexpr int B = fft::StencilGradient::kBatch;
  const double invN = 1.0 / double(Ntot);
  displacement_to_real(u);
  ensure_stream_scratch();
  int failure = 0;
  PassSums total;
  Vec9 correction = Vec9::Zero();  // volume mean of P_full − P̂
#pragma omp parallel
  {
    PassSums local;
    Vec9 local_correction = Vec9::Zero();
    Mat9 A_point;
    stencil->streamed_pass(fft3->real(0), stream_scratch.data(), [&](std::size_t p0, int count, const double* grad, double* stress) {
      for (int l = 0; l < count; ++l) {
        const std::size_t v = p0 + std::size_t(l);  // one point per voxel
        int seen;
#pragma omp atomic read
        seen = failure;
        Mat3 P = Mat3::Zero();
        if (!seen) {
          Mat9* A = with_tangent ? &A_point : nullptr;
          const MaterialStatus st = evaluate_point(v, 0, lane_F(Fbar_grid, grad, l), dt, P, A, local);
          if (st != MaterialStatus::ok || !P.allFinite()) {
            const int code = st == MaterialStatus::ok ? int(MaterialStatus::not_finite) : int(st);
#pragma omp atomic write
            failure = code;
            P.setZero();
          } else {
            local.P += invN * flatten(P);
            if (A) {
              local.A += invN * (*A);
              store_tangent(v, *A);
            }
            const double ratio = pressures.active() ? double(pressures.dP_ratio[v]) : 0.0;
            if (ratio != 0.0) {  // P_full = P̂ + ratio · slope (evaluate_residual())
              const Mat3 d = ratio * pressures.slope(pure_phase(v), v, compact.get());
              P += d;
              local_correction += flatten(d);
            }
          }
        }
        for (int c = 0; c < 9; ++c) stress[c * B + l] = P(c / 3, c % 3);
      }
    }, true, false, slab_shift_up());
#pragma omp critical
    {
      total.add(local);
      correction += local_correction;
    }
  }
  sums = total;
  if (dist) {
    // A failure on any rank fails the pass on all (the same control flow everywhere).
    failure = dist->max(failure);
    if (!failure) {
      detail::reduce_pass_sums(sums, *dist);
      dist->sum(correction.data(), 9);
    }
  }
  if (failure) return MaterialStatus(failure);
  streamed_residual(free, P_target, correction, r, err);
  return MaterialStatus::ok;
}

void FftRveSolver::Impl::streamed_residual(const std::array<bool, 9>& free, const Vec9& P_target,
                                           const Vec9& correction, KVec& r, double& err) {
  constexpr int B = fft::StencilGradient::kBatch;
  const double invN = 1.0 / double(Ntot);
  fft3->forward();
  const Complex* s3 = fft3->spectrum(0);
  r.u.resize(3 * NM);
#pragma omp parallel for schedule(static)
  for (std::size_t a = 0; a < 3 * NM; ++a) r.u[a] = invN * s3[a];
  if (!pressures.active()) {
    macro_residual(free, P_target, r);
    err = residual_norm(r, free, P_target);
    return;
  }
  // Merit of P̂: Dᴴ P̂ = r_u − Dᴴ (P_full − P̂), the correction's divergence in fft3.
#pragma omp parallel
  stencil->streamed_pass(fft3->real(0), stream_scratch.data(), [&](std::size_t p0, int count, const double*, double* stress) {
    for (int l = 0; l < count; ++l) {
      const std::size_t v = p0 + std::size_t(l);
      const double ratio = pressures.dP_ratio[v];
      const Mat3 d = ratio != 0.0 ? Mat3(ratio * pressures.slope(pure_phase(v), v, compact.get())) : Mat3::Zero();
      for (int c = 0; c < 9; ++c) stress[c * B + l] = d(c / 3, c % 3);
    }
  }, false, false, slab_shift_up());
  fft3->forward();
  macro_residual(free, P_target, r);  // of P̂ (sums.P)
  const double merit_hat = std::sqrt(spectral_norm2(r.u.data(), fft3->spectrum(0), invN) + r.f.squaredNorm());
  sums.P += invN * correction;
  macro_residual(free, P_target, r);
  err = residual_norm(r, free, P_target);
  true_merit = merit;
  merit = merit_hat;
}

MaterialStatus FftRveSolver::Impl::evaluate_start() {
  if (!streamed) {
    gradient_to_real(u);
    return evaluate_points(to_grid(Fbar), 0.0, opt.scheme == FftScheme::newton_cg);
  }
  const std::array<bool, 9> none{};
  double err = 0.0;
  cg_p.u.resize(3 * NM);
  return evaluate_streamed(to_grid(Fbar), 0.0, true, none, Vec9::Zero(), cg_p, err);
}

MaterialStatus FftRveSolver::Impl::evaluate_iterate(double dt, bool with_tangent, const std::array<bool, 9>& free,
                                                    const Vec9& P_target, KVec& r, double& err) {
  if (streamed) return evaluate_streamed(to_grid(Fbar), dt, with_tangent, free, P_target, r, err);
  gradient_to_real(u);
  const MaterialStatus s = evaluate_points(to_grid(Fbar), dt, with_tangent);
  if (s == MaterialStatus::ok) err = evaluate_residual(free, P_target, r);
  return s;
}

double FftRveSolver::Impl::stress_scale(const std::array<bool, 9>& free, const Vec9& P_target) const {
  const Vec9 Pl = T_load * sums.P;
  double s = 1e-6 * G_min;
  for (int c = 0; c < 9; ++c) s = std::max(s, free[c] ? std::abs(P_target[c]) : std::abs(Pl[c]));
  return s;
}

double FftRveSolver::Impl::residual_norm(const KVec& r, const std::array<bool, 9>& free, const Vec9& P_target) {
  const double s = spectral_norm2(r.u.data(), nullptr, 0.0);
  merit = std::sqrt(s + r.f.squaredNorm());
  return std::max(std::sqrt(s), r.f.cwiseAbs().maxCoeff()) / stress_scale(free, P_target);
}

}  // namespace softhom::rve
