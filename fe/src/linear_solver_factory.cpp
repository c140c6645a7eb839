// The linear-solver factory of fe::Simulation: the route and preconditioner chosen from the typed
// options (linear_solver.hpp), and the one object that solves (linear_solver_factory.hpp).
#include "linear_solver_factory.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <sstream>
#include <vector>

#include "petsc_solve.hpp"
#include "softhom/fe/solver.hpp"
#include "softhom/materials/errors.hpp"

namespace softhom::fe {

const char* to_string(LinearRoute route) {
  switch (route) {
    case LinearRoute::cholmod: return "cholmod";
    case LinearRoute::umfpack: return "umfpack";
    case LinearRoute::petsc: return "petsc";
  }
  return "?";
}

const char* to_string(Preconditioner preconditioner) {
  switch (preconditioner) {
    case Preconditioner::sparse_factor: return "sparse-factor";
    case Preconditioner::field_split_boomeramg: return "field-split-boomeramg";
    case Preconditioner::field_split_p_multigrid: return "field-split-p-multigrid";
    case Preconditioner::gamg: return "gamg";
    case Preconditioner::lu: return "mumps-lu";
    case Preconditioner::bddc: return "bddc";
    case Preconditioner::petsc_options: return "petsc_options";
  }
  return "?";
}

std::string petsc_option_value(const std::string& options, const std::string& name) {
  std::istringstream in(options);
  std::vector<std::string> tokens;
  for (std::string t; in >> t;) tokens.push_back(t);
  std::string value;
  for (std::size_t k = 0; k < tokens.size(); ++k)
    if (tokens[k] == name) value = k + 1 < tokens.size() && tokens[k + 1][0] != '-' ? tokens[k + 1] : "";
  return value;
}

namespace {

/// The petsc route's preconditioner: the expert options' -pc_type first, then the typed key.
Preconditioner petsc_preconditioner(const NewtonOptions& o, const LinearSystemFacts& f, const std::string& user_pc_type) {
  if (user_pc_type == "bddc") return Preconditioner::bddc;
  if (!user_pc_type.empty()) return Preconditioner::petsc_options;
  switch (o.petsc_preconditioner) {
    case PetscPreconditioner::bddc: return Preconditioner::bddc;
    case PetscPreconditioner::lu: return Preconditioner::lu;
    case PetscPreconditioner::automatic:
      // Under cavity-volume control the tangent at fixed pressure turns singular at the pressure maximum
      // the control passes and indefinite beyond it, and the bordered cavity row needs its solves to
      // 1e-10: the split's AMG stagnates there (the 1 800-dof balloon: GMRES at |r|/|b| = 0.99 after 2 000
      // iterations in its first step), MUMPS's LU takes 30 steps in 4.1 s CPU (BENCHMARKS.md).
      if (f.cavity_control) return Preconditioner::lu;
      [[fallthrough]];
    case PetscPreconditioner::field_split: break;
  }
  if (!f.three_field) return Preconditioner::gamg;
  const bool p_multigrid = f.any_tets && o.petsc_p_multigrid != PMultigrid::off;
  return p_multigrid ? Preconditioner::field_split_p_multigrid : Preconditioner::field_split_boomeramg;
}

}  // namespace

LinearSolverChoice choose_linear_solver(const NewtonOptions& o, const LinearSystemFacts& f) {
  LinearSolverChoice c;
  const SolverKind kind = automatic_solver(o, f.free_dofs, f.quadratic_tets_only, f.cavity_control);
  if (kind != SolverKind::petsc) {
    c.route = kind == SolverKind::umfpack ? LinearRoute::umfpack : LinearRoute::cholmod;
    c.preconditioner = Preconditioner::sparse_factor;
    c.saddle_krylov = o.saddle_krylov && f.three_field;
    c.symmetric_indefinite = c.route == LinearRoute::cholmod && o.symmetric_indefinite;
    return c;
  }
  c.route = LinearRoute::petsc;
  c.petsc_options = o.petsc_options;
  c.user_pc_type = petsc_option_value(o.petsc_options, "-pc_type");
  c.preconditioner = petsc_preconditioner(o, f, c.user_pc_type);
  const bool bddc = c.preconditioner == Preconditioner::bddc;
  // The split of the (u, p) system: by default, or when the expert options ask for it by name.
  c.field_split = c.preconditioner == Preconditioner::field_split_boomeramg ||
                  c.preconditioner == Preconditioner::field_split_p_multigrid || c.preconditioner == Preconditioner::gamg ||
                  c.user_pc_type == "fieldsplit";
  c.p_multigrid = f.any_tets && !bddc && o.petsc_p_multigrid != PMultigrid::off;
  // A displacement solver chosen by the keys or the options is not replaced.
  const bool user_block = o.petsc_p_multigrid != PMultigrid::automatic || o.petsc_augmentation.has_value() ||
                          o.petsc_options.find("-fieldsplit_u_") != std::string::npos;
  c.p_multigrid_fallback = c.p_multigrid && !user_block;
  c.augmentation = o.petsc_augmentation.value_or(c.p_multigrid ? kPMultigridAugmentation : kSplitAugmentation);
  if (c.augmentation < 0.0)
    throw InputError("solver.petsc_augmentation", std::to_string(c.augmentation), "must be >= 0");
  c.nested_matrix = o.petsc_nested_matrix;
  c.current_modes = c.p_multigrid && o.petsc_current_modes;
  c.bddc_flux = bddc && o.bddc_flux;
  return c;
}

SparseDirectSolver::SparseDirectSolver(LinearRoute route, bool symmetric_indefinite)
    : symmetric_indefinite_(symmetric_indefinite && route == LinearRoute::cholmod) {
  if (route == LinearRoute::cholmod) cholesky_ = make_linear_solver(SolverKind::cholmod);
}

double relative_skew(const CscMatrix& A) {
  if (A.mirror.empty()) return std::numeric_limits<double>::infinity();  // no transposes known
  double skew = 0.0, big = 0.0;
  for (long k = 0; k < A.nnz(); ++k) {
    big = std::max(big, std::abs(A.values[k]));
    skew = std::max(skew, std::abs(A.values[k] - A.values[A.mirror[k]]));
  }
  return big > 0.0 ? skew / big : 0.0;
}

void SparseDirectSolver::sum_times() {
  times_ = {};
  for (const LinearSolver* s : {cholesky_.get(), ldlt_.get(), lu_.get()}) {
    if (!s) continue;
    const SolverTimes& t = s->times();
    times_.analysis += t.analysis;
    times_.factorization += t.factorization;
    times_.solve += t.solve;
    times_.factorizations += t.factorizations;
    times_.solves += t.solves;
    times_.flops += t.flops;
    times_.factor_nnz = std::max(times_.factor_nnz, t.factor_nnz);
  }
}

void SparseDirectSolver::begin_step() { indefinite_this_step_ = !cholesky_backoff_.take_chance(); }

void SparseDirectSolver::analyze(const CscMatrix& A) {
  if (!cholesky_now() || cholesky_analyzed_) return;
  cholesky_->analyze(A);
  cholesky_analyzed_ = true;
  sum_times();
}

bool SparseDirectSolver::factorize_with(LinearSolver& s, bool& analyzed, const CscMatrix& A) {
  if (!analyzed) {
    s.analyze(A);
    analyzed = true;
  }
  const double before = s.times().flops;
  const bool ok = s.factorize(A);
  current_ = &s;
  last_flops_ = s.times().flops - before;
  return ok;
}

bool SparseDirectSolver::factorize(const CscMatrix& A) {
  bool ok = false;
  fell_back_ = false;
  if (cholesky_now()) {
    ok = factorize_with(*cholesky_, cholesky_analyzed_, A);
    // Not positive definite (an iterate past a limit point, near a buckling mode, or a Newton iterate off
    // the equilibrium path): an indefinite factorization for the rest of this step; Cholesky is tried
    // again in the next one.
    indefinite_this_step_ = fell_back_ = !ok;
    if (ok) cholesky_backoff_.succeeded();
    else cholesky_backoff_.failed();
  }
  // The symmetric part's LDLᵀ where the skew part is round-off (the check is one pass over the entries);
  // never for the run's first factor, whose singularity check (a mechanism, a disconnected part) needs
  // the pivot ratio that LU reports and MUMPS's LDLᵀ does not.
  if (!ok && symmetric_indefinite_ && factorized_ && relative_skew(A) <= kLdltSkew) {
    if (!ldlt_) ldlt_ = make_symmetric_indefinite_solver();
    ok = factorize_with(*ldlt_, ldlt_analyzed_, A);
  }
  if (!ok) {
    if (!lu_) lu_ = make_linear_solver(SolverKind::umfpack);
    ok = factorize_with(*lu_, lu_analyzed_, A);
  }
  factorized_ = factorized_ || ok;
  sum_times();
  return ok;
}

std::string SparseDirectSolver::description() const {
  std::string out;
  const std::pair<const LinearSolver*, const char*> parts[] = {{cholesky_.get(), "cholmod"}, {ldlt_.get(), "mumps-ldlt"}, {lu_.get(), "umfpack"}};
  for (const auto& [s, name] : parts) {
    if (!s || s->times().factorizations == 0) continue;
    if (!out.empty()) out += " + ";
    out += name;
    out += " " + std::to_string(s->times().factorizations);
  }
  return out.empty() ? to_string(kind()) : out;
}

void SparseDirectSolver::solve(const std::vector<double>& b, std::vector<double>& x) {
  current_->solve(b, x);
  sum_times();
}

SolverKind SparseDirectSolver::kind() const {
  if (current_) return current_->kind();
  return cholesky_ ? SolverKind::cholmod : SolverKind::umfpack;
}

double SparseDirectSolver::predicted_flops() const { return cholesky_now() ? cholesky_->predicted_flops() : 0.0; }

double SparseDirectSolver::reciprocal_condition() const { return current_ ? current_->reciprocal_condition() : 0.0; }

std::unique_ptr<LinearSolver> make_macro_linear_solver(const LinearSolverChoice& choice, const Mesh& mesh, const DofMap& dofs) {
  if (choice.route == LinearRoute::petsc) return std::make_unique<PetscSolver>(mesh, dofs, choice);
  return std::make_unique<SparseDirectSolver>(choice.route, choice.symmetric_indefinite);
}

}  // namespace softhom::fe
