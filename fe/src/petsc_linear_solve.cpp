// The petsc path of fe::Simulation's linear solves (linear_solve.cpp hands over when the petsc solver
// is in use): no lagged factors here, a fresh multigrid hierarchy for every new tangent, GMRES to the
// forcing-term tolerance of the Newton iteration.
#include <iostream>

#include "simulation_impl.hpp"
#include "softhom/materials/errors.hpp"

namespace softhom::fe {
using namespace detail;

bool Simulation::Impl::petsc_linear_solve(const std::vector<double>& b, std::vector<double>& x, double tol,
                                          std::string& why) {
  x.assign(dofs_.num_free, 0.0);
  if (norm(b) == 0.0) return true;
  if (factor_version_ != k_version_ || !factor_valid_) {
    // Three-field elements: the uncondensed (u, p_e) system with its field split (petsc_solve.cpp).
    if (!sad_elem_.empty()) {
      if (first_factorization_) petsc_->set_mixed(sad_off_, sad_eq_);
      saddle_current();
      petsc_->set_mixed_tangent(sad_db_, sad_cb_);
    }
    petsc_->factorize(K_);
    factor_valid_ = true;
    factor_version_ = k_version_;
    if (first_factorization_)
      note_once("petsc", "linear solver: petsc (" + petsc_->description() + ", rigid-body near-nullspace) on " +
                             std::to_string(petsc_->ranks()) + " MPI rank(s)");
    first_factorization_ = false;
  }
  const KrylovOutcome o = petsc_->solve(b, x, tol);
  stats_.krylov_iterations += o.iterations;
  if (options_.verbose)
    std::cerr << "      petsc " << o.iterations << " its, |r|/|b| = " << o.relative_residual << " (" << o.reason << ")\n";
  if (!o.converged) {
    why = "linear solver: PETSc " + petsc_->description() + " did not converge in " + std::to_string(o.iterations) +
          " iterations (" + o.reason + ", |r|/|b| = " + format_number(o.relative_residual) + ")";
    return false;
  }
  return true;
}

}  // namespace softhom::fe
