#pragma once
// Cooperative stop on SIGINT / SIGTERM (Ctrl-C, `timeout`, Slurm). The handler only sets a flag; every
// step loop polls stop_requested() between sub-steps (and long Krylov/Newton loops between iterations),
// ends the run with the converged rows, and the command writes a summary that says "interrupted".
namespace softhom {

/// True once SIGINT/SIGTERM arrived or request_stop() was called.
bool stop_requested() noexcept;
/// The signal that asked for the stop (0 when request_stop() was called without one).
int stop_signal() noexcept;
/// Asks every running loop to stop at its next check (async-signal-safe).
void request_stop(int signal = 0) noexcept;
/// Forgets a stop request (tests, and embedding codes that run several jobs in one process).
void clear_stop_request() noexcept;
/// Installs the SIGINT/SIGTERM handlers. A second signal of the same kind after the first ends the
/// process at once with the default action, so a stuck run can still be killed from the keyboard.
void install_stop_handlers();

}  // namespace softhom
