#pragma once
// The messages of a campaign over MPI (sweep_mpi.cpp): tags, and the byte layout of a chain
// assignment. Finished cases travel as encode_case_record() bytes (campaign.hpp).
//
// Protocol (rank 0 schedules and writes; every other rank is a worker):
//   worker → 0  kRequest      (empty)            a job slot of the worker is free
//   0 → worker  kAssign       int[]              a chain: {chain, last, n, members[n], store[n]}, or {-1}: no more work
//   worker → 0  kRecord       bytes              a finished case to store
//   worker → 0  kChainDone    int                the worker finished (or abandoned) that chain
//   0 → worker  kStop         (empty)            stop after the case in flight (signal or write failure on rank 0)
//   worker → 0  kFinished     long               the worker's last message: Newton iterations it computed
// Messages between two ranks arrive in the order sent (MPI's non-overtaking rule; rank 0 receives
// whatever MPI_Probe finds first), so a chain's records always precede its kChainDone.
#include <vector>

#include "sweep_internal.hpp"

namespace softhom::studies::sweep_detail {

enum SweepTag : int { kRequest = 7101, kAssign, kRecord, kChainDone, kStop, kFinished };

/// {index, last, n, members..., store...}
std::vector<int> encode_assignment(int index, const Chain& chain);
/// Inverse of encode_assignment; std::runtime_error on a malformed message.
Chain decode_assignment(const std::vector<int>& message, int& index);

}  // namespace softhom::studies::sweep_detail
