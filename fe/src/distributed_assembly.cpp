// Distributed assembly of fe::Simulation (the petsc path, on one process or under MPI): an element
// partition, each rank's elements straight into the PETSc matrix (petsc_solve.cpp), and the sums over
// the ranks that keep the replicated Newton iteration identical on every rank.
#include <mpi.h>

#include <algorithm>
#include <climits>
#include <cstdio>
#include <string>

#include "partition.hpp"
#include "simulation_impl.hpp"
#include "softhom/core/mpi.hpp"

namespace softhom::fe {

bool Simulation::Impl::petsc_distributed() const {
  const SolverKind kind = resolved_solver();
  // Also the one-process program (one part): the elements go straight into PETSc's matrix, so neither
  // the CSC tangent with its transposed positions nor a copy of it exists on the petsc path.
  return kind == SolverKind::petsc;
}

void Simulation::Impl::build_partition() {
  distributed_ = petsc_distributed();
  if (!distributed_) return;
  const Mesh& mesh = model_.mesh;
  // Coordinate bisection: the structures are slender (tubes, plates, shells) and their elements of
  // nearly equal cost, so equal counts in compact slabs balance the work with few interface nodes
  // (BENCHMARKS.md, "Distributed assembly").
  mpi_rank_ = mpi::world_rank();
  mpi_ranks_ = mpi::world_size();
  if (mpi_rank_ != 0) options_.verbose = false;  // every rank runs the same Newton iteration: one log
  element_owner_ = partition_elements_rcb(mesh, mpi_ranks_);
  owned_elements_.clear();
  for (int e = 0; e < mesh.num_elements(); ++e)
    if (element_owner_[e] == mpi_rank_) owned_elements_.push_back(e);
}

void Simulation::Impl::build_distributed_system() {
  if (!distributed_) return;
  const Mesh& mesh = model_.mesh;
  const std::vector<int> node_owner = node_owners(mesh, element_owner_);
  petsc_->distribute(element_owner_, node_owner, sad_elem_, couplings_);
  // The partition's quality: nodes whose elements lie on more than one rank (their rows receive
  // off-rank contributions through PETSc's stash).
  std::vector<int> lowest(mesh.num_nodes(), 1 << 30), highest(mesh.num_nodes(), -1);
  for (int e = 0; e < mesh.num_elements(); ++e) {
    const int* en = mesh.element_nodes(e);
    for (int a = 0; a < mesh.element_size(e); ++a) {
      lowest[en[a]] = std::min(lowest[en[a]], element_owner_[e]);
      highest[en[a]] = std::max(highest[en[a]], element_owner_[e]);
    }
  }
  int shared = 0;
  for (int n = 0; n < mesh.num_nodes(); ++n) shared += highest[n] > lowest[n];
  const int ranks = mpi::world_size();
  const int ne = mesh.num_elements();
  char percent[32];
  std::snprintf(percent, sizeof percent, "%.2f", 100.0 * shared / std::max(1, mesh.num_nodes()));
  note_once("distributed assembly", "distributed assembly over " + std::to_string(ranks) + " rank(s): " +
                                        std::to_string(ne / ranks) + (ne % ranks ? "–" + std::to_string(ne / ranks + 1) : "") +
                                        " elements per rank (coordinate bisection), " + std::to_string(shared) +
                                        " nodes shared between ranks (" +
                                        percent + " %)");
}

namespace {
void sum_in_place(std::vector<double>& v) {
  if (!v.empty()) MPI_Allreduce(MPI_IN_PLACE, v.data(), int(v.size()), MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
}
}  // namespace

void Simulation::Impl::reduce_element_sums(Assembly& out) const {
  if (!distributed_ || mpi_ranks_ == 1) return;
  // Every rank then holds the same sums (MPI's reductions give one result to all ranks), so the norms,
  // the convergence test, the line search and the cavity row agree bit for bit across the ranks.
  sum_in_place(out.R);
  sum_in_place(out.R_true);
  sum_in_place(out.R_u);
  sum_in_place(out.dirichlet_rhs);
  // The lowest failed element over the ranks, with its status (one element number on every rank).
  struct {
    int element, status;
  } f{out.failed_element >= 0 ? out.failed_element : INT_MAX, int(out.status)};
  MPI_Allreduce(MPI_IN_PLACE, &f, 1, MPI_2INT, MPI_MINLOC, MPI_COMM_WORLD);
  out.failed_element = f.element == INT_MAX ? -1 : f.element;
  out.status = f.element == INT_MAX ? MaterialStatus::ok : MaterialStatus(f.status);
}

void Simulation::Impl::reduce_cauchy(std::vector<double>& cauchy) const {
  if (distributed_ && mpi_ranks_ > 1) sum_in_place(cauchy);  // the other ranks' elements hold zeros
}

double Simulation::Impl::sum_over_ranks(double v) const {
  if (distributed_ && mpi_ranks_ > 1) MPI_Allreduce(MPI_IN_PLACE, &v, 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
  return v;
}

}  // namespace softhom::fe
