#pragma once
// The PETSc linear solver of fe::Simulation (the petsc route of linear_solver.hpp): right-preconditioned
// GMRES on a distributed copy of the tangent, with the preconditioner of the route's choice (the (u, p)
// field split, GAMG with the rigid-body modes, MUMPS's LU, BDDC, or the expert options' own). No PETSc
// type appears here, so the rest of fe/ compiles without PETSc's headers.
//
// Layout (distribute): each rank adds its own elements' matrices, rows numbered rank by rank along an
// element partition; every dof of the mesh has a row (3 per node, node-major, block size 3), the
// prescribed ones as identity rows scaled to the mean free diagonal, so the rigid-body modes stay whole
// blocks for the aggregation. The Newton iteration is replicated on every rank, and the solution is
// gathered to every rank.
#include <memory>
#include <string>
#include <vector>

#include "softhom/fe/contribution.hpp"
#include "softhom/fe/linear_solver.hpp"
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
  /// The petsc route of `choice` (its preconditioner and settings; choice.petsc_options go into PETSc's
  /// options database over the defaults).
  PetscSolver(const Mesh& mesh, const DofMap& dofs, const LinearSolverChoice& choice);
  ~PetscSolver() override;
  PetscSolver(const PetscSolver&) = delete;
  PetscSolver& operator=(const PetscSolver&) = delete;

  /// Not used: the system is laid out by distribute and filled by the element loop (throws).
  void analyze(const CscMatrix& A) override;
  /// Builds the preconditioner of the tangent the element loop filled (its seconds:
  /// times().factorization); A is not read.
  bool factorize(const CscMatrix& A) override;
  /// Keeps the preconditioner of an earlier tangent for the one the element loop filled: GMRES then
  /// solves this tangent with the lagged one.
  void update_operator();
  /// The displacement of the next tangent to be factorized (the whole mesh vector, replicated): a coarse
  /// solver of the p-multigrid that reads rigid-body modes (GAMG) gets those of the current vertex
  /// positions at that set-up (unless LinearSolverChoice::current_modes is off: the reference ones throughout).
  void set_displacement(const std::vector<double>& u);
  /// Solve to relative residual 1e-12.
  void solve(const std::vector<double>& b, std::vector<double>& x) override;
  /// x = A⁻¹ b on the free dofs (replicated on every rank) to relative residual `rtol` (or the tighter
  /// -ksp_rtol of the options) in at most `max_iterations` (0: the options' limit).
  KrylovOutcome solve(const std::vector<double>& b, std::vector<double>& x, double rtol, int max_iterations = 0);
  SolverKind kind() const override { return SolverKind::petsc; }
  double reciprocal_condition() const override { return 1.0; }
  /// The layout of the distributed assembly (on one process too; before the first fill): rank r
  /// fills only the entries of the elements it owns (`element_owner`) and owns the rows of the nodes
  /// of `node_owner` r, numbered rank by rank (then the element pressures of its elements in
  /// `mixed_elements`, the three-field ones). Creates the matrix, preallocated per rank from the mesh,
  /// and the Krylov solver. Under BDDC the matrix is a MATIS of the condensed displacement
  /// system instead (no pressure rows), rank r's subdomain the elements it owns (petsc_subdomains.hpp).
  /// `couplings`: node groups beyond the elements (the model's contributions) in the preallocation.
  void distribute(const std::vector<int>& element_owner, const std::vector<int>& node_owner,
                  const std::vector<int>& mixed_elements, const Couplings& couplings);
  /// The couplings of contributions that changed them (a moving contact set): the next fill goes
  /// through MatSetValues and enters every pair of their free dofs (zeros where nothing is added), which
  /// PETSc allocates beyond the preallocation; entries of earlier couplings stay (as zeros).
  void accept_new_entries(const Couplings& couplings);
  /// One tangent into the distributed matrix (every rank, collective at end_fill): begin_fill, then
  /// add_element for the owned elements and add_entry for the loads, then end_fill.
  void begin_fill();
  /// Element e's matrix Ke (3·nn dofs of `nodes`, column-major) on its free dofs. A three-field
  /// element (d = ∂θ_e/∂u, c = V_e U″(θ_e); d null otherwise) enters uncondensed: Ke − c d dᵀ on u, its
  /// pressure column d/|d| and its row c|d| dᵀ, −1 (the layout of the comment in petsc_solve.cpp);
  /// with the augmented split the part γ of c it keeps on u is added at end_fill. Under BDDC Ke enters
  /// whole (condensed) into the subdomain's matrix, and `volume` V_e d = ∂v_e/∂u into the flux of the
  /// subdomain's faces (set_bddc_constraints).
  void add_element(int e, int nn, const int* nodes, const double* Ke, const double* d, double c, double volume);
  /// Whether add_element may run concurrently for elements that share no node (one process, a fill of
  /// the final pattern straight into the matrix's values); otherwise one call at a time.
  bool concurrent_fill() const;
  /// K(row_dof, col_dof) += v for free mesh dofs, kept only on the rank owning the row (every rank
  /// passes the same entries).
  void add_entry(int row_dof, int col_dof, double v);
  /// The prescribed rows' identity (scaled to the mean free diagonal of the first tangent) and the
  /// assembly of the off-rank contributions.
  void end_fill();
  /// Ranks sharing the system.
  int ranks() const;
  /// The largest of `value` over the ranks (collective): decisions taken from measured times must be
  /// the same on every rank, or the ranks part ways at the next collective set-up.
  double max_over_ranks(double value) const;
  /// The Krylov method and preconditioner in use, e.g. "gmres + gamg".
  std::string description() const;
  /// What the preconditioner is given beyond the matrix: the rigid-body near-nullspace, or BDDC's
  /// constraints on edges and faces.
  std::string near_nullspace() const;
  /// The p-multigrid's P2 smoother works on the 3 × 3 nodal blocks (choose_fine_smoother), and the
  /// nodal block spread of the tangent that made it so.
  bool anisotropic_smoother() const;
  double block_spread() const;
  /// After a GMRES failure with the default p-multigrid on the displacement block: BoomerAMG on the P2
  /// block itself (and α = 10 from the next fill) for the rest of the run, set up at the next
  /// factorize. False when there is nothing to fall back from (no p-multigrid in use, already fallen
  /// back, or the user's options chose the displacement block's solver). Collective.
  bool fall_back_from_p_multigrid();
  /// Whether fall_back_from_p_multigrid() would act: the default p-multigrid is in use.
  bool can_fall_back_from_p_multigrid() const;

 private:
  struct Data;
  std::unique_ptr<Data> d_;
  /// The choice's settings and PETSc's options database (its defaults under the expert options).
  void apply_choice(const LinearSolverChoice& choice);
  /// Matrix (with Data::dnz, onz), vectors, near-nullspace and Krylov solver of the layout in Data.
  void create_system();
  /// The p-multigrid: the interpolation of the displacement block's two-level multigrid, once the field
  /// split has set up its sub-solvers (petsc_p_multigrid.hpp).
  void attach_p_multigrid();
  /// The P2 level's smoother from the tangent's nodal block spread (unless the options set it): one
  /// Chebyshev sweep on the diagonal, or, once a tangent is anisotropic, two on the 3 × 3 nodal blocks.
  void choose_fine_smoother();
  /// The coarse level's near-nullspace: the rigid-body modes of its vertices at `coords` (x y z per
  /// owned vertex), with a fresh coarse preconditioner that will read them at its next set-up.
  void set_coarse_modes(std::vector<double>& coords);
  /// The augmented split of the owned three-field elements once diag(A) is assembled (end_fill of a
  /// fill without the previous diag(A): the first one).
  void finish_augmented_split();
  /// BDDC's primal constraints for this fill: the near-nullspace of the rigid-body modes and the faces'
  /// volume fluxes.
  void set_bddc_constraints();
  /// end_fill of a fill that took γ from the previous diag(A): the Schur diagonal's assembly, and this
  /// tangent's diag(A) without its γ terms kept for the next fill.
  void finish_lagged_augmentation();
  /// diag(A) (with `without_gamma`, less Data::gamma_diagonal) on every rank and its mean magnitude
  /// over the free dofs, kept as Data::lagged_diagonal and lagged_mean (collective).
  void keep_diagonal(bool without_gamma);
  /// The bytes of SolverTimes: the system matrix and the field split's displacement block.
  void account_matrices();
  /// Mean |diag(A)| (with `without_gamma`, of diag(A) less Data::gamma_diagonal) over the free mesh
  /// dofs of all ranks (collective); with `gather`, that whole diagonal is also left on every rank in
  /// Data::all.
  double mean_free_diagonal(bool gather, bool without_gamma = false);
};

}  // namespace softhom::fe
