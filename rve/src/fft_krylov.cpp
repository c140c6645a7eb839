// The FFT solver's Newton operator, preconditioners and Krylov solves (fft_solver_impl.hpp).
#include "fft_solver_impl.hpp"

#include "fft_local_bulk.hpp"
#include "fft_preconditioner.hpp"

namespace softhom::rve {

/// The Krylov space of the Newton system for krylov::pcg: half spectra of ũ with mode weights and
/// the free macro components; the direction update is fused with the operator and the solution
/// update with the preconditioner and ⟨r, z⟩ (one pass each over the spectra).
struct FftRveSolver::Impl::CgSpace {
  Impl& m;
  const std::array<bool, 9>& free;
  const Eigen::MatrixXd& Minv;
  const std::vector<int>& free_idx;
  double shift;
  const KVec* r_live = nullptr;  // CG's r, when z.u is not stored (stencil operator)
  void start(const KVec& b, KVec& x, KVec& r) {
    r_live = &r;
    r.u = b.u;
    r.f = b.f;
    x.u.assign(3 * m.NM, 0.0);
    x.f.setZero();
  }
  double precondition_dot(const KVec& r, KVec& z) {
    precondition_macro(r.f, Minv, free_idx, z.f);
    const double bulk = m.local_bulk_in(shift) ? m.local_bulk_prepare(r.u.data()) : 0.0;
    return m.global_sum(m.green.apply_dot(r.u.data(), z.u.empty() ? nullptr : z.u.data())) + bulk + r.f.dot(z.f);
  }
  double direction(const KVec& z, double beta, KVec& p, KVec& Ap) {
    return m.apply_direction(z, beta, p, free, Ap, shift, z.u.empty() ? r_live : nullptr);
  }
  double update(double alpha, const KVec& p, const KVec& Ap, KVec& x, KVec& r, KVec& z) {
    double rz_new = m.stencil ? m.green.cg_update(alpha, p.u.data(), m.fft3->spectrum(0), x.u.data(), r.u.data(),
                                                  z.u.empty() ? nullptr : z.u.data(), 1.0, 1.0 / double(m.Ntot))
                              : m.green.cg_update(alpha, p.u.data(), Ap.u.data(), x.u.data(), r.u.data(), z.u.data());
    rz_new = m.global_sum(rz_new);
    if (m.local_bulk_in(shift)) rz_new += m.local_bulk_prepare(r.u.data());
    x.f += alpha * p.f;
    r.f -= alpha * Ap.f;
    precondition_macro(r.f, Minv, free_idx, z.f);
    return rz_new + r.f.dot(z.f);
  }
};

/// The same space for krylov::pminres (unfused operations, shift-free operator and preconditioner).
struct FftRveSolver::Impl::MinresSpace {
  Impl& m;
  const std::array<bool, 9>& free;
  const Eigen::MatrixXd& Minv;
  const std::vector<int>& free_idx;
  KVec zero_like(const KVec& b) const { return KVec{std::vector<Complex>(b.u.size(), 0.0), Vec9::Zero()}; }
  void precondition(const KVec& r, KVec& z) { m.precondition(r, Minv, free_idx, z); }
  void apply(const KVec& x, KVec& y) { m.apply(x, free, y); }
  double dot(const KVec& a, const KVec& b) const { return m.dot(a, b); }
  void axpby(double alpha, const KVec& x, double beta, KVec& y) const { Impl::axpby(alpha, x, beta, y); }
  void divide(KVec& x, double s) const {
    for (auto& e : x.u) e /= s;
    x.f /= s;
  }
  void combine(const KVec& z, double a3, const KVec& w_old, double a2, const KVec& w, double a1, KVec& w_new, double c,
               KVec& x) const {
    const std::size_t nu = z.u.size();
#pragma omp parallel for schedule(static)
    for (std::size_t i = 0; i < nu; ++i) {
      w_new.u[i] = (z.u[i] - a3 * w_old.u[i] - a2 * w.u[i]) / a1;
      x.u[i] += c * w_new.u[i];
    }
    w_new.f = (z.f - a3 * w_old.f - a2 * w.f) / a1;
    x.f += c * w_new.f;
  }
};

void FftRveSolver::Impl::axpy(double alpha, const KVec& x, KVec& y) {
  const std::size_t n = x.u.size();
#pragma omp parallel for schedule(static)
  for (std::size_t i = 0; i < n; ++i) y.u[i] += alpha * x.u[i];
  y.f += alpha * x.f;
}

Vec9 FftRveSolver::Impl::tangent_product(const Vec9& dFbar, double shift) {
  const Mat9 S = shift * C_shift;  // Levenberg–Marquardt shift (see pcg)
  const int ncol = op.columns();
  Vec9 mean = Vec9::Zero();
  double wq[8];
  for (int q = 0; q < nq; ++q) wq[q] = op.quadrature()[q].weight;
  const double* T = tangent.data();
#pragma omp parallel
  {
    double local[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
#pragma omp for schedule(static)
    for (std::size_t v = 0; v < N; ++v)
      for (int q = 0; q < nq; ++q) {
        double* base = fft->real(9 * q) + v;
        double dF[9], dP[9];
        for (int c = 0; c < 9; ++c) dF[c] = dFbar[c] + (c % 3 < ncol ? base[std::size_t(c) * N] : 0.0);
        detail::symmetric_product(T + 45 * (v * nq + q), dF, dP);
        if (shift != 0.0) Eigen::Map<Vec9>(dP) += S * Eigen::Map<const Vec9>(dF);
        for (int c = 0; c < 9; ++c) {
          if (c % 3 < ncol) base[std::size_t(c) * N] = dP[c];
          local[c] += wq[q] * dP[c];
        }
      }
#pragma omp critical
    for (int c = 0; c < 9; ++c) mean[c] += local[c];
  }
  if (dist) dist->sum(mean.data(), 9);
  return mean / double(Ntot);
}

void FftRveSolver::Impl::tangent_product_batch(std::size_t p0, int count, const double* dF, double* dP) const {
  if (compact)
    compact->product(p0, count, dF, dP, [&](int l) {
      const std::size_t p = p0 + std::size_t(l);
      const int c = comp_id[p / nq];
      return c < 0 ? -1L : long(c) * nq + long(p % nq);
    });
  else if (!tangent_f.empty())
    fft::symmetric_product_batch(tangent_f.data() + 45 * p0, dF, dP);
  else
    fft::symmetric_product_batch(tangent.data() + 45 * p0, dF, dP);  // block p0/8 starts at 360·p0/8
}

Vec9 FftRveSolver::Impl::stencil_tangent_product(const Vec9& dFbar, double shift, double* dot) {
  const Mat9 S = shift * C_shift;
  Vec9 mean = Vec9::Zero();
  double wq[8];
  for (int q = 0; q < nq; ++q) wq[q] = op.quadrature()[q].weight;
  if (streamed) ensure_stream_scratch();
  double dot_sum = 0.0;
#pragma omp parallel reduction(+ : dot_sum)
  {
    double local[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
    constexpr int B = fft::StencilGradient::kBatch;
    static_assert(B == 8, "fft::symmetric_product_batch() and the tangent blocks hold 8 points");
    auto body = [&](std::size_t p0, int count, const double* grad, double* dP) {
      alignas(64) double dF[9 * B];
      for (int c = 0; c < 9; ++c)
        for (int l = 0; l < B; ++l) dF[c * B + l] = dFbar[c] + grad[c * B + l];
      tangent_product_batch(p0, count, dF, dP);
      if (mean_dilatation) md_coupling.add_to_batch<B>(p0, count, wq, dF, dP);
      for (int l = 0; l < count; ++l) {
        if (shift != 0.0)
          for (int a = 0; a < 9; ++a) {
            double acc = 0.0;
            for (int b = 0; b < 9; ++b) acc += S(a, b) * dF[b * B + l];
            dP[a * B + l] += acc;
          }
        const double w = wq[(p0 + l) % nq];
        for (int c = 0; c < 9; ++c) local[c] += w * dP[c * B + l];
      }
    };
    if (streamed)
      dot_sum += stencil->streamed_pass(fft3->real(0), stream_scratch.data(), body, true, dot != nullptr, slab_shift_up());
    else
      stencil->gradient_pass(fft3->real(0), stencil_store(), body);
#pragma omp critical
    for (int c = 0; c < 9; ++c) mean[c] += local[c];
  }
  if (!streamed) {
    fill_store_halo();
    dot_sum = stencil->divergence_pass(stencil_store(), fft3->real(0), dot ? fft3->real(0) : nullptr);
  }
  if (dot) *dot = dot_sum;
  if (dist) dist->sum(mean.data(), 9);
  return mean / double(Ntot);
}

void FftRveSolver::Impl::apply(const KVec& x, const std::array<bool, 9>& free, KVec& y, double shift) {
  if (stencil) {
    displacement_to_real(x.u);
    const Vec9 mean = stencil_tangent_product(flatten(to_grid(unflatten(x.f))), shift);
    fft3->forward();
    const double invN = 1.0 / double(Ntot);
    const Complex* s3 = fft3->spectrum(0);
    y.u.resize(3 * NM);
#pragma omp parallel for schedule(static)
    for (std::size_t a = 0; a < 3 * NM; ++a) y.u[a] = invN * s3[a];
    const Vec9 ml = T_load * mean;
    for (int c = 0; c < 9; ++c) y.f[c] = free[c] ? ml[c] : 0.0;
    return;
  }
  op.gradient(x.u.data(), fft->spectrum(0), false);
  fft->backward();
  const Vec9 mean = tangent_product(flatten(to_grid(unflatten(x.f))), shift);
  fft->forward();
  op.divergence(fft->spectrum(0), y.u.data(), 1.0 / double(Ntot));
  const Vec9 ml = T_load * mean;
  for (int c = 0; c < 9; ++c) y.f[c] = free[c] ? ml[c] : 0.0;
}

double FftRveSolver::Impl::apply_direction(const KVec& z, double beta, KVec& p, const std::array<bool, 9>& free,
                                           KVec& Ap, double shift, const KVec* r_for_z) {
  if (stencil) {
    // p ← z + βp, and a copy for the c2r transform (which destroys its input).
    Complex* s3 = fft3->spectrum(0);
    const Complex* zu = z.u.data();
    Complex* pu = p.u.data();
    if (r_for_z) {
      green.direction_update(r_for_z->u.data(), beta, pu, s3);
      if (local_bulk_in(shift))
        green.add_bulk_correction(bulk_cof, r_for_z->u.data(), bulk_fft->spectrum(0), 1.0 / double(Ntot), bulk_w0, pu, s3);
    } else {
#pragma omp parallel for schedule(static)
      for (std::size_t a = 0; a < 3 * NM; ++a) {
        const Complex v = beta == 0.0 ? zu[a] : zu[a] + beta * pu[a];
        pu[a] = v;
        s3[a] = v;
      }
    }
    p.f = beta == 0.0 ? Vec9(z.f) : Vec9(z.f + beta * p.f);
    fft3->backward();
    fill_displacement_halo();
    // ⟨p, Ap⟩ on the real fields (Parseval: Σ_half m_k Re(p̂_k* Âp_k) = Σ_y p(y)·f(y) / N).
    double pAp_local = 0.0;
    const Vec9 mean = stencil_tangent_product(flatten(to_grid(unflatten(p.f))), shift, &pAp_local);
    const double pAp = global_sum(pAp_local) / double(Ntot);
    fft3->forward();
    const Vec9 ml = T_load * mean;
    for (int c = 0; c < 9; ++c) Ap.f[c] = free[c] ? ml[c] : 0.0;
    return pAp + p.f.dot(Ap.f);
  }
  op.gradient_of_update(z.u.data(), beta, p.u.data(), fft->spectrum(0));
  p.f = beta == 0.0 ? Vec9(z.f) : Vec9(z.f + beta * p.f);
  fft->backward();
  const Vec9 mean = tangent_product(flatten(to_grid(unflatten(p.f))), shift);
  fft->forward();
  const double pAp = global_sum(op.divergence_dot(fft->spectrum(0), Ap.u.data(), 1.0 / double(Ntot), p.u.data()));
  const Vec9 ml = T_load * mean;
  for (int c = 0; c < 9; ++c) Ap.f[c] = free[c] ? ml[c] : 0.0;
  return pAp + p.f.dot(Ap.f);
}

void FftRveSolver::Impl::precondition_macro(const Vec9& rf, const Eigen::MatrixXd& macro_inverse,
                                            const std::vector<int>& free_idx, Vec9& zf) {
  zf.setZero();
  if (free_idx.empty()) return;
  Eigen::VectorXd r(free_idx.size());
  for (std::size_t a = 0; a < free_idx.size(); ++a) r[a] = rf[free_idx[a]];
  const Eigen::VectorXd z = macro_inverse * r;
  for (std::size_t a = 0; a < free_idx.size(); ++a) zf[free_idx[a]] = z[a];
}

std::vector<int> FftRveSolver::Impl::free_indices(const std::array<bool, 9>& free) {
  std::vector<int> idx;
  for (int c = 0; c < 9; ++c)
    if (free[c]) idx.push_back(c);
  return idx;
}

Eigen::MatrixXd FftRveSolver::Impl::macro_block_inverse(const std::vector<int>& free_idx, double shift) const {
  const Mat9 Cl = T_load * (C0 + shift * C_shift) * T_load.transpose();
  const int m = int(free_idx.size());
  Eigen::MatrixXd B(m, m);
  for (int a = 0; a < m; ++a)
    for (int b = 0; b < m; ++b) B(a, b) = Cl(free_idx[a], free_idx[b]);
  return m ? Eigen::MatrixXd(B.inverse()) : Eigen::MatrixXd(0, 0);
}

void FftRveSolver::Impl::set_reference(bool shift_without_bulk) {
  choose_reference();
  if (local_bulk) set_local_bulk_reference();
  C_shift = shift_without_bulk ? shift_medium(C0) : C0;
  green.set(C0);
  green_shift = 0.0;
  if (jacobi_green()) detail::set_jacobi_scaling(*this);
}

void FftRveSolver::Impl::tabulate_green(double shift) {
  if (shift == green_shift) return;
  green.set(C0 + shift * C_shift);
  green_shift = shift;
}

Mat9 FftRveSolver::Impl::shift_medium(const Mat9& C) {
  Eigen::SelfAdjointEigenSolver<Mat9> es(0.5 * (C + C.transpose()));
  if (es.info() != Eigen::Success) return C;
  Vec9 e = es.eigenvalues();
  if (!(e[7] > 0.0) || !(e[8] > e[7])) return C;
  e[8] = e[7];
  return es.eigenvectors() * e.asDiagonal() * es.eigenvectors().transpose();
}

void FftRveSolver::Impl::set_local_bulk_reference() {
  const detail::IsotropicModuli iso = detail::isotropic_projection(C0);
  const double k0 = std::max(iso.K, 0.0), mu0 = std::max(iso.mu, 1e-12 * std::max(k0, 1.0));
  const Mat3 Fg = to_grid(Fbar);
  const double J = Fg.determinant();
  C0 = detail::isotropic_pull_back(k0, mu0, Fg);
  bulk_cof = J * Fg.inverse().transpose();
  bulk_w0 = J / (k0 + 4.0 / 3.0 * mu0);
  Vec9 b;
  for (int c = 0; c < 9; ++c) b[c] = bulk_cof(c / 3, c % 3);
  const double b2 = b.squaredNorm();
  constexpr int B = fft::StencilGradient::kBatch;
  double w_sum = 0.0;
#pragma omp parallel for schedule(static) reduction(+ : w_sum)
  for (std::size_t p0 = 0; p0 < NP; p0 += B) {
    const int count = int(std::min<std::size_t>(B, NP - p0));
    alignas(64) double dF[9 * B], dP[9 * B];
    for (int c = 0; c < 9; ++c)
      for (int l = 0; l < B; ++l) dF[c * B + l] = b[c];
    tangent_product_batch(p0, count, dF, dP);
    for (int l = 0; l < count; ++l) {
      double bAb = 0.0;
      for (int c = 0; c < 9; ++c) bAb += b[c] * dP[c * B + l];
      const double w = J / (detail::local_bulk_modulus(bAb, J, b2) + 4.0 / 3.0 * mu0);
      bulk_w[p0 + std::size_t(l)] = float(w);
      w_sum += double(float(w));
    }
  }
  bulk_w_sum = global_sum(w_sum);
}

double FftRveSolver::Impl::local_bulk_prepare(const Complex* r) {
  green.bulk_potential(bulk_cof, r, bulk_fft->spectrum(0));
  bulk_fft->backward();
  double* f = bulk_fft->real(0);
  const float* w = bulk_w.data();
  const std::size_t n1 = std::size_t(grid.n[0]), pitch = bulk_fft->real_row_pitch();
  const long rows = long(N / n1);
  double s_w_psi = 0.0, s_w_psi2 = 0.0, s_psi2 = 0.0;
#pragma omp parallel for schedule(static) reduction(+ : s_w_psi, s_w_psi2, s_psi2)
  for (long row = 0; row < rows; ++row) {
    const double* fr = f + std::size_t(row) * pitch;
    const float* wr = w + std::size_t(row) * n1;
    for (std::size_t i = 0; i < n1; ++i) {
      const double psi = fr[i], wv = double(wr[i]);
      s_w_psi += wv * psi;
      s_w_psi2 += wv * psi * psi;
      s_psi2 += psi * psi;
    }
  }
  if (dist) {  // one reduction for the three sums
    double sums3[3] = {s_w_psi, s_w_psi2, s_psi2};
    dist->sum(sums3, 3);
    s_w_psi = sums3[0];
    s_w_psi2 = sums3[1];
    s_psi2 = sums3[2];
  }
  const double c = bulk_w_sum > 0.0 ? -s_w_psi / bulk_w_sum : 0.0;
#pragma omp parallel for schedule(static)
  for (long row = 0; row < rows; ++row) {
    double* fr = f + std::size_t(row) * pitch;
    const float* wr = w + std::size_t(row) * n1;
    for (std::size_t i = 0; i < n1; ++i) fr[i] = double(wr[i]) * (fr[i] + c);
  }
  bulk_fft->forward();
  return (s_w_psi2 + c * s_w_psi - bulk_w0 * s_psi2) / double(Ntot);
}

void FftRveSolver::Impl::choose_reference() {
  if (opt.reference == ReferenceMedium::geometric && opt.scheme == FftScheme::newton_cg &&
      sums.phase_A_w[0] > 0.0 && sums.phase_A_w[1] > 0.0) {
    // Isotropic projections of the phase-mean tangents.
    double K[2], mu[2];
    for (int x = 0; x < 2; ++x) {
      const detail::IsotropicModuli iso = detail::isotropic_projection(sums.phase_A[x] / sums.phase_A_w[x]);
      K[x] = iso.K;
      mu[x] = iso.mu;
    }
    if (K[0] > 0.0 && K[1] > 0.0 && mu[0] > 0.0 && mu[1] > 0.0) {
      const double K0 = std::sqrt(K[0] * K[1]), mu0 = std::sqrt(mu[0] * mu[1]);
      C0 = detail::isotropic_tangent(K0 - 2.0 / 3.0 * mu0, mu0);
      return;
    }
  }
  if (opt.reference != ReferenceMedium::isotropic && opt.scheme == FftScheme::newton_cg)
    C0 = 0.5 * (sums.A + sums.A.transpose());
  else
    C0 = detail::isotropic_tangent(lambda_ref, mu_ref);
}

krylov::Controls FftRveSolver::Impl::krylov_controls(double rel_tol) const {
  krylov::Controls c;
  c.rel_tol = rel_tol;
  c.max_iterations = opt.max_krylov_iterations;
  c.stop = dist ? nullptr : &stop_requested;  // distributed: polled collectively per Newton iteration
  return c;
}

int FftRveSolver::Impl::pcg(const KVec& b, const std::array<bool, 9>& free, double rel_tol, KVec& x, double shift,
                            bool& breakdown, KVec* residual) {
  const auto start = Clock::now();
  const std::vector<int> free_idx = free_indices(free);
  tabulate_green(shift);
  const Eigen::MatrixXd Minv = macro_block_inverse(free_idx, shift);
  cg_p.u.resize(3 * NM);
  if (!stencil) cg_z.u.resize(3 * NM);  // the stencil operator's CG recomputes z (CgSpace::direction)
  if (!stencil) cg_Ap.u.resize(3 * NM);  // the stencil operator leaves Ap in fft3's spectrum buffer
  // Per iteration (Fourier operator): one fused pass p ← z + βp → ∇p, FFT⁻¹ of 6·nq (section) or 9·nq
  // fields, the tangent pass, FFT, one fused pass Div → Ap and ⟨p, Ap⟩, one fused pass x += αp,
  // r −= αAp, z = M⁻¹r and ⟨r, z⟩. Stencil operator (rotated/hex): p ← z + βp (+ copy), FFT⁻¹ of 3
  // fields, one real-space pass ∇p → δP → per-voxel nodal values (SIMD tangent product over 8
  // points), one gather pass Bᵀ δP with ⟨p, Ap⟩, FFT of 3 fields, the same CG update pass reading Ap
  // from the FFT buffer.
  CgSpace space{*this, free, Minv, free_idx, shift};
  auto macro = [&](const Vec9& rf) {
    Vec9 zf;
    precondition_macro(rf, Minv, free_idx, zf);
    return zf;
  };
  const krylov::CgResult res = jacobi_green() && shift == 0.0
                                   ? detail::jacobi_green_pcg(*this, b, free, macro, krylov_controls(rel_tol), x)
                                   : krylov::pcg(space, b, x, residual ? *residual : cg_r, cg_z, cg_p, cg_Ap,
                                                 krylov_controls(rel_tol));
  breakdown = res.breakdown;
  krylov_seconds += std::chrono::duration<double>(Clock::now() - start).count();
  return res.iterations;
}

void FftRveSolver::Impl::recover_rhs(KVec& b, const KVec& x, const std::array<bool, 9>& free, double shift) {
  cg_p.u.resize(3 * NM);
  apply(x, free, cg_p, shift);
  axpy(1.0, cg_p, b);
}

double FftRveSolver::Impl::dot(const KVec& a, const KVec& b) const {
  double s = 0.0;
#pragma omp parallel for reduction(+ : s) schedule(static)
  for (std::size_t k = 0; k < NM; ++k) {
    const double m = grid.mode_weight(k);
    for (int c = 0; c < 3; ++c) s += m * std::real(std::conj(a.u[c * NM + k]) * b.u[c * NM + k]);
  }
  return global_sum(s) + a.f.dot(b.f);
}

void FftRveSolver::Impl::axpby(double alpha, const KVec& x, double beta, KVec& y) {
  const std::size_t n = x.u.size();
#pragma omp parallel for schedule(static)
  for (std::size_t i = 0; i < n; ++i) y.u[i] = alpha * x.u[i] + beta * y.u[i];
  y.f = alpha * x.f + beta * y.f;
}

int FftRveSolver::Impl::pminres(const KVec& b, const std::array<bool, 9>& free, double rel_tol, KVec& x, bool& converged) {
  const auto start = Clock::now();
  const std::vector<int> free_idx = free_indices(free);
  tabulate_green(0.0);
  const Eigen::MatrixXd Minv = macro_block_inverse(free_idx);
  MinresSpace space{*this, free, Minv, free_idx};
  const krylov::MinresResult res = krylov::pminres(space, b, x, krylov_controls(rel_tol));
  converged = res.converged;
  krylov_seconds += std::chrono::duration<double>(Clock::now() - start).count();
  return res.iterations;
}

Mat9 FftRveSolver::homogenized_tangent(double krylov_tolerance, RveCounts* counts) {
  Impl& m = *impl_;
  if (m.opt.scheme != FftScheme::newton_cg)
    throw InputError("solver.scheme", to_string(m.opt.scheme), "the homogenized tangent needs newton-cg (stored tangents)");
  const std::array<bool, 9> prescribed{};  // no free macro component: K_uu δũ = −Dᴴ A E
  std::array<bool, 9> all{};
  all.fill(true);                          // macro rows of K [δũ; E] = ⟨A (E + ∇δũ)⟩
  m.set_reference();
  const std::vector<int> no_free;
  const Eigen::MatrixXd no_macro(0, 0);
  Impl::KVec e{std::vector<Complex>(3 * m.NM, 0.0), Vec9::Zero()}, b{std::vector<Complex>(3 * m.NM), Vec9::Zero()};
  Impl::KVec x{std::vector<Complex>(3 * m.NM, 0.0), Vec9::Zero()}, y{std::vector<Complex>(3 * m.NM), Vec9::Zero()};
  m.cg_p.u.resize(3 * m.NM);
  if (!m.stencil) m.cg_z.u.resize(3 * m.NM);
  if (!m.stencil) m.cg_Ap.u.resize(3 * m.NM);
  Mat9 C = Mat9::Zero();
  int iterations = 0;
  for (int c = 0; c < 9; ++c) {
    e.f = Vec9::Unit(c);
    m.apply(e, prescribed, b);
    for (auto& v : b.u) v = -v;
    b.f.setZero();
    Impl::CgSpace space{m, prescribed, no_macro, no_free, 0.0};
    const krylov::CgResult res = krylov::pcg(space, b, x, m.cg_r, m.cg_z, m.cg_p, m.cg_Ap, m.krylov_controls(krylov_tolerance));
    iterations += res.iterations + 2;  // + the operator applications of the right-hand side and the average
    bool converged = res.converged;
    if (res.breakdown) {  // indefinite tangent field (past a bifurcation): MINRES, as the Newton step
      iterations += m.pminres(b, prescribed, krylov_tolerance, x, converged);
    }
    if (!converged)
      throw ConvergenceError("homogenized tangent: the linear cell problem of F̄ component " + std::to_string(c / 3 + 1) +
                             std::to_string(c % 3 + 1) + " did not converge in " +
                             std::to_string(m.opt.max_krylov_iterations) + " Krylov iterations");
    x.f = e.f;
    m.apply(x, all, y);
    C.col(c) = y.f;
  }
  if (counts) counts->krylov_iterations += iterations;
  return C;
}

FftRveSolver::DenseOperator FftRveSolver::dense_fluctuation_operator() {
  Impl& m = *impl_;
  const std::size_t n = 6 * m.NM;
  if (n > 4096 || m.dist)
    throw InputError("microstructure.grid", std::to_string(m.Ntot) + " voxels",
                     "the dense Newton operator is for one-process cells of at most 4096 unknowns");
  const std::array<bool, 9> prescribed{};
  DenseOperator out;
  out.K.resize(Eigen::Index(n), Eigen::Index(n));
  out.laplacian.resize(n);
  Impl::KVec e{std::vector<Complex>(3 * m.NM, 0.0), Vec9::Zero()}, y{std::vector<Complex>(3 * m.NM), Vec9::Zero()};
  for (std::size_t j = 0; j < n; ++j) {
    const std::size_t a = j / 2;
    out.laplacian[j] = m.op.laplacian(m.op.mode_offset() + a % m.NM);
    e.u[a] = j % 2 ? Complex(0.0, 1.0) : Complex(1.0, 0.0);
    m.apply(e, prescribed, y);
    e.u[a] = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t b = i / 2;
      const double w = m.grid.mode_weight(b % m.NM);
      out.K(Eigen::Index(i), Eigen::Index(j)) = w * (i % 2 ? y.u[b].imag() : y.u[b].real());
    }
  }
  return out;
}

}  // namespace softhom::rve
