#pragma once
// One pix2pix training step (Isola et al. 2017, paper §6), exactly as the
// original optimize_parameters(): D on (label, G(label)) detached and on
// (label, truth), D loss halved; then G against the frozen D with 100·L1.
#include <functional>

#include <torch/torch.h>

#include "reefgen/model/networks.hpp"
#include "reefgen/train/fused_adam.hpp"

namespace reefgen::train {

class Comm;
class GradientReducer;

// Extra L1 weight on the cells whose true height lies near sea level: the
// reef crest, the reef flat, motu and beaches are a few percent of a canvas
// and a few metres tall, so a plain mean L1 lets G trade them for the abyss
// (docs/MODEL.md "Shore-weighted L1"). Per cell
//   w = 1 + extra * exp(-((h - sea) / band)^2),   loss = mean(w |G - h|) / mean(w)
// in normalised units, so the loss keeps pix2pix's scale whatever `extra` is.
struct L1Weighting {
  double extra = 0;     // extra weight at sea level; 0 = plain mean L1, [0, 100]
  double sea = 0;       // sea level, normalised height units
  double band = 0.01;   // e-folding half-width, normalised height units, > 0
};
// L1 of fake against target {N,1,S,S} under `w`; exactly F::l1_loss when w.extra == 0.
torch::Tensor weighted_l1(const torch::Tensor& fake, const torch::Tensor& target, const L1Weighting& w);

// L1 between the slopes of fake and target {N,1,S,S}: the mean over both axes
// of |Δfake − Δtarget|, Δ the difference of neighbouring cells (normalised
// units per cell). A per-cell L1 lets G trade a slope's shape for its mean
// height — a bench at mid-radius of a cone costs little where it crosses the
// truth — while the slope term charges every cell where the fall differs
// (the gradient loss of Eigen & Fergus 2015 for depth maps; docs/MODEL.md
// "Slope loss").
torch::Tensor slope_l1(const torch::Tensor& fake, const torch::Tensor& target);

// L1 between the uphill slopes of fake and target {N,1,S,S} on land: each
// land cell's slope along the truth's own uphill direction n — the gradient
// of the truth smoothed over ~4 cells (Gaussian σ = kRiseSmoothCells), so
// valleys a sketch cannot place do not turn it — of fake and of target,
// their difference box-averaged over 5×5 cells, then |·| averaged over the
// land cells (truth above `sea`) where the smoothed truth slopes at all.
// A ring valley, a rim or a bench parallel to the coast is a fall or a
// flat along n where the truth rises (docs/MODEL.md "The ring loss"); a
// valley running downhill, or an offset, costs nothing.
inline constexpr double kRiseSmoothCells = 4;
torch::Tensor rise_l1(const torch::Tensor& fake, const torch::Tensor& target, double sea);

// How far G's answers sit in tanh's flat tails: the mean over cells of
// max(0, |z| − kLogitMax), z the logits before G's tanh {N,1,S,S}. Where
// |z| ≫ 1 tanh passes no gradient (sech²(20) ≈ 1e-17), so the L1, the GAN
// and the ring terms cannot move such a cell: a generator trained on a flat
// −100 m floor (the range's end) learnt to park cells there, and later
// stages on a floor with relief inherited them as a fixed pattern they
// could not remove (docs/MODEL.md "Saturated cells"). The bound gives those
// cells back a gradient and charges nothing inside ±kLogitMax, where tanh
// reaches 0.999 of the range: within 0.33 m of its ends at reefgen's 660 m.
inline constexpr double kLogitMax = 3.8;
torch::Tensor logit_excess(const torch::Tensor& logits);

struct Pix2PixOptions {
  model::UNetOptions g;       // generator: 3 -> 1 channels
  model::PatchOptions d;      // discriminator: 4 input channels (label ⊕ height)
  double lr = 2e-4;           // Adam learning rate at the start; (0, 1]
  double beta1 = 0.5;         // Adam β1; [0, 1)
  double beta2 = 0.999;       // Adam β2; [0, 1)
  double lambda_l1 = 100.0;   // weight of the L1 term in G's loss; [0, 1e4]
  L1Weighting l1;             // extra L1 weight near sea level (none by default: pix2pix's plain mean)
  double lambda_slope = 0;    // weight of slope_l1 in G's loss (0: pix2pix's loss); [0, 1e5]
  double lambda_rise = 0;     // weight of rise_l1 in G's loss (0: none); [0, 1e5]
  double lambda_logit = 0;    // weight of logit_excess in G's loss (0: none); [0, 1e5]
  int d_crop = 0;             // D sees each step's pairs cropped by a random 0..d_crop cells per side (0: whole); [0, 64]
  model::ConvOptions conv;    // who runs G's and D's convolutions (LibTorch by default)
};

struct Losses {
  double g_gan = 0, g_l1 = 0, d_real = 0, d_fake = 0;  // g_l1: lambda_l1·L1 + lambda_slope·slope L1 + lambda_rise·rise L1 + lambda_logit·logit excess
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
  std::function<torch::Tensor(const torch::Tensor&)> d_view(int64_t h, int64_t w) const;
  Pix2PixOptions options_;
  model::UNetGenerator g_;
  model::PatchDiscriminator d_;
  std::unique_ptr<FusedAdam> opt_g_, opt_d_;
  double lr_;
  Comm* comm_ = nullptr;
  std::shared_ptr<GradientReducer> reduce_g_, reduce_d_;  // with comm_
};

}  // namespace reefgen::train
