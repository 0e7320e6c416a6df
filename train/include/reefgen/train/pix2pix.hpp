#pragma once
// One pix2pix training step (Isola et al. 2017, paper §6), exactly as the
// original optimize_parameters(): D on (label, G(label)) detached and on
// (label, truth), D loss halved; then G against the frozen D with 100·L1.
#include <torch/torch.h>

#include "reefgen/model/networks.hpp"
#include "reefgen/train/fused_adam.hpp"

namespace reefgen::train {

class Comm;
class GradientReducer;

struct Pix2PixOptions {
  model::UNetOptions g;       // generator: 3 -> 1 channels
  model::PatchOptions d;      // discriminator: 4 input channels (label ⊕ height)
  double lr = 2e-4;           // Adam learning rate at the start; (0, 1]
  double beta1 = 0.5;         // Adam β1; [0, 1)
  double beta2 = 0.999;       // Adam β2; [0, 1)
  double lambda_l1 = 100.0;   // weight of the L1 term in G's loss; [0, 1e4]
  model::ConvOptions conv;    // who runs G's and D's convolutions (LibTorch by default)
};

struct Losses {
  double g_gan = 0, g_l1 = 0, d_real = 0, d_fake = 0;  // g_l1 already weighted by lambda_l1
};

class Pix2Pix {
 public:
  explicit Pix2Pix(const Pix2PixOptions& options);
  // label {N,3,S,S} and height {N,1,S,S}, both in [-1, 1].
  Losses step(const torch::Tensor& label, const torch::Tensor& height);
  void set_lr(double lr);
  // Data-parallel (distributed.hpp): BatchNorm over the global batch and
  // gradients averaged over the ranks before each Adam step. nullptr (the
  // default): this process alone. The Comm must outlive the steps.
  void set_comm(Comm* comm, double bucket_mb = 4);
  double lr() const { return lr_; }

  const Pix2PixOptions& options() const { return options_; }
  model::UNetGenerator& G() { return g_; }
  model::PatchDiscriminator& D() { return d_; }
  torch::optim::Adam& opt_G() { return *opt_g_; }
  torch::optim::Adam& opt_D() { return *opt_d_; }

 private:
  Pix2PixOptions options_;
  model::UNetGenerator g_;
  model::PatchDiscriminator d_;
  std::unique_ptr<FusedAdam> opt_g_, opt_d_;
  double lr_;
  Comm* comm_ = nullptr;
  std::shared_ptr<GradientReducer> reduce_g_, reduce_d_;  // with comm_
};

}  // namespace reefgen::train
