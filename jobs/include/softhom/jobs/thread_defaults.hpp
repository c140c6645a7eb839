#pragma once
// How many OpenMP threads a run uses when the user chose none (no --threads, no threads=, no
// OMP_NUM_THREADS). Threads pay off only when each has enough work between two barriers: on a small
// cell a second thread gains little on an idle machine and loses several-fold on a busy one, where each
// barrier waits for a time slice of the thread that was descheduled (bench/thread_defaults.py).
#include <cstddef>

namespace softhom::jobs {

/// Whether the user chose the thread count: `count` > 0 (--threads, threads=) or OMP_NUM_THREADS set.
bool thread_count_given(int count);

/// Voxels of an FFT cell per thread of its default thread count: a 32² section (1024 voxels) runs on
/// one thread, 64² on two (bench/thread_defaults.py: at 32², 2 threads gain 1.12× on an idle machine
/// and lose 1.6-2× beside a competing 2-thread load; at 64² they gain on both).
inline constexpr std::size_t kVoxelsPerDefaultThread = 2048;

/// Free degrees of freedom of a macro mesh (per MPI rank) per thread of its default thread count: meshes
/// below 32 768 free dofs run on one thread (bench/thread_defaults.py, 2 cores loaded by other work: 1 vs
/// 2 passive threads within 1.2x of each other from 1 152 to 30 188 free dofs, neither ahead throughout;
/// one thread leaves the other core to the machine's other work).
inline constexpr std::size_t kFreeDofsPerDefaultThread = 16384;

/// `work_items` / `items_per_thread` threads, at least 1, at most `available` (the OpenMP default).
int default_thread_count(std::size_t work_items, std::size_t items_per_thread, int available);

/// For its lifetime, `threads` OpenMP threads in this thread (0: unchanged); restores the previous count.
class ThreadCountScope {
 public:
  explicit ThreadCountScope(int threads);
  ~ThreadCountScope();
  ThreadCountScope(const ThreadCountScope&) = delete;
  ThreadCountScope& operator=(const ThreadCountScope&) = delete;

 private:
  int before_ = 0;
  bool changed_ = false;
};

}  // namespace softhom::jobs
