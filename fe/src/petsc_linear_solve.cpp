// The petsc path of fe::Simulation's linear solves (linear_solve.cpp hands over when the petsc solver
// is in use): GMRES to the forcing-term tolerance of the Newton iteration, preconditioned by the
// preconditioner of this tangent or, where its set-up dominates the solve (a factorization such as
// MUMPS's), of an earlier one, refreshed by the lagged-factor rules of the direct path.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <iostream>

#include "simulation_impl.hpp"
#include "softhom/materials/errors.hpp"

namespace softhom::fe {
using namespace detail;

namespace {

// GMRES iterations a fresh solve with the default p-multigrid (not from a secant start) gets before it
// counts as failed, and the displacement block falls back to BoomerAMG on the P2 field. Its converged
// solves take at most 158 on the device scenes and 259 on the 106 395-dof fibered tube at K/G 1e5
// (BENCHMARKS.md, "Macro solver on PETSc", Cook's membrane); where its P1 coarse space
// locks it either crawls (the plane-strain tet10 membrane at K/G 1e4, 32x32: 670, 393, 292, 292,
// against 59–96 on BoomerAMG) or stalls at |r|/|b| ~ 1 (64x64 at 1e4, 32x32 at 1e5).
constexpr int kPMultigridBudget = 400;

}  // namespace

bool Simulation::Impl::petsc_reuse_pays() const {
  // Reuse saves at most one set-up and costs the extra GMRES iterations of a lagged preconditioner. A
  // multigrid hierarchy costs 5–15 % of its solve (tube, cPASMO: BENCHMARKS.md), below the threshold,
  // and a lagged one cost up to 5x the iterations at K/G ~ 1e5, so it is rebuilt per tangent. A
  // factorization costs tens to hundreds of its one-iteration solves, and a lagged one needs a few to
  // twenty iterations, as the direct path's.
  return options_.reuse_preconditioner && petsc_lag_failures_ < 2 && petsc_iteration_time_ > 0.0 &&
         petsc_setup_time_ > 0.25 * std::max(1, petsc_fresh_iterations_) * petsc_iteration_time_;
}

void Simulation::Impl::petsc_set_operator(bool new_preconditioner) {
  // (The element loop has filled the matrix, three-field elements uncondensed with their pressures.)
  petsc_operator_version_ = k_version_;
  if (!new_preconditioner) {
    petsc_->update_operator();
    return;
  }
  const double before = petsc_->times().factorization;
  petsc_->factorize(K_);
  petsc_setup_time_ = petsc_->max_over_ranks(petsc_->times().factorization - before);
  factor_valid_ = true;
  factor_stale_ = false;
  factor_version_ = k_version_;
  if (first_factorization_)
    note_once("petsc", "linear solver: petsc (" + petsc_->description() + ", " + petsc_->near_nullspace() + ") on " +
                           std::to_string(petsc_->ranks()) + " MPI rank(s)");
  first_factorization_ = false;
  if (petsc_->anisotropic_smoother() && !anisotropic_smoother_noted_) {
    anisotropic_smoother_noted_ = true;
    char spread[32];
    std::snprintf(spread, sizeof spread, "%.3g", petsc_->block_spread());
    note_once("petsc smoother", "linear solver: from t = " + format_number(time_) +
                                    " the P2 level's smoother works on the 3 x 3 nodal blocks, two Chebyshev sweeps (nodal block spread " +
                                    spread + " of the tangent: anisotropic, e.g. fibers in tension)");
  }
}

bool Simulation::Impl::petsc_linear_solve(const std::vector<double>& b, std::vector<double>& x, double tol,
                                          std::string& why, bool secant_start) {
  x.assign(dofs_.num_free, 0.0);
  if (norm(b) == 0.0) return true;
  // factor_stale_ also carries the Newton iteration's refresh rules (solver.cpp, newton_correction): a
  // new preconditioner at the first iteration of an extrapolated step and while the residual does not halve.
  if (!factor_valid_ || factor_stale_ || (factor_version_ != k_version_ && !petsc_reuse_pays()))
    petsc_set_operator(true);
  else if (petsc_operator_version_ != k_version_)
    petsc_set_operator(false);
  for (;;) {
    const bool lagged = factor_version_ != k_version_;
    // A lagged preconditioner may spend the iterations a new one would save, no more. The first solve
    // from a secant start gets five times the last fresh solve's iterations (at least 200): where the
    // extrapolation overshoots (the gripper's fingers at 200 kPa) GMRES crawls at |r|/|b| ~ 1e-3 for
    // its whole limit, and a failure there is retried from the converged state (attempt_substep).
    // Other fresh solves with the default p-multigrid judge it, within kPMultigridBudget (a secant start's
    // crawl is the extrapolation's failure, not the preconditioner's).
    const bool judged = !lagged && !secant_start && petsc_->can_fall_back_from_p_multigrid();
    const int budget = lagged ? petsc_fresh_iterations_ + std::clamp(int(petsc_setup_time_ / petsc_iteration_time_), 10, 200)
                       : secant_start ? std::max(200, 5 * petsc_fresh_iterations_)
                       : judged       ? kPMultigridBudget
                                      : 0;
    const auto t0 = std::chrono::steady_clock::now();
    const KrylovOutcome o = petsc_->solve(b, x, tol, budget);
    const double t = petsc_->max_over_ranks(seconds_since(t0));  // every rank takes the same decisions
    stats_.krylov_iterations += o.iterations;
    if (o.iterations > 0) {
      const double per = t / o.iterations;
      petsc_iteration_time_ = petsc_iteration_time_ > 0.0 ? 0.7 * petsc_iteration_time_ + 0.3 * per : per;
    }
    if (options_.verbose)
      std::cerr << "      petsc " << o.iterations << " its, |r|/|b| = " << o.relative_residual << " (" << o.reason << ", "
                << (lagged ? "lagged" : "fresh") << " preconditioner)\n";
    if (o.converged) {
      if (!lagged) {
        petsc_fresh_iterations_ = o.iterations;
      } else {
        petsc_lag_failures_ = 0;
        // Refreshed at the next tangent once its extra iterations cost 3/4 of a set-up (the direct path's rule).
        if ((o.iterations - petsc_fresh_iterations_) * petsc_iteration_time_ > 0.75 * petsc_setup_time_) factor_stale_ = true;
      }
      return true;
    }
    if (!lagged) {
      why = "linear solver: PETSc " + petsc_->description() + " did not converge in " + std::to_string(o.iterations) +
            " iterations (" + o.reason + ", |r|/|b| = " + format_number(o.relative_residual) + ")";
      // The p-multigrid's P1 coarse space locks where nearly incompressible material is confined (Cook's
      // membrane in plane strain at K/G 1e5 in tet10: GMRES stalls at |r|/|b| ~ 1), where BoomerAMG on
      // the P2 block converges in 40–80 iterations (BENCHMARKS.md, "Macro solver on PETSc",
      // Cook's membrane). It takes over from the retry of this step on, whose tangent is filled with its
      // own augmentation (on this tangent, filled with α = 1, BoomerAMG failed as well).
      if (judged && petsc_->fall_back_from_p_multigrid()) {
        factor_valid_ = false;
        note_once("petsc fallback", "linear solver: at t = " + format_number(time_) + " GMRES with the p-multigrid on the displacement block did not converge in " +
                                        std::to_string(o.iterations) + " iterations (" + o.reason +
                                        "); from the retry on, that block takes BoomerAMG on the P2 field (augmentation alpha = 10)");
      }
      return false;
    }
    // The tangent moved too far from the preconditioner's: a new one, and the solve again.
    ++petsc_lag_failures_;
    if (options_.verbose) std::cerr << "      lagged preconditioner failed: rebuild\n";
    petsc_set_operator(true);
  }
}

}  // namespace softhom::fe
