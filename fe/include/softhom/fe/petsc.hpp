#pragma once
// PETSc's life cycle for the petsc linear solver ([solver] linear_solver = "petsc"). PETSc is
// initialised lazily, the first time a PETSc solver is built: with the MPI that softhom started under
// an MPI launcher (softhom/core/mpi.hpp), or PETSc's own one-process start otherwise.

namespace softhom::fe {

/// PetscInitialize on first use; later calls do nothing.
void petsc_initialize();
/// PetscFinalize if PETSc was initialised and not yet finalised. Call before MPI_Finalize (main() does);
/// a process whose MPI PETSc started itself also finalises at exit.
void petsc_finalize();

/// This rank's storage of the petsc solver's matrices (entries allocated × (value + column index)),
/// taken at the first preconditioner set-up of the most recent petsc solver of this process.
struct PetscMatrixBytes {
  double system = 0.0;      ///< the system matrix (with the element pressures for three-field elements)
  double split_copy = 0.0;  ///< the field split's extracted displacement block (0: it uses the block itself)
};
PetscMatrixBytes petsc_last_matrix_bytes();

}  // namespace softhom::fe
