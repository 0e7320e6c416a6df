#include "reefgen/heap.hpp"

#include <malloc.h>

namespace reefgen {

void keep_freed_memory() {
  keep_freed_images();
  // 32 MiB is glibc's largest mmap threshold, and ngf-64 nets have 32 MiB
  // weights and gradients: without this each step would map, fault in and
  // unmap them afresh.
  mallopt(M_MMAP_MAX, 0);
}

// A block is mapped above kMapAboveBytes; the heap's top is trimmed past kTrimAboveBytes.
constexpr int kMapAboveBytes = 32 << 20, kTrimAboveBytes = 1 << 30;
void keep_freed_images() {
  mallopt(M_MMAP_THRESHOLD, kMapAboveBytes);
  mallopt(M_TRIM_THRESHOLD, kTrimAboveBytes);
}

}  // namespace reefgen
