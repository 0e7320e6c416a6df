#pragma once
// pix2pix networks (Isola et al. 2017) as used by the paper's section 6:
// a U-Net generator and a PatchGAN discriminator, in LibTorch module style.
// Layer for layer the same as the original pytorch-CycleGAN-and-pix2pix code
// (proven by tests/test_model.cpp against scripts/reference/pix2pix_ref.py).
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <torch/torch.h>

#include "reefgen/model/dnnl_conv.hpp"

namespace reefgen::model {

enum class Norm { Batch, Instance, None };
Norm norm_from_string(const std::string& s);  // "batch" | "instance" | "none"
std::string to_string(Norm n);

// How the decoder doubles the resolution. pix2pix: a 4×4 stride-2 transposed
// convolution, whose uneven kernel overlap draws 2-px checkerboards (Odena et
// al. 2016). Resize-convolution (nearest or bilinear ×2, then a 3×3
// convolution) cannot: every output pixel sees the same kernel taps.
enum class Upsample { Transpose, Nearest, Bilinear };
Upsample upsample_from_string(const std::string& s);  // "transpose" | "nearest" | "bilinear"
std::string to_string(Upsample u);

struct UNetOptions {
  int in_channels = 3;     // RGB label sketch in [-1, 1]; [1, 64]
  int out_channels = 1;    // height normalised to [-1, 1]; [1, 64]
  int ngf = 64;            // filters of the outermost layer; [1, 1024]
  int depth = 8;           // down-samplings; the input side must be a multiple of 2^depth; [5, 12]
  Norm norm = Norm::Batch; // pix2pix default; convolutions have a bias only without BatchNorm
  double dropout = 0.5;    // after the decoder blocks of the ngf*8 levels 4..depth-2; [0, 1)
  Upsample upsample = Upsample::Transpose;  // pix2pix default; resize-convolution has no checkerboards
};

struct PatchOptions {
  int in_channels = 4;     // label (3) + height (1)
  int ndf = 64;            // filters of the first layer; [1, 1024]
  int n_layers = 3;        // 3 = 70x70 receptive field, 30x30 logits at 256²; [1, 8]
  Norm norm = Norm::Batch;
};

// Which code runs the convolutions, a run-time choice that changes no
// parameter: LibTorch's own kernels, or oneDNN directly (dnnl_conv.hpp; equal
// within 1e-4 in float32, faster per training step (docs/BENCHMARKS.md), bf16
// where the CPU has it). Modules whose weights are not float32 always use LibTorch.
enum class ConvEngine { Torch, OneDnn };
struct ConvOptions {
  ConvEngine engine = ConvEngine::Torch;
  ConvPrecision precision = ConvPrecision::Fp32;  // Bf16: oneDNN engine only
};

// Data-parallel training (docs/TRAINING.md): the sum of a small tensor over
// every replica of the network, differentiable (an all-reduce whose backward
// all-reduces the gradient). Given one, BatchNorm layers in training mode
// normalise with the statistics of the global batch (synchronised
// BatchNorm), so N ranks of batch b compute what one process of batch N·b
// does. Empty: each process's own batch (the default, and LibTorch's kernel).
using ReplicaSum = std::function<torch::Tensor(const torch::Tensor&)>;

// The U-Net, flattened: level k (0 = outermost) has a down convolution
// c_{k-1} -> c_k and an up transposed convolution back, c_k = ngf*min(2^k, 8).
class UNetGeneratorImpl : public torch::nn::Module {
 public:
  explicit UNetGeneratorImpl(const UNetOptions& options = {});
  torch::Tensor forward(torch::Tensor x);  // {N,in,S,S} -> {N,out,S,S} in (-1, 1): tanh(logits(x))
  // The answer before its tanh: what a bound on saturation needs (train/pix2pix.hpp logit_excess).
  torch::Tensor logits(torch::Tensor x);   // {N,in,S,S} -> {N,out,S,S}
  const UNetOptions& options() const { return options_; }
  // Dropout on/off independently of BatchNorm's train/eval mode: pix2pix runs
  // G in train mode at test time; tests and deterministic inference need
  // batch statistics without the dropout noise.
  void set_dropout_enabled(bool on) { dropout_enabled_ = on; }
  bool dropout_enabled() const { return dropout_enabled_; }
  void set_conv(const ConvOptions& c) { conv_ = c; }
  const ConvOptions& conv() const { return conv_; }
  // One seed per sample of the next batches: sample i's dropout masks come
  // from its own generator, so a sample is dropped the same way whichever
  // batch or rank it is in (data-parallel runs equal one-process runs).
  // Empty (the default): masks drawn from torch's global generator.
  void set_dropout_seeds(std::vector<uint64_t> seeds) { dropout_seeds_ = std::move(seeds); }
  void set_replica_sum(const ReplicaSum& sum);

 private:
  UNetOptions options_;
  bool dropout_enabled_ = true;
  std::vector<uint64_t> dropout_seeds_;
  ConvOptions conv_;
  torch::nn::ModuleList levels_{nullptr};
};
TORCH_MODULE(UNetGenerator);

class PatchDiscriminatorImpl : public torch::nn::Module {
 public:
  explicit PatchDiscriminatorImpl(const PatchOptions& options = {});
  torch::Tensor forward(torch::Tensor x);  // {N,in,S,S} -> logits {N,1,P,P}, P = 30 at S = 256
  const PatchOptions& options() const { return options_; }
  void set_conv(const ConvOptions& c) { conv_ = c; }
  const ConvOptions& conv() const { return conv_; }
  void set_replica_sum(const ReplicaSum& sum);  // see ReplicaSum

 private:
  PatchOptions options_;
  ConvOptions conv_;
  torch::nn::Sequential net_{nullptr};
};
TORCH_MODULE(PatchDiscriminator);

// pix2pix "normal" initialisation: conv weights N(0, gain), norm weights
// N(1, gain), biases 0. Draws from torch's global generator (seed it first).
void init_pix2pix(torch::nn::Module& net, double gain = 0.02);

int64_t count_parameters(const torch::nn::Module& net);

}  // namespace reefgen::model
