#pragma once
// The PETSc linear solver of fe::Simulation: right-preconditioned GMRES with smoothed-aggregation
// algebraic multigrid (GAMG) and the rigid-body modes of the mesh as its near-nullspace, on a
// distributed (MPIAIJ) copy of the tangent. No PETSc type appears here, so the rest of fe/ compiles
// without PETSc's headers.
//
// Layout: the PETSc system has every dof of the mesh (3 per node, node-major, block size 3), the
// prescribed ones as identity rows scaled to the mean free diagonal, so the rigid-body modes stay
// whole blocks for the aggregation. Rank r owns a contiguous range of nodes (the generated meshes are
// numbered along the structure, so a range is a compact slab). The mesh, the Newton iteration and the
// assembly are replicated on every rank; each rank copies its owned rows into the distributed matrix,
// and the solution is gathered to every rank.
#include <memory>
#include <string>
#include <vector>

#include "softhom/fe/mesh.hpp"
#include "softhom/fe/petsc.hpp"
#include "softhom/fe/sparse.hpp"

namespace softhom::fe {

/// Outcome of one Krylov solve.
struct KrylovOutcome {
  bool converged = false;
  int iterations = 0;
  double relative_residual = 0.0;  ///< ‖b − A x‖ / ‖b‖ (unpreconditioned: right preconditioning)
  std::string reason;              ///< PETSc's converged/diverged reason
};

class PetscSolver final : public LinearSolver {
 public:
  /// `options`: entries for PETSc's options database (they override the defaults above).
  PetscSolver(const Mesh& mesh, const DofMap& dofs, const std::string& options);
  ~PetscSolver() override;
  PetscSolver(const PetscSolver&) = delete;
  PetscSolver& operator=(const PetscSolver&) = delete;

  /// Three-field elements: the system is solved uncondensed in (u, p_e) (see petsc_solve.cpp), one
  /// pressure unknown per mixed element k with free equations eq[off[k] .. off[k+1]) (−1: prescribed).
  /// Before analyze.
  void set_mixed(const std::vector<int>& off, const std::vector<int>& eq);
  /// The element data of the next factorize: d_k = ∂θ_k/∂u (at off[k] ..) and c_k = V_k U″(θ_k).
  void set_mixed_tangent(const std::vector<double>& d, const std::vector<double>& c);
  /// Distributed matrix with the pattern of A (free dofs) plus the identity rows; near-nullspace.
  void analyze(const CscMatrix& A) override;
  /// Copies the values of A into the distributed matrix; the preconditioner is rebuilt at the next solve.
  bool factorize(const CscMatrix& A) override;
  /// Solve to relative residual 1e-12.
  void solve(const std::vector<double>& b, std::vector<double>& x) override;
  /// x = A⁻¹ b on the free dofs (replicated on every rank) to relative residual `rtol` (or the tighter
  /// -ksp_rtol of the options).
  KrylovOutcome solve(const std::vector<double>& b, std::vector<double>& x, double rtol);
  SolverKind kind() const override { return SolverKind::petsc; }
  double reciprocal_condition() const override { return 1.0; }
  /// Ranks sharing the system.
  int ranks() const;
  /// The Krylov method and preconditioner in use, e.g. "gmres + gamg".
  std::string description() const;

 private:
  struct Data;
  std::unique_ptr<Data> d_;
};

}  // namespace softhom::fe
