#pragma once
// OpenMP threads that reach a barrier first spin by default (libgomp: until OMP_WAIT_POLICY says
// otherwise). Beside any other load the spinning threads take the cores the working ones need: a 32²
// cell ran 73 s on two threads against 3.3 s on one. libgomp reads the policy once, when it is loaded,
// before main(); the program therefore starts itself again, once, with OMP_WAIT_POLICY=passive when
// the user has not set the variable.

namespace softhom::app {

/// Replaces this process by the same program with the same arguments and OMP_WAIT_POLICY=passive,
/// unless OMP_WAIT_POLICY is set (the user's choice, or this is the second start) or SOFTHOM_REEXEC=0.
/// Returns only when it did not (or could not) start again; the process id stays the same, so MPI
/// launchers and signal senders see one process.
void restart_with_passive_waiting(char** argv);

}  // namespace softhom::app
