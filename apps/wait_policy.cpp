// Passive OpenMP waiting for the program (wait_policy.hpp).
#include "wait_policy.hpp"

#include <unistd.h>

#include <cstdlib>
#include <cstring>

namespace softhom::app {

void restart_with_passive_waiting(char** argv) {
  if (std::getenv("OMP_WAIT_POLICY") != nullptr) return;
  // The second start finds the variable set; this one guards against an environment that drops it.
  if (const char* again = std::getenv("SOFTHOM_REEXEC"); again && std::strcmp(again, "0") == 0) return;
  if (::setenv("OMP_WAIT_POLICY", "passive", 1) != 0 || ::setenv("SOFTHOM_REEXEC", "0", 1) != 0) return;
  ::execv("/proc/self/exe", argv);
  // No /proc (or exec refused): run as started; OpenMP keeps its default policy in this process.
}

}  // namespace softhom::app
