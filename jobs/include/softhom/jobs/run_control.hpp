#pragma once
// How a job ends a run early (a stop request: a signal, or Ctrl-C in Python) and reports progress.
#include <unistd.h>

#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <iostream>
#include <string>
#include <thread>
#include <vector>

#include "softhom/core/input_error.hpp"
#include "softhom/io/summary.hpp"
#include "softhom/materials/interrupt.hpp"

namespace softhom::jobs {

/// Thrown from a step callback when a stop was requested: the solver unwinds at once and the command
/// writes what converged (the solver loops also poll stop_requested() inside a step).
struct RunInterrupted : std::exception {
  const char* what() const noexcept override { return "interrupted"; }
};

/// Test hook: SOFTHOM_TEST_SIGTERM_AFTER_STEPS=N raises a real SIGTERM in this process once N output
/// steps have converged, so that the interrupt path is tested deterministically.
inline void raise_test_signal_after(std::size_t steps_done) {
  static const long after = [] {
    const char* v = std::getenv("SOFTHOM_TEST_SIGTERM_AFTER_STEPS");
    return v ? std::atol(v) : -1L;
  }();
  if (after >= 0 && steps_done >= static_cast<std::size_t>(after) && !stop_requested()) std::raise(SIGTERM);
}

/// Called after each converged output step has been recorded: throws RunInterrupted on a stop request.
inline void stop_point(std::size_t steps_done) {
  raise_test_signal_after(steps_done);
  if (stop_requested()) throw RunInterrupted{};
}

/// Most threads (or parallel jobs) a run may ask for: 4 per hardware thread. More only oversubscribe
/// the cores (OpenMP barriers spin) and each OpenMP thread reserves a stack: a huge count exhausts
/// memory, or crashes the thread start, before any work is done.
inline int max_parallelism() {
  const unsigned hw = std::thread::hardware_concurrency();
  return 4 * static_cast<int>(hw > 0 ? hw : 1u);
}

/// Why `count` threads are too many or negative ("" when allowed; 0 means a default).
inline std::string parallelism_problem(long count) {
  const int max = max_parallelism();
  if (count >= 0 && count <= max) return {};
  return std::to_string(count) + " is out of range: 0 to " + std::to_string(max) + " (4 x the " +
         std::to_string(max / 4) + " hardware threads of this machine)";
}

/// The thread count a run asks for, `count` given as `field` ("--threads", "threads"): InputError beyond
/// the bound. With 0 (OpenMP's default) the default comes from OMP_NUM_THREADS, which is bounded the same.
inline void check_thread_count(long count, const std::string& field) {
  if (std::string p = parallelism_problem(count); !p.empty()) throw InputError(field, std::to_string(count), p);
  if (count != 0) return;
  // OpenMP reads the first entry of a list ("8,2"); text it cannot read it ignores, and so does this.
  const char* env = std::getenv("OMP_NUM_THREADS");
  char* end = nullptr;
  const long n = env ? std::strtol(env, &end, 10) : 0;
  if (env && end != env && !parallelism_problem(n).empty())
    throw InputError("OMP_NUM_THREADS", env, parallelism_problem(n) + "; set it lower or give " + field);
}

/// Input warnings (plausibility) on stderr, one line each, unless quiet.
inline void print_warnings(const std::string& tag, const std::vector<std::string>& warnings, bool quiet) {
  if (quiet) return;
  for (const auto& w : warnings) std::cerr << tag << ": warning: " << w << "\n";
}

/// "interrupted by SIGTERM" (or "interrupted" without a signal).
inline std::string interruption_message() {
  return stop_signal() > 0 ? "interrupted by " + io::signal_name(stop_signal()) : std::string("interrupted");
}

/// A computed value in a progress line: 6 significant digits (the row in response.csv has them all).
inline std::string progress_number(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", x);
  return buf;
}

/// Progress lines on stderr: on a terminal one line rewritten in place (\r); in a file or a pipe
/// (Slurm logs, `2> log`) one plain line per update, so logs stay line-oriented.
class Progress {
 public:
  explicit Progress(bool quiet) : quiet_(quiet), tty_(::isatty(STDERR_FILENO) == 1) {}
  ~Progress() { finish(); }
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  void update(const std::string& line) {
    if (quiet_) return;
    if (tty_) {
      std::cerr << '\r' << line << "\033[K" << std::flush;  // erase what a longer previous line left
      open_ = true;
    } else {
      std::cerr << line << '\n';
    }
  }
  /// Ends an in-place line (call before printing anything else).
  void finish() {
    if (open_) std::cerr << '\n' << std::flush;
    open_ = false;
  }
  bool quiet() const { return quiet_; }

 private:
  bool quiet_;
  bool tty_;
  bool open_ = false;
};

}  // namespace softhom::jobs
