#pragma once
// Adam with the update fused into one pass over each parameter tensor.
//
// Same maths, state and checkpoint format as torch::optim::Adam (it is one:
// save/load are inherited), but LibTorch's step makes ~10 separate passes over
// the 54 M generator parameters and was 23 % of a pix2pix iteration (autograd
// profile, docs/BENCHMARKS.md). Element-wise and chunked over a fixed grain,
// so the result does not depend on the thread count. No weight decay, no
// AMSGrad (pix2pix uses neither; both are refused).
#include <torch/torch.h>

namespace reefgen::train {

class FusedAdam : public torch::optim::Adam {
 public:
  FusedAdam(std::vector<torch::Tensor> params, torch::optim::AdamOptions options);
  torch::Tensor step(LossClosure closure = nullptr) override;
};

// The key torch::optim::Adam files a parameter's state under (the address
// of its TensorImpl, as text): FusedAdam, the checkpoints and the broadcast
// of a resumed state all look it up here.
inline std::string adam_state_key(const torch::Tensor& param) {
  return c10::guts::to_string(param.unsafeGetTensorImpl());
}
// The Adam state of `param` in `opt`, or nullptr before its first step.
inline torch::optim::AdamParamState* adam_state(torch::optim::Optimizer& opt, const torch::Tensor& param) {
  auto it = opt.state().find(adam_state_key(param));
  return it == opt.state().end() ? nullptr : static_cast<torch::optim::AdamParamState*>(it->second.get());
}

// Drops the gradients instead of filling them with zeros: the next backward
// writes fresh ones (no fill pass, no accumulation pass over 54 M values).
void clear_grads(const std::vector<torch::Tensor>& params);

}  // namespace reefgen::train

