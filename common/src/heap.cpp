#include "reefgen/heap.hpp"

#include <malloc.h>

namespace reefgen {

void keep_freed_memory() {
  mallopt(M_MMAP_THRESHOLD, 32 << 20);
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
  // 32 MiB is glibc's largest mmap threshold, and ngf-64 nets have 32 MiB
  // weights and gradients: without this each step would map, fault in and
  // unmap them afresh.
  mallopt(M_MMAP_MAX, 0);
}

}  // namespace reefgen
