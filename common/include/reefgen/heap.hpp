#pragma once
// The process's heap: freed blocks kept for the next allocation. LibTorch-free (glibc).
namespace reefgen {

// Keeps freed activation and gradient buffers (up to 32 MB each) in the heap
// instead of returning them to the kernel after every step or forward: the
// page faults of re-mapping them were 11 % of a training iteration (perf).
// Call once, before training or inference.
void keep_freed_memory();

// Keeps freed blocks of up to 32 MiB (glibc's largest mmap threshold: every
// image up to 2896² floats) in the heap, and the heap's free top until it
// passes 1 GiB; larger blocks are still mapped and returned when freed, so a
// world's peak memory does not grow. glibc's own thresholds returned a 256²
// island's images to the kernel after each island and faulted them in again
// for the next: ~1,100 page faults and 18 % of `bench generate`'s time in the
// kernel (docs/BENCHMARKS.md). Every reefgen command calls it first.
void keep_freed_images();

}  // namespace reefgen
