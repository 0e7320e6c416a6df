#include "reefgen/train/pix2pix.hpp"

#include <cmath>
#include <functional>
#include <utility>

#include "reefgen/train/distributed.hpp"

namespace reefgen::train {

namespace F = torch::nn::functional;

namespace {
torch::optim::AdamOptions adam(const Pix2PixOptions& o) {
  return torch::optim::AdamOptions(o.lr).betas(std::make_tuple(o.beta1, o.beta2));
}
void set_requires_grad(torch::nn::Module& m, bool on) {
  for (auto& p : m.parameters()) p.set_requires_grad(on);
}
}  // namespace

torch::Tensor weighted_l1(const torch::Tensor& fake, const torch::Tensor& target, const L1Weighting& w) {
  if (w.extra == 0) return F::l1_loss(fake, target);
  // The weights follow the truth only: no gradient flows through them.
  const torch::Tensor z = (target.detach() - w.sea) / w.band;    // {N,1,S,S}
  const torch::Tensor weight = 1 + w.extra * torch::exp(-z * z);  // {N,1,S,S}
  return (weight * (fake - target).abs()).sum() / weight.sum();
}

torch::Tensor slope_l1(const torch::Tensor& fake, const torch::Tensor& target) {
  const auto dx = [](const torch::Tensor& t) { return t.slice(3, 1) - t.slice(3, 0, -1); };  // {N,1,S,S-1}
  const auto dy = [](const torch::Tensor& t) { return t.slice(2, 1) - t.slice(2, 0, -1); };  // {N,1,S-1,S}
  return 0.5 * ((dx(fake) - dx(target)).abs().mean() + (dy(fake) - dy(target)).abs().mean());
}

namespace {
// A normalised 1-D Gaussian of σ cells, 3σ each side: {1,1,1,K}.
torch::Tensor gaussian_row(double sigma) {
  const int64_t r = int64_t(std::ceil(3 * sigma));
  const torch::Tensor x = torch::arange(-r, r + 1, torch::kFloat32);
  const torch::Tensor g = torch::exp(-x * x / float(2 * sigma * sigma));
  return (g / g.sum()).view({1, 1, 1, -1});
}
// t {N,1,S,S} blurred by the separable kernel row (and its transpose), edges replicated.
torch::Tensor blur(const torch::Tensor& t, const torch::Tensor& row) {
  const int64_t r = row.size(3) / 2;
  torch::Tensor x = F::pad(t, F::PadFuncOptions({r, r, 0, 0}).mode(torch::kReplicate));
  x = F::conv2d(x, row);
  x = F::pad(x, F::PadFuncOptions({0, 0, r, r}).mode(torch::kReplicate));
  return F::conv2d(x, row.transpose(2, 3));
}
// Central differences along x and y, edges replicated: {N,1,S,S} each.
std::pair<torch::Tensor, torch::Tensor> central_gradient(const torch::Tensor& t) {
  const torch::Tensor p = F::pad(t, F::PadFuncOptions({1, 1, 1, 1}).mode(torch::kReplicate));
  const int64_t S = t.size(2), W = t.size(3);
  return {0.5 * (p.slice(2, 1, S + 1).slice(3, 2, W + 2) - p.slice(2, 1, S + 1).slice(3, 0, W)),
          0.5 * (p.slice(2, 2, S + 2).slice(3, 1, W + 1) - p.slice(2, 0, S).slice(3, 1, W + 1))};
}
}  // namespace

torch::Tensor rise_l1(const torch::Tensor& fake, const torch::Tensor& target, double sea) {
  // The truth's uphill direction and the land mask follow the truth only.
  const torch::Tensor truth = target.detach();
  const auto [sx, sy] = central_gradient(blur(truth, gaussian_row(kRiseSmoothCells)));  // {N,1,S,S}
  const torch::Tensor norm = torch::sqrt(sx * sx + sy * sy);
  // Where the smoothed truth is flat there is no uphill to follow (1e-5 of
  // the normalised range per cell: ~3 mm at reefgen's 660 m range).
  const torch::Tensor sloped = (norm > 1e-5) & (truth > sea);
  const torch::Tensor nx = sx / norm.clamp_min(1e-5), ny = sy / norm.clamp_min(1e-5);
  const auto [fx, fy] = central_gradient(fake);
  const auto [tx, ty] = central_gradient(truth);
  const torch::Tensor diff = (fx - tx) * nx + (fy - ty) * ny;           // {N,1,S,S}
  const torch::Tensor local = F::avg_pool2d(F::pad(diff, F::PadFuncOptions({2, 2, 2, 2}).mode(torch::kReplicate)),
                                            F::AvgPool2dFuncOptions(5).stride(1));  // {N,1,S,S}
  const torch::Tensor m = sloped.to(fake.scalar_type());
  return (local.abs() * m).sum() / m.sum().clamp_min(1);
}

torch::Tensor logit_excess(const torch::Tensor& logits) {
  return torch::relu(logits.abs() - kLogitMax).mean();
}

Pix2Pix::Pix2Pix(const Pix2PixOptions& o) : options_(o), g_(o.g), d_(o.d), lr_(o.lr) {
  if (o.d.in_channels != o.g.in_channels + o.g.out_channels)
    throw std::invalid_argument("Pix2PixOptions: D takes label ⊕ height, so d.in_channels must be " +
                                std::to_string(o.g.in_channels + o.g.out_channels));
  if (!(o.lr > 0 && o.lr <= 1)) throw std::invalid_argument("Pix2PixOptions: lr must be in (0, 1]");
  if (!(o.beta1 >= 0 && o.beta1 < 1 && o.beta2 >= 0 && o.beta2 < 1))
    throw std::invalid_argument("Pix2PixOptions: betas must be in [0, 1)");
  g_->set_conv(o.conv);
  d_->set_conv(o.conv);
  model::init_pix2pix(*g_);
  model::init_pix2pix(*d_);
  opt_g_ = std::make_unique<FusedAdam>(g_->parameters(), adam(o));
  opt_d_ = std::make_unique<FusedAdam>(d_->parameters(), adam(o));
}

void Pix2Pix::set_lr(double lr) {
  lr_ = lr;
  for (auto* opt : {opt_g_.get(), opt_d_.get()})
    for (auto& group : opt->param_groups()) static_cast<torch::optim::AdamOptions&>(group.options()).lr(lr);
}

void Pix2Pix::set_comm(Comm* comm, double bucket_mb) {
  comm_ = comm;
  reduce_g_.reset();
  reduce_d_.reset();
  if (!comm || comm->world_size() == 1) return;
  reduce_g_ = std::make_shared<GradientReducer>(*comm, g_->parameters(), "the all-reduce of G's gradients", bucket_mb);
  reduce_d_ = std::make_shared<GradientReducer>(*comm, d_->parameters(), "the all-reduce of D's gradients", bucket_mb);
}

// What D sees of a {N,C,H,W} pair this step: with d_crop > 0 the pair cut
// to (H − d_crop) × (W − d_crop) at an offset drawn from torch's generator
// (reseeded per step by the trainer), the same for the real and the fake
// pairs, so a pattern at a fixed place of G's answer is never at the same
// place of D's view. Measured against G's fixed top-left pattern, it only
// shrank it; the logit bound removed it (docs/MODEL.md "Saturated cells").
std::function<torch::Tensor(const torch::Tensor&)> Pix2Pix::d_view(int64_t h, int64_t w) const {
  const int64_t c = options_.d_crop;
  if (c <= 0) return [](const torch::Tensor& t) { return t; };
  const int64_t oy = torch::randint(c + 1, {1}).item<int64_t>(), ox = torch::randint(c + 1, {1}).item<int64_t>();
  return [=](const torch::Tensor& t) { return t.slice(2, oy, oy + h - c).slice(3, ox, ox + w - c); };
}

Losses Pix2Pix::step(const torch::Tensor& label, const torch::Tensor& height) {
  g_->train();
  d_->train();
  // Synchronised BatchNorm for the step only: validation passes on rank 0
  // alone must not wait for the other ranks.
  struct SyncScope {
    Pix2Pix& p;
    explicit SyncScope(Pix2Pix& q) : p(q) {
      if (!p.comm_) return;
      Comm* c = p.comm_;
      const model::ReplicaSum sum = [c](const torch::Tensor& x) { return c->replica_sum(x); };
      p.g_->set_replica_sum(sum);
      p.d_->set_replica_sum(sum);
    }
    ~SyncScope() {
      if (!p.comm_) return;
      p.g_->set_replica_sum(nullptr);
      p.d_->set_replica_sum(nullptr);
    }
  } sync(*this);
  const torch::Tensor logits = g_->logits(label);  // {N,1,S,S}
  const torch::Tensor fake = torch::tanh(logits);  // G's answer, as g_->forward(label)
  const auto seen = d_view(label.size(2), label.size(3));

  // D step: fake pairs detached so G gets no gradient from it.
  set_requires_grad(*d_, true);
  clear_grads(d_->parameters());
  const torch::Tensor pred_fake = d_->forward(seen(torch::cat({label, fake.detach()}, 1)));  // {N,1,P,P}
  const torch::Tensor d_fake = F::binary_cross_entropy_with_logits(pred_fake, torch::zeros_like(pred_fake));
  const torch::Tensor pred_real = d_->forward(seen(torch::cat({label, height}, 1)));
  const torch::Tensor d_real = F::binary_cross_entropy_with_logits(pred_real, torch::ones_like(pred_real));
  // Halved so D learns more slowly than G (pix2pix).
  if (reduce_d_) reduce_d_->begin();
  ((d_fake + d_real) * 0.5).backward();
  if (reduce_d_) reduce_d_->end();  // D's gradients: the mean over the ranks
  opt_d_->step();

  // G step against a frozen D: no gradients accumulate in D's parameters.
  set_requires_grad(*d_, false);
  clear_grads(g_->parameters());
  const torch::Tensor pred = d_->forward(seen(torch::cat({label, fake}, 1)));
  const torch::Tensor g_gan = F::binary_cross_entropy_with_logits(pred, torch::ones_like(pred));
  torch::Tensor g_l1 = weighted_l1(fake, height, options_.l1) * options_.lambda_l1;
  if (options_.lambda_slope > 0) g_l1 = g_l1 + slope_l1(fake, height) * options_.lambda_slope;
  if (options_.lambda_rise > 0) g_l1 = g_l1 + rise_l1(fake, height, options_.l1.sea) * options_.lambda_rise;
  if (options_.lambda_logit > 0) g_l1 = g_l1 + logit_excess(logits) * options_.lambda_logit;
  if (reduce_g_) reduce_g_->begin();
  (g_gan + g_l1).backward();
  if (reduce_g_) reduce_g_->end();
  opt_g_->step();
  set_requires_grad(*d_, true);

  return {g_gan.item<double>(), g_l1.item<double>(), d_real.item<double>(), d_fake.item<double>()};
}

}  // namespace reefgen::train
