// Couplings that follow the configuration (Contribution::couplings_change): at the start of every
// sub-step attempt the contributions that pair surfaces choose their pairing from the converged state,
// and the stiffness pattern follows it. On the factorizing path the CSC pattern, its scatter positions
// and the symbolic analysis are rebuilt; on the petsc path the matrix keeps its preallocation and takes
// the new couplings' entries at its next fill (PETSc allocates them; entries no longer coupled stay, as
// zeros).
#include <chrono>

#include "simulation_impl.hpp"

namespace softhom::fe {
using namespace detail;

Couplings Simulation::Impl::all_couplings() const {
  Couplings all = couplings_;
  for (int g = 0; g < pairing_couplings_.size(); ++g)
    all.add(pairing_couplings_.nodes.data() + pairing_couplings_.offsets[g],
            pairing_couplings_.offsets[g + 1] - pairing_couplings_.offsets[g]);
  return all;
}

void Simulation::Impl::update_pairing() {
  if (!pairing_) return;
  Couplings next;
  const Iterate converged{time_, time_, 0.0, &u_, cavity_pressure_};
  for (std::size_t k = 0; k < contributions_.size(); ++k) {
    const Contribution* c = contributions_[k];
    if (!c->couplings_change()) continue;
    Iterate own = converged;  // the pairing is part of the converged history, rewritten in place
    if (const long off = contribution_state_offset_[k]; off >= 0) {
      own.state_new = contribution_state_old_.data() + off;
      own.state_old = own.state_new;
    }
    c->pair(model_.mesh, own, next);
  }
  if (next == pairing_couplings_) return;
  pairing_couplings_ = std::move(next);
  rebuild_pattern();
}

void Simulation::Impl::rebuild_pattern() {
  const auto t0 = std::chrono::steady_clock::now();
  if (distributed_) {
    petsc_->accept_new_entries(pairing_couplings_);
  } else {
    K_ = build_pattern(model_.mesh, dofs_, all_couplings());
    build_scatter();
    direct_->new_pattern();  // the next factorization analyses the new pattern first
    factor_valid_ = false;   // a factor of the old pattern is no preconditioner of the new matrix's layout
    factor_stale_ = false;
  }
  ++stats_.pattern_rebuilds;
  stats_.pattern_rebuild_time += seconds_since(t0);
}

}  // namespace softhom::fe
