#include "reefgen/interrupt.hpp"

#include <atomic>

namespace reefgen {

namespace {
std::atomic<InterruptHook> g_hook{nullptr};
}

void set_interrupt_hook(InterruptHook hook) { g_hook.store(hook); }

void check_interrupt() {
  if (const InterruptHook hook = g_hook.load()) hook();
}

}  // namespace reefgen
