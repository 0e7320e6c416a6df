#include "reefgen/train/pix2pix.hpp"

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
  const torch::Tensor fake = g_->forward(label);  // {N,1,S,S}

  // D step: fake pairs detached so G gets no gradient from it.
  set_requires_grad(*d_, true);
  clear_grads(d_->parameters());
  const torch::Tensor pred_fake = d_->forward(torch::cat({label, fake.detach()}, 1));  // {N,1,P,P}
  const torch::Tensor d_fake = F::binary_cross_entropy_with_logits(pred_fake, torch::zeros_like(pred_fake));
  const torch::Tensor pred_real = d_->forward(torch::cat({label, height}, 1));
  const torch::Tensor d_real = F::binary_cross_entropy_with_logits(pred_real, torch::ones_like(pred_real));
  // Halved so D learns more slowly than G (pix2pix).
  if (reduce_d_) reduce_d_->begin();
  ((d_fake + d_real) * 0.5).backward();
  if (reduce_d_) reduce_d_->end();  // D's gradients: the mean over the ranks
  opt_d_->step();

  // G step against a frozen D: no gradients accumulate in D's parameters.
  set_requires_grad(*d_, false);
  clear_grads(g_->parameters());
  const torch::Tensor pred = d_->forward(torch::cat({label, fake}, 1));
  const torch::Tensor g_gan = F::binary_cross_entropy_with_logits(pred, torch::ones_like(pred));
  torch::Tensor g_l1 = weighted_l1(fake, height, options_.l1) * options_.lambda_l1;
  if (options_.lambda_slope > 0) g_l1 = g_l1 + slope_l1(fake, height) * options_.lambda_slope;
  if (reduce_g_) reduce_g_->begin();
  (g_gan + g_l1).backward();
  if (reduce_g_) reduce_g_->end();
  opt_g_->step();
  set_requires_grad(*d_, true);

  return {g_gan.item<double>(), g_l1.item<double>(), d_real.item<double>(), d_fake.item<double>()};
}

}  // namespace reefgen::train
