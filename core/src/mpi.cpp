#include "softhom/core/mpi.hpp"

#include <unistd.h>

#include <array>
#include <cstdlib>
#include <string_view>

namespace softhom::mpi {

namespace {

bool has_env(const char* name) {
  const char* v = std::getenv(name);
  return v != nullptr && *v != '\0';
}

int env_int(const char* name) {
  const char* v = std::getenv(name);
  return v ? std::atoi(v) : 0;
}

}  // namespace

bool launched_by_mpi_launcher() {
  // Open MPI's mpirun, a PMIx server (Open MPI 4/5, Slurm with --mpi=pmix), Hydra/MPICH's PMI.
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_RANK", "PMI_SIZE"})
    if (has_env(name)) return true;
  // srun without an MPI plugin still gives every task its rank; one task is a plain run.
  return env_int("SLURM_NTASKS") > 1 && has_env("SLURM_PROCID") && has_env("SLURM_STEP_ID");
}

Environment::Environment(int& argc, char**& argv) {
  if (!launched_by_mpi_launcher()) return;
  int initialised = 0;
  MPI_Initialized(&initialised);
  if (initialised) return;
  int provided = 0;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
  initialised_here_ = true;
  // Errors are checked where they matter; a failed collective aborts the job rather than hanging it.
  MPI_Comm_set_errhandler(MPI_COMM_WORLD, MPI_ERRORS_ARE_FATAL);
}

Environment::~Environment() {
  if (!initialised_here_) return;
  int finalised = 0;
  MPI_Finalized(&finalised);
  if (!finalised) MPI_Finalize();
}

bool active() {
  int initialised = 0, finalised = 0;
  MPI_Initialized(&initialised);
  if (!initialised) return false;
  MPI_Finalized(&finalised);
  return !finalised;
}

int world_rank() {
  if (!active()) return 0;
  int rank = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  return rank;
}

int world_size() {
  if (!active()) return 1;
  int size = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  return size;
}

std::string processor_name() {
  if (active()) {
    std::array<char, MPI_MAX_PROCESSOR_NAME> name{};
    int length = 0;
    MPI_Get_processor_name(name.data(), &length);
    return std::string(name.data(), std::size_t(length));
  }
  std::array<char, 256> name{};
  if (gethostname(name.data(), name.size() - 1) != 0) return "unknown";
  return std::string(name.data());
}

void abort_all(int exit_code) {
  if (active() && world_size() > 1) MPI_Abort(MPI_COMM_WORLD, exit_code);
  std::exit(exit_code);
}

}  // namespace softhom::mpi
