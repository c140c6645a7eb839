#pragma once
// The process's place among MPI ranks, and the rule that keeps softhom one program.
//
// softhom initialises MPI only when an MPI launcher started it (mpirun/mpiexec of Open MPI, srun under
// Slurm, a PMI/PMIx launcher). Started any other way it never calls MPI: no singleton start-up (about
// 0.3 s with Open MPI), and results are those of a one-rank run. Code that communicates asks active()
// first, or uses the helpers below, which fall back to the one-process answer.
#include <mpi.h>

#include <string>

namespace softhom::mpi {

/// True when the environment shows an MPI launcher started this process (Open MPI, PMIx, PMI, Slurm srun
/// with more than one task).
bool launched_by_mpi_launcher();

/// Initialises MPI (MPI_THREAD_FUNNELED: OpenMP threads compute, the main thread communicates) when the
/// process was launched by an MPI launcher and MPI is not yet initialised; finalises what it initialised.
/// One per process, in main().
class Environment {
 public:
  Environment(int& argc, char**& argv);
  ~Environment();
  Environment(const Environment&) = delete;
  Environment& operator=(const Environment&) = delete;

 private:
  bool initialised_here_ = false;
};

/// MPI initialised and not finalised (by Environment, PETSc or a test's main).
bool active();
/// Rank in MPI_COMM_WORLD, 0 when MPI is not active.
int world_rank();
/// Ranks in MPI_COMM_WORLD, 1 when MPI is not active.
int world_size();
/// Host name of this rank (MPI_Get_processor_name, or gethostname without MPI).
std::string processor_name();

/// Ends every rank with `exit_code` (MPI_Abort when more than one rank runs, std::exit otherwise): a rank
/// that cannot go on must not leave the others waiting in a collective.
[[noreturn]] void abort_all(int exit_code);

}  // namespace softhom::mpi
