#include "reefgen/train/fused_adam.hpp"

#include "reefgen/vector_path.hpp"

#include <cmath>

#include <ATen/Parallel.h>

namespace reefgen::train {

FusedAdam::FusedAdam(std::vector<torch::Tensor> params, torch::optim::AdamOptions options)
    : torch::optim::Adam(std::move(params), options) {
  if (options.weight_decay() != 0 || options.amsgrad())
    throw std::invalid_argument("FusedAdam: weight decay and AMSGrad are not supported");
}

namespace {
// One pass: m, v and the weight updated together, on the vector path this
// process runs (common/vector_path.hpp, capped by REEFGEN_CPU_PATH); add,
// mul, div and sqrt are exactly rounded and FMA contraction is off, so every
// path gives the same bits.
REEFGEN_INLINE_BODY void adam_update_body(float* __restrict w, const float* __restrict g,
                                                                   float* __restrict m, float* __restrict v,
                                                                   int64_t n, float b1, float one_b1, float b2,
                                                                   float one_b2, float sqrt_bc2, float eps,
                                                                   float neg_step) {
  for (int64_t i = 0; i < n; ++i) {
    const float gi = g[i];
    const float mi = m[i] * b1 + gi * one_b1;
    const float vi = v[i] * b2 + one_b2 * gi * gi;
    m[i] = mi;
    v[i] = vi;
    w[i] += neg_step * (mi / (__builtin_sqrtf(vi) / sqrt_bc2 + eps));
  }
}
REEFGEN_DISPATCHED(void, adam_update, (float* __restrict w, const float* __restrict g, float* __restrict m, float* __restrict v, int64_t n, float b1, float one_b1, float b2, float one_b2, float sqrt_bc2, float eps, float neg_step), (w, g, m, v, n, b1, one_b1, b2, one_b2, sqrt_bc2, eps, neg_step))
}  // namespace

torch::Tensor FusedAdam::step(LossClosure closure) {
  torch::NoGradGuard no_grad;
  torch::Tensor loss;
  if (closure) {
    at::AutoGradMode enable_grad(true);
    loss = closure();
  }
  for (auto& group : param_groups_) {
    const auto& o = static_cast<const torch::optim::AdamOptions&>(group.options());
    for (auto& p : group.params()) {
      if (!p.grad().defined()) continue;
      TORCH_CHECK(p.scalar_type() == torch::kFloat32 && p.is_contiguous() && p.grad().is_contiguous(),
                  "FusedAdam: contiguous float32 parameters only");
      // The key torch::optim::Adam uses, so checkpoints stay interchangeable.
      const std::string key = adam_state_key(p);
      auto it = state_.find(key);
      if (it == state_.end()) {
        auto s = std::make_unique<torch::optim::AdamParamState>();
        s->step(0);
        s->exp_avg(torch::zeros_like(p, torch::MemoryFormat::Preserve));
        s->exp_avg_sq(torch::zeros_like(p, torch::MemoryFormat::Preserve));
        it = state_.emplace(key, std::move(s)).first;
      }
      auto& s = static_cast<torch::optim::AdamParamState&>(*it->second);
      s.step(s.step() + 1);
      const double beta1 = std::get<0>(o.betas()), beta2 = std::get<1>(o.betas());
      const double bc1 = 1 - std::pow(beta1, double(s.step())), bc2 = 1 - std::pow(beta2, double(s.step()));
      // The scalars in float, as LibTorch's kernels use them on float tensors.
      const float b1 = float(beta1), one_b1 = float(1 - beta1), b2 = float(beta2), one_b2 = float(1 - beta2);
      const float sqrt_bc2 = float(std::sqrt(bc2)), eps = float(o.eps()), neg_step = float(-(o.lr() / bc1));
      float* w = p.data_ptr<float>();
      const float* g = p.grad().data_ptr<float>();
      float* m = s.exp_avg().data_ptr<float>();
      float* v = s.exp_avg_sq().data_ptr<float>();
      at::parallel_for(0, p.numel(), 1 << 15, [&](int64_t begin, int64_t end) {
        adam_update(w + begin, g + begin, m + begin, v + begin, end - begin, b1, one_b1, b2, one_b2, sqrt_bc2, eps,
                    neg_step);
      });
      // Written through raw pointers: tell whoever caches a copy of p (the
      // oneDNN convolutions keep packed weights) that it changed.
      p.unsafeGetTensorImpl()->bump_version();
    }
  }
  return loss;
}

void clear_grads(const std::vector<torch::Tensor>& params) {
  for (const auto& p : params) p.mutable_grad() = torch::Tensor();
}

}  // namespace reefgen::train

