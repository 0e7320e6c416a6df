#pragma once
// A stop requested from outside a long computation (Ctrl-C in Python, where
// the signal only sets a flag that the interpreter reads when it runs):
// long loops call check_interrupt() between their steps, which runs the
// hook a host installed (none by default: the command line's signal
// handlers end the process themselves). The hook throws Interrupted to stop.
#include "reefgen/error.hpp"

namespace reefgen {

// Thrown by an interrupt hook: the work was stopped on request.
struct Interrupted : Error {
  Interrupted() : Error("interrupted") {}
};

using InterruptHook = void (*)();
// Installs `hook` (nullptr: none). Not for use while a computation runs.
void set_interrupt_hook(InterruptHook hook);
// Runs the installed hook, if any: call between the steps of long work, on
// the thread that started it.
void check_interrupt();

}  // namespace reefgen
