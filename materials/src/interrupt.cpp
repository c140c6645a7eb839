#include "softhom/materials/interrupt.hpp"

#include <atomic>
#include <csignal>

namespace softhom {
namespace {

std::atomic<int> requested_signal{-1};  // -1: no stop requested

extern "C" void on_stop_signal(int signal) {
  int expected = -1;
  if (!requested_signal.compare_exchange_strong(expected, signal)) {
    // Second signal: give the user back the default behaviour (terminate now).
    std::signal(signal, SIG_DFL);
    std::raise(signal);
  }
}

}  // namespace

bool stop_requested() noexcept { return requested_signal.load(std::memory_order_relaxed) >= 0; }
int stop_signal() noexcept {
  const int s = requested_signal.load(std::memory_order_relaxed);
  return s > 0 ? s : 0;
}
void request_stop(int signal) noexcept { requested_signal.store(signal < 0 ? 0 : signal); }
void clear_stop_request() noexcept { requested_signal.store(-1); }

void install_stop_handlers() {
  struct sigaction action {};
  action.sa_handler = on_stop_signal;
  sigemptyset(&action.sa_mask);
  action.sa_flags = 0;  // no SA_RESTART: a blocking read returns EINTR and the loop sees the flag
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
}

}  // namespace softhom
