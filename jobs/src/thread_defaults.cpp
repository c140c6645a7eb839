// Default thread counts (thread_defaults.hpp).
#include "softhom/jobs/thread_defaults.hpp"

#include <omp.h>

#include <algorithm>
#include <cstdlib>

namespace softhom::jobs {

bool thread_count_given(int count) { return count > 0 || std::getenv("OMP_NUM_THREADS") != nullptr; }

int default_thread_count(std::size_t work_items, std::size_t items_per_thread, int available) {
  const std::size_t wanted = work_items / std::max<std::size_t>(items_per_thread, 1);
  return static_cast<int>(std::clamp<std::size_t>(wanted, 1, static_cast<std::size_t>(std::max(available, 1))));
}

ThreadCountScope::ThreadCountScope(int threads) : before_(omp_get_max_threads()), changed_(threads > 0) {
  if (changed_) omp_set_num_threads(threads);
}

ThreadCountScope::~ThreadCountScope() {
  if (changed_) omp_set_num_threads(before_);
}

}  // namespace softhom::jobs
