#pragma once
// What every command that runs the network sets first: LibTorch's intra-op
// threads (it starts with one unless told) and the allocator that keeps
// freed memory for the next step or forward (reefgen/heap.hpp).

namespace reefgen::model {

// threads ≥ 1. Call once, before the first forward.
void use_torch_threads(int threads);

}  // namespace reefgen::model
