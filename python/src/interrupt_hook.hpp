#pragma once
// Ctrl-C during a long call: Python's SIGINT handler only sets a flag that
// the interpreter reads when it runs again, so a C++ call of half a minute
// (infer at 8192²) held Ctrl-C until it returned. reefgen's long loops call
// check_interrupt() between their steps (reefgen/interrupt.hpp); this hook
// takes the GIL, lets Python run its signal handlers, and stops the work
// with reefgen::Interrupted, which the module raises as KeyboardInterrupt.
#include <pybind11/pybind11.h>

#include "reefgen/interrupt.hpp"

namespace reefgen::python {

constexpr const char* kStoppedBetweenSteps = "reefgen: stopped between steps by Ctrl-C";

inline void interrupt_hook() {
  pybind11::gil_scoped_acquire gil;
  if (PyErr_CheckSignals() != 0) {
    PyErr_Clear();  // raised again, as KeyboardInterrupt, where the call returns to Python
    throw Interrupted();
  }
}

// Installs the hook and raises Interrupted as KeyboardInterrupt. Registered
// after the module's other translators: pybind11 tries the last one first,
// and Interrupted is also a reefgen::Error.
inline void install_interrupt_hook() {
  set_interrupt_hook(&interrupt_hook);
  pybind11::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const Interrupted&) {
      // Said, so that a caller (and the test) can tell a call stopped between
      // its steps from one whose Ctrl-C was only seen after it returned.
      PyErr_SetString(PyExc_KeyboardInterrupt, kStoppedBetweenSteps);
    }
  });
}

}  // namespace reefgen::python
