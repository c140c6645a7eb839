// One sub-step of the FFT solver: the Newton loop with its line search and shifts, the failure
// diagnosis and the fixed-point scheme (fft_solver_impl.hpp).
#include "fft_solver_impl.hpp"

#include "softhom/fe/line_search.hpp"

namespace softhom::rve {

detail::HotSpots FftRveSolver::Impl::hot_spots(const KVec& r) {
  detail::HotSpots h;
  const Mat3 Fg = to_grid(Fbar);
  auto see_point = [&](std::size_t v, int q, Mat3 F) {
    const std::size_t p = v * nq + q;
    const double f = fraction(v);
    if (f >= 1.0) return;
    const bool composite = comp_id[v] >= 0;
    if (composite && comp_normal[comp_id[v]].squaredNorm() > 0.0) {
      const std::size_t c = std::size_t(comp_id[v]) * nq + q;
      const Vec3 a(lam_a_trial[3 * c], lam_a_trial[3 * c + 1], lam_a_trial[3 * c + 2]);
      F -= f * a * comp_normal[comp_id[v]].transpose();
    }
    h.see_matrix_point(v0 + v, mat[0]->limit_margin(F), F.determinant(), composite);
    if (pressures.mixed[0] && !composite) h.see_pressure(v0 + v, double(pressures.p_trial[p]));
  };
  if (streamed) {
    displacement_to_real(u);
    // one thread: the points in voxel order, as below (ties name the first voxel)
#pragma omp parallel num_threads(1)
    stencil->gradient_pass(fft3->real(0), nullptr, [&](std::size_t p0, int count, const double* grad, double*) {
      for (int l = 0; l < count; ++l) see_point(p0 + std::size_t(l), 0, lane_F(Fg, grad, l));
    });
  } else {
    gradient_to_real(u);
    for (std::size_t v = 0; v < N; ++v)
      for (int q = 0; q < nq; ++q) see_point(v, q, point_F(Fg, v, q));
  }
  // Nodal forces Dᴴ P in real space.
  const auto [t, step] = vector_to_real(r.u);
  std::vector<double> f(3 * N);  // dense copies of the three components (a failure path)
  for (int i = 0; i < 3; ++i) copy_from_real(*t, i * step, f.data() + i * N);
  h.see_forces(f.data(), f.data() + N, f.data() + 2 * N, N);
  if (dist) {
    h.v_force += v0;
    detail::reduce_hot_spots(h, *dist, N);
  }
  return h;
}

std::string FftRveSolver::Impl::voxel_name(std::size_t v) const {
  if (!dist) return detail::voxel_name(grid.n, local_fraction(), v);
  const double f = detail::fractions_of(*dist, local_fraction(), N, v0, {v})[0];
  return detail::voxel_name(grid.n, detail::FractionOf([f](std::size_t) { return f; }), v);
}

std::string FftRveSolver::Impl::describe(const detail::HotSpots& h) const {
  if (!dist) return detail::describe_hot_spots(h, grid.n, local_fraction(), pressures.mixed[0], Fbar_committed(0, 0));
  const std::vector<std::size_t> named{h.v_margin, h.v_J_min, h.v_force, h.v_p};
  const std::vector<double> f = detail::fractions_of(*dist, local_fraction(), N, v0, named);
  auto fraction = [&](std::size_t v) { return f[std::find(named.begin(), named.end(), v) - named.begin()]; };
  return detail::describe_hot_spots(h, grid.n, detail::FractionOf(fraction), pressures.mixed[0], Fbar_committed(0, 0));
}

FftRveSolver::Impl::StepOutcome& FftRveSolver::Impl::fatal(StepOutcome& out, std::string why) {
  out.fatal = true;
  out.why = std::move(why);
  return out;
}

FftRveSolver::Impl::StepOutcome& FftRveSolver::Impl::converged(StepOutcome& out) const {
  const std::string where[2] = {voxel_name(sums.margin_at[0]), voxel_name(sums.margin_at[1])};
  if (std::string why = detail::phase_limit_reached(sums.margin, where, Fbar); !why.empty()) return fatal(out, why);
  out.ok = true;
  return out;
}

void FftRveSolver::Impl::move_to_accepted(const KVec& dx, double& applied, const Mat3& Fbar_prev) {
#pragma omp parallel for schedule(static)
  for (std::size_t i = 0; i < u.size(); ++i) u[i] -= applied * dx.u[i];
  applied = 0.0;
  Fbar = Fbar_prev;
}

FftRveSolver::Impl::StepOutcome FftRveSolver::Impl::step(const MixedControl& control, double t_new, double dt) {
  StepOutcome out;
  NewtonState s;
  s.t_new = t_new;
  s.dt = dt;
  s.target = Fbar;
  for (int c = 0; c < 9; ++c) {
    s.free[c] = control.kind[c] == ControlKind::stress;
    if (s.free[c])
      s.P_target[c] = control.value[c](t_new);
    else
      s.target(c / 3, c % 3) = control.value[c](t_new);
  }
  s.r = KVec{std::vector<Complex>(3 * NM), Vec9::Zero()};
  if (std::string why = detail::target_inverts(control, t_new, Fbar_committed); !why.empty()) return fatal(out, why);
  if (opt.scheme == FftScheme::moulinec_suquet) return fixed_point(s.free, s.P_target, s.target, dt, s.r);

  s.max_it = opt.max_newton_iterations;
  s.minres_mode = opt.indefinite_solver == IndefiniteSolver::minres;
  s.Fbar_prev = Fbar;
  // The predictor takes the extrapolated pressure (or, at the committed state, the exact W_V′(J),
  // which is what the linearization there would give); every later iterate takes its pressure from
  // the linearization at the last accepted state (see PressureIteration::correct()).
  pressures.linearized = false;
  for (int it = 0; it <= s.max_it; ++it) {
    if (stop_now()) {
      out.why = "stopped by a signal";
      return out;
    }
    // Evaluate the new iterate. After a Newton update, a backtracking line search on the residual
    // norm: nearly incompressible matrices (K/G ~ 1e5) make full Newton steps overshoot in J.
    if (!(it == 0 ? evaluate_predictor(s, out) : search_line(s, out))) return out;
    const double err = s.err;
    out.residuals.push_back(err);
    if (opt.on_newton_iteration) opt.on_newton_iteration(t_new, it, err, out.krylov_iterations);
    const Mat3 dFp = prescribed_gap(s);
    const bool prescribed_reached = dFp.cwiseAbs().maxCoeff() == 0.0;
    if (!std::isfinite(err)) {
      out.why = "non-finite residual";
      return out;
    }
    // Round-off floor: stresses ~ K (J − 1) carry absolute errors ~ ε K (K/G = 1.2e5 for ecoflex), so
    // a relative tolerance below ε K / |P̄| cannot be reached; there the floor counts as convergence.
    const double floor = 64.0 * std::numeric_limits<double>::epsilon() * K_max / stress_scale(s.free, s.P_target);
    if (prescribed_reached && err <= std::max(opt.tolerance, floor)) {
      return converged(out);
    }
    follow_continuation(s, it, prescribed_reached, out);
    if (it == s.max_it && !extend_with_minres(s, it, prescribed_reached, out)) break;
    if (prescribed_reached) {
      if (s.first_err < 0.0) s.first_err = err;
      if (err > 1e6 * std::max(s.first_err, opt.tolerance)) {
        out.why = "Newton diverged";
        return out;
      }
    }
    solve_newton_step(s, it, dFp, prescribed_reached, out);
  }
  out.why = "no convergence in " + std::to_string(opt.max_newton_iterations) + " Newton iterations" +
            (s.continuation ? " + " + std::to_string(out.continuation_iterations) + " continuation iterations"
                            : std::string()) +
            " (residual " + format_number(s.err) + "); " + describe(hot_spots(s.r));
  return out;
}

bool FftRveSolver::Impl::evaluate_predictor(NewtonState& s, StepOutcome& out) {
  // Predictor: linear extrapolation of the last converged increment (prescribed components set
  // exactly); the path is smooth, so this lands much closer to the solution than the tangent
  // predictor when the matrix is nearly incompressible. Falls back to the tangent predictor.
  s.extrapolated = false;
  if (extrapolate && dt_last > 0.0 && !du_last.empty()) {
    const double ratio = s.dt / dt_last;
    for (std::size_t i = 0; i < u.size(); ++i) u[i] = u_committed[i] + ratio * Complex(du_last[i]);
    Fbar = Fbar_committed + ratio * dF_last;
    for (int c = 0; c < 9; ++c)
      if (!s.free[c]) Fbar(c / 3, c % 3) = s.target(c / 3, c % 3);
    pressures.predictor_ratio = ratio;
    s.extrapolated = evaluate_iterate(s.dt, true, s.free, s.P_target, s.r, s.err) == MaterialStatus::ok;
    pressures.predictor_ratio = -1.0;
    if (!s.extrapolated) restore();
    // Its merit (extrapolated pressure) is not comparable with the Newton iterates' (pressure
    // reset to the constraint's linearization), so the first Newton step is taken in full.
    else if (pressures.active()) s.full_first_step = true;
  }
  const MaterialStatus status =
      s.extrapolated ? MaterialStatus::ok : evaluate_iterate(s.dt, true, s.free, s.P_target, s.r, s.err);
  if (status != MaterialStatus::ok) {
    out.why = std::string("material call failed (") + to_string(status) + ")";
    return false;
  }
  pressures.linearized = pressures.active();
  return true;
}

bool FftRveSolver::Impl::search_line(NewtonState& s, StepOutcome& out) {
  MaterialStatus last = MaterialStatus::ok;
  int trials = 0;
  auto trial = [&](double scale) -> std::optional<double> {
    if (pressures.active() && (trials++ > 0 || opt.relinearize_every_trial)) {
      // The previous trial was rejected and left its linearization (all of it, or part after a
      // material failure): back to the accepted iterate (applied = 0) and its linearization before
      // this trial reads it (FftSolverOptions::relinearize_every_trial: before every trial, a check).
      // A trial evaluated with the rejected one's linearization would still converge to the same
      // stress, by another path.
      move_to_accepted(s.dx, s.applied, s.Fbar_prev);
      relinearize_pressures(to_grid(Fbar));
    }
    const double move = scale - s.applied;
#pragma omp parallel for schedule(static)
    for (std::size_t i = 0; i < u.size(); ++i) u[i] += move * s.dx.u[i];
    s.applied = scale;
    Fbar = s.Fbar_prev + scale * s.step_macro;
    last = evaluate_iterate(s.dt, true, s.free, s.P_target, s.r, s.err);
    if (last != MaterialStatus::ok) return std::nullopt;
    if (!std::isfinite(s.err)) return std::nullopt;
    return merit;
  };
  // Continuation accepts any admissible iterate: on the way from the end of one equilibrium
  // branch to the next the residual has to grow before it falls.
  // Mixed iteration: the trials are measured with the pressure linearized at the accepted
  // iterate x_k, which reproduces W_V′ there, so the reference is x_k's true residual; the
  // merit x_k was accepted with (the previous linearization's) is not comparable and, taken as
  // the reference, let the true residual grow several-fold or held the step to the last trial
  // (BENCHMARKS.md, "Iteration cost and solver options": the line search).
  const double merit_accepted = pressures.active() ? true_merit : merit;
  const bool accepted =
      fe::backtracking_line_search(merit_accepted, s.continuation || s.had_prescribed_step, trial).accepted;
  if (accepted) return true;
  out.why = last != MaterialStatus::ok ? std::string("material call failed (") + to_string(last) + ")"
                                       : std::string("line search failed");
  // Diagnose the last accepted iterate, not the rejected trial (an overshooting full step of a
  // nearly incompressible matrix can be arbitrarily far from anything the cell can reach).
  // r holds the right-hand side of the last solve: re-evaluate the restored iterate's residual,
  // with its linearization (the trials overwrote it).
  // The composite points start their laminate solves from the committed jump vectors: the
  // failed trials left theirs, from which a solve at the accepted F can fail too and leave the
  // diagnosis without a residual (RveStops.FftFailedLineSearchIsDiagnosedAtTheAcceptedIterate).
  move_to_accepted(s.dx, s.applied, s.Fbar_prev);
  lam_a_trial = lam_a;
  if (pressures.active()) relinearize_pressures(to_grid(Fbar));
  double accepted_err = 0.0;
  const MaterialStatus again = evaluate_iterate(s.dt, false, s.free, s.P_target, s.r, accepted_err);
  // Without its residual the hot spots would name a zero force at voxel (0, 0, 0): say so instead.
  out.why += again == MaterialStatus::ok
                 ? "; " + describe(hot_spots(s.r))
                 : std::string("; the last accepted iterate could not be evaluated again (") + to_string(again) + ")";
  return false;
}

Mat3 FftRveSolver::Impl::prescribed_gap(const NewtonState& s) const {
  Mat3 dFp = Mat3::Zero();
  for (int c = 0; c < 9; ++c)
    if (!s.free[c]) dFp(c / 3, c % 3) = s.target(c / 3, c % 3) - Fbar(c / 3, c % 3);
  return dFp;
}

void FftRveSolver::Impl::follow_continuation(NewtonState& s, int it, bool prescribed_reached, StepOutcome& out) const {
  if (s.continuation) {
    // Switched evolution relaxation, one-sided: the shift follows a falling residual, so it
    // vanishes (Newton) as the iteration closes in on an equilibrium, but is not raised while the
    // residual grows on the way between branches (that would stall the descent); only an
    // indefinite linear solve raises it (the Levenberg–Marquardt retry in solve_newton_step()).
    s.ptc_shift *= std::clamp(s.err / s.ptc_err, 0.2, 1.0);
    if (s.ptc_shift < 1e-9) s.ptc_shift = 0.0;
    s.ptc_err = s.err;
    ++out.continuation_iterations;
  } else if (prescribed_reached && opt.max_continuation_iterations > 0 && it >= 10 &&
             (it == s.max_it || s.err > 0.3 * out.residuals[out.residuals.size() - 4])) {
    // Stagnation (less than a factor 3 in three iterations after ten): the branch has ended.
    s.continuation = true;
    s.ptc_shift = std::max(10.0 * s.lm_shift, 1e-2);
    s.ptc_err = s.err;
    s.max_it = it + opt.max_continuation_iterations;
  }
}

bool FftRveSolver::Impl::extend_with_minres(NewtonState& s, int it, bool prescribed_reached, StepOutcome& out) const {
  if (s.minres_mode || s.continuation || !opt.minres_fallback || !prescribed_reached || !(s.err < opt.minres_below))
    return false;
  // The shifted iteration stalls just above the tolerance next to a bifurcation point of the
  // cell (singular tangent): take the exact Newton steps there (MINRES on negative curvature).
  s.minres_mode = true;
  s.lm_shift = 0.0;
  s.max_it = it + opt.max_newton_iterations;
  ++out.minres_fallbacks;
  return true;
}

void FftRveSolver::Impl::form_newton_rhs(NewtonState& s, const Mat3& dFp, bool prescribed_reached, StepOutcome& out) {
  // Right-hand side −r − K [0; ΔF_p] (tangent predictor for the prescribed increment), formed in
  // r's storage: r is not read again before the next evaluation overwrites it. The CG work vectors
  // serve as e and K e (pcg overwrites them).
  KVec& b = s.r;
  for (auto& c : b.u) c = -c;
  b.f = -b.f;
  if (!prescribed_reached) {
    KVec& e = s.dx;  // pcg() starts from zero
    KVec& Ke = cg_p;
    e.u.assign(3 * NM, 0.0);
    e.f = flatten(dFp);
    Ke.u.resize(3 * NM);
    apply(e, s.free, Ke);
    ++out.krylov_iterations;
    axpy(-1.0, Ke, b);
  }
}

void FftRveSolver::Impl::solve_newton_step(NewtonState& s, int it, const Mat3& dFp, bool prescribed_reached,
                                           StepOutcome& out) {
  // The solve after the step's full linear increment (the extrapolated predictor's, else that after
  // the tangent predictor's step, which is taken in full) starts where J − 1 = O(Δ∇u²) near the
  // fibers, a pressure spike K (J − 1) that makes the tangent indefinite (composite voxels, whose
  // laminate carries the law's own pressure): its shift must leave the dilatation free
  // (shift_medium()). Later solves shift by C0 itself, which damps every mode alike and measured
  // better once the spike is gone (BENCHMARKS.md, "Iteration cost and solver options").
  set_reference(it == 0 || (it == 1 && !s.extrapolated));
  form_newton_rhs(s, dFp, prescribed_reached, out);
  KVec& b = s.r;
  const double err = s.err;
  // Forcing term (Eisenstat–Walker-like): loose while far from the solution, tight near it.
  double eta = std::clamp(std::max(std::min(1e-2, err), 0.1 * opt.tolerance / std::max(err, 1e-300)), 1e-12, 0.1);
  if (opt.krylov_tolerance > 0.0) eta = opt.krylov_tolerance;
  // Indefinite tangent (large pressure or compression away from the solution): retry the linear
  // solve as a Levenberg–Marquardt step with a shift of the reference medium, which grows by 10
  // on each breakdown and starts the next Newton iteration ten times smaller.
  bool breakdown = false;
  double shift = s.continuation ? s.ptc_shift : s.lm_shift;
  const double lin_tol = prescribed_reached ? eta : std::min(eta, 1e-3);
  // The solve's residual lives in b's storage (one spectral vector less): after a breakdown b is
  // recovered for the retry.
  const bool rhs_in_place = !jacobi_green();
  for (int attempt = 0; attempt < 8; ++attempt) {
    const int cg_iterations = pcg(b, s.free, lin_tol, s.dx, shift, breakdown, rhs_in_place ? &b : nullptr);
    out.krylov_iterations += cg_iterations;
    if (!breakdown) break;
    out.discarded_krylov_iterations += cg_iterations;
    if (rhs_in_place) {
      recover_rhs(b, s.dx, s.free, shift);
      ++out.krylov_iterations;
      ++out.discarded_krylov_iterations;
    }
    // Negative curvature near the solution (the residual is already small): an indefinite
    // equilibrium tangent, not a transient of the iteration — solve it as it is (MINRES).
    if (s.minres_mode && shift == 0.0 && prescribed_reached && err < opt.minres_below) {
      bool converged = false;
      const int minres_iterations = pminres(b, s.free, lin_tol, s.dx, converged);
      out.krylov_iterations += minres_iterations;
      if (!converged) out.discarded_krylov_iterations += minres_iterations;
      ++out.minres_solves;
      if (converged) {
        breakdown = false;
        break;
      }
    }
    shift = shift == 0.0 ? 1e-3 : 10.0 * shift;
    ++out.shifted_solves;
  }
  s.lm_shift = shift >= 1e-2 ? 0.1 * shift : 0.0;
  if (s.continuation) s.ptc_shift = shift;
  ++out.newton_iterations;
  s.applied = 0.0;
  s.Fbar_prev = Fbar;
  s.step_macro = dFp + unflatten(s.dx.f);
  s.had_prescribed_step = !prescribed_reached || (it == 0 && s.full_first_step);
}

FftRveSolver::Impl::StepOutcome FftRveSolver::Impl::fixed_point(const std::array<bool, 9>& free, const Vec9& P_target,
                                                                const Mat3& target, double dt, KVec& r) {
  StepOutcome out;
  for (int c = 0; c < 9; ++c)
    if (!free[c]) Fbar(c / 3, c % 3) = target(c / 3, c % 3);
  set_reference();
  const std::vector<int> free_idx = free_indices(free);
  const Eigen::MatrixXd Minv = macro_block_inverse(free_idx);
  KVec z{std::vector<Complex>(3 * NM), Vec9::Zero()};
  double err = 0.0;
  for (int it = 0; it <= opt.max_fixed_point_iterations; ++it) {
    if (stop_now()) {
      out.why = "stopped by a signal";
      return out;
    }
    gradient_to_real(u);
    const MaterialStatus s = evaluate_points(to_grid(Fbar), dt, false);
    if (s != MaterialStatus::ok) {
      out.why = std::string("material call failed (") + to_string(s) + ")";
      return out;
    }
    residual(free, P_target, r);
    err = residual_norm(r, free, P_target);
    if (!std::isfinite(err) || err > 1e12) {
      out.why = "fixed point diverged";
      return out;
    }
    if (err <= opt.tolerance) {
      out.residuals.push_back(err);
      return converged(out);
    }
    precondition(r, Minv, free_idx, z);
    for (std::size_t i = 0; i < u.size(); ++i) u[i] -= z.u[i];
    Fbar -= unflatten(z.f);
    ++out.newton_iterations;
  }
  out.residuals.push_back(err);
  out.why = "fixed point: no convergence in " + std::to_string(opt.max_fixed_point_iterations) + " iterations";
  return out;
}

void FftRveSolver::Impl::commit(double dt) {
  // Remember the converged increment: the next step starts from its linear extrapolation.
  du_last.resize(u.size());
  for (std::size_t i = 0; i < u.size(); ++i) du_last[i] = std::complex<float>(u[i] - u_committed[i]);
  dF_last = Fbar - Fbar_committed;
  dt_last = dt;
  u_committed = u;
  Fbar_committed = Fbar;
  lam_a = lam_a_trial;
  for (int x = 0; x < 2; ++x)
    if (state_size[x]) hist_old[x].swap(hist_new[x]);
  pressures.commit(true);
}

void FftRveSolver::Impl::restore() {
  u = u_committed;
  Fbar = Fbar_committed;
  lam_a_trial = lam_a;
}

}  // namespace softhom::rve
