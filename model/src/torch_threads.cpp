#include "reefgen/model/torch_threads.hpp"

#include <torch/torch.h>

#include "reefgen/heap.hpp"

namespace reefgen::model {

void use_torch_threads(int threads) {
  torch::set_num_threads(threads);
  keep_freed_memory();
}

}  // namespace reefgen::model
