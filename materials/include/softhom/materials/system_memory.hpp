#pragma once
// How much memory this process may still allocate: the one system query behind every "refuse before
// allocating" check (FFT grids, FE RVE meshes, macro meshes), so that an oversized problem ends in an
// input error naming its field instead of std::bad_alloc or a solver library's failure.
#include <algorithm>
#include <cstddef>
#include <fstream>
#include <string>

namespace softhom {

/// MemAvailable of /proc/meminfo, lowered to the cgroup (v2) limit minus its usage when one is set
/// (batch schedulers and containers). 0 when unknown (then nothing is refused).
inline std::size_t available_memory_bytes() {
  std::size_t avail = 0;
  {
    std::ifstream in("/proc/meminfo");
    std::string key, unit;
    std::size_t kib = 0;
    while (in >> key >> kib >> unit)
      if (key == "MemAvailable:") {
        avail = kib * 1024;
        break;
      }
  }
  std::ifstream max_in("/sys/fs/cgroup/memory.max"), cur_in("/sys/fs/cgroup/memory.current");
  std::string max_s;
  std::size_t cur = 0;
  if (max_in >> max_s && max_s != "max" && cur_in >> cur) {
    const std::size_t limit = std::stoull(max_s);
    const std::size_t room = limit > cur ? limit - cur : 0;
    avail = avail == 0 ? room : std::min(avail, room);
  }
  return avail;
}

}  // namespace softhom
