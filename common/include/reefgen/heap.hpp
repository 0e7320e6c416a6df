#pragma once
// The process's heap for the network's buffers. LibTorch-free (glibc).
namespace reefgen {

// Keeps freed activation and gradient buffers (up to 32 MB each) in the heap
// instead of returning them to the kernel after every step or forward: the
// page faults of re-mapping them were 11 % of a training iteration (perf).
// Call once, before training or inference.
void keep_freed_memory();

}  // namespace reefgen
