#include "reefgen/model/networks.hpp"

#include <algorithm>
#include <stdexcept>

#include <ATen/CPUGeneratorImpl.h>

namespace reefgen::model {
namespace nn = torch::nn;

Norm norm_from_string(const std::string& s) {
  if (s == "batch") return Norm::Batch;
  if (s == "instance") return Norm::Instance;
  if (s == "none") return Norm::None;
  throw std::invalid_argument("norm '" + s + "': use batch, instance or none");
}

std::string to_string(Norm n) {
  switch (n) {
    case Norm::Batch: return "batch";
    case Norm::Instance: return "instance";
    case Norm::None: return "none";
  }
  return "?";
}

Upsample upsample_from_string(const std::string& s) {
  if (s == "transpose") return Upsample::Transpose;
  if (s == "nearest") return Upsample::Nearest;
  if (s == "bilinear") return Upsample::Bilinear;
  throw std::invalid_argument("upsample '" + s + "': use transpose, nearest or bilinear");
}

std::string to_string(Upsample u) {
  switch (u) {
    case Upsample::Transpose: return "transpose";
    case Upsample::Nearest: return "nearest";
    case Upsample::Bilinear: return "bilinear";
  }
  return "?";
}

namespace {

// BatchNorm in training mode over the global batch of all replicas: the
// same maths as BatchNorm2d (biased variance to normalise, unbiased in the
// running estimate), written with differentiable ops around `sum` so that
// autograd all-reduces the gradient terms too. One all-reduce each way per
// layer: the sums of x − c and (x − c)² and the element count travel
// together. The shift c is the running mean, near the batch mean once
// training is under way, so E[(x−c)²] − E[x−c]² does not cancel in float32
// (at the start both are near 0: pix2pix's initialisation centres them).
torch::Tensor sync_batch_norm(const torch::Tensor& x, nn::BatchNorm2dImpl& bn, const ReplicaSum& sum) {
  const int64_t C = x.size(1);  // x {N,C,H,W}
  const double local_n = double(x.numel() / C);
  const torch::Tensor c = bn.options.track_running_stats() ? bn.running_mean.detach() : torch::zeros({C}, x.options());
  const torch::Tensor xs = x - c.view({1, C, 1, 1});  // {N,C,H,W}
  const torch::Tensor stats = sum(torch::cat(
      {xs.sum({0, 2, 3}), xs.square().sum({0, 2, 3}), torch::full({1}, local_n, x.options())}));  // {2C+1}
  const double n = stats[2 * C].item<double>();
  const torch::Tensor m1 = stats.narrow(0, 0, C) / n, m2 = stats.narrow(0, C, C) / n;  // {C}
  const torch::Tensor mean = c + m1;
  const torch::Tensor var = (m2 - m1.square()).clamp_min(0);  // biased
  const double eps = bn.options.eps();
  torch::Tensor y = (x - mean.view({1, C, 1, 1})) * torch::rsqrt(var + eps).view({1, C, 1, 1});
  if (bn.options.affine()) y = y * bn.weight.view({1, C, 1, 1}) + bn.bias.view({1, C, 1, 1});
  if (bn.options.track_running_stats()) {
    torch::NoGradGuard no_grad;
    const double m = bn.options.momentum().value();
    bn.running_mean.mul_(1 - m).add_(mean.detach(), m);
    bn.running_var.mul_(1 - m).add_(var.detach() * (n / std::max(1.0, n - 1)), m);
    bn.num_batches_tracked.add_(1);
  }
  return y;
}

// A normalisation layer chosen at run time; empty for Norm::None.
// pix2pix: BatchNorm2d(affine), InstanceNorm2d(affine=False, no running stats).
struct NormLayerImpl : nn::Module {
  NormLayerImpl(Norm n, int channels) {
    if (n == Norm::Batch) bn = register_module("bn", nn::BatchNorm2d(channels));
    if (n == Norm::Instance) in = register_module("inorm", nn::InstanceNorm2d(channels));  // not "in": a Python keyword breaks archive loading
  }
  torch::Tensor forward(const torch::Tensor& x) {
    if (bn && replica_sum && bn->is_training()) return sync_batch_norm(x, *bn, replica_sum);
    if (bn) return bn->forward(x);
    if (in) return in->forward(x);
    return x;
  }
  nn::BatchNorm2d bn{nullptr};
  nn::InstanceNorm2d in{nullptr};
  ReplicaSum replica_sum;  // set: BatchNorm over every replica's batch
};
TORCH_MODULE(NormLayer);

void set_replica_sum_on(nn::Module& net, const ReplicaSum& sum) {
  for (auto& m : net.modules(/*include_self=*/false))
    if (auto* n = m->as<NormLayerImpl>()) n->replica_sum = sum;
}

// Dropout whose mask for sample i is drawn from its own generator seeded
// with seeds[i] and the layer: the same sample is dropped the same way in
// any batch. Same distribution and scaling as torch::dropout.
torch::Tensor per_sample_dropout(const torch::Tensor& u, double p, const std::vector<uint64_t>& seeds, int layer) {
  if (int64_t(seeds.size()) != u.size(0))
    throw std::invalid_argument("UNetGenerator: " + std::to_string(seeds.size()) + " dropout seeds for a batch of " +
                                std::to_string(u.size(0)));
  torch::Tensor mask = torch::empty_like(u);  // {N,C,h,w}
  for (int64_t i = 0; i < u.size(0); ++i) {
    // splitmix-style mixing of the layer into the seed: layers draw independent masks
    uint64_t z = seeds[size_t(i)] + 0x9E3779B97F4A7C15ull * uint64_t(layer + 1);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    at::Generator gen = at::make_generator<at::CPUGeneratorImpl>(z ^ (z >> 31));
    mask[i].bernoulli_(1.0 - p, gen);
  }
  return u * mask.div_(1.0 - p);
}

bool on_onednn(const ConvOptions& o, const torch::Tensor& x, const torch::Tensor& w) {
  return o.engine == ConvEngine::OneDnn && x.scalar_type() == torch::kFloat32 && w.scalar_type() == torch::kFloat32;
}

// The module's own forward, or the same convolution on oneDNN (the networks'
// convolutions are square, with explicit symmetric padding).
template <class Conv>
torch::Tensor run(Conv& c, const torch::Tensor& x, const ConvOptions& o, bool transposed) {
  if (!on_onednn(o, x, c.weight)) return c.forward(x);
  const int64_t pad = c10::get<torch::ExpandingArray<2>>(c.options.padding())->at(0);
  return dnnl_conv2d(x, c.weight, c.bias, {c.options.stride()->at(0), pad, transposed}, o.precision);
}
torch::Tensor run(nn::Conv2dImpl& c, const torch::Tensor& x, const ConvOptions& o) { return run(c, x, o, false); }
torch::Tensor run(nn::ConvTranspose2dImpl& c, const torch::Tensor& x, const ConvOptions& o) {
  return run(c, x, o, true);
}

nn::Conv2dOptions conv4(int in, int out, int stride, bool bias) {
  return nn::Conv2dOptions(in, out, 4).stride(stride).padding(1).bias(bias);
}

void check_options(const UNetOptions& o) {
  auto bad = [](const std::string& what) { throw std::invalid_argument("UNetOptions: " + what); };
  if (o.in_channels < 1 || o.in_channels > 64) bad("in_channels must be in [1, 64]");
  if (o.out_channels < 1 || o.out_channels > 64) bad("out_channels must be in [1, 64]");
  if (o.ngf < 1 || o.ngf > 1024) bad("ngf must be in [1, 1024]");
  if (o.depth < 5 || o.depth > 12) bad("depth must be in [5, 12]");
  if (!(o.dropout >= 0.0 && o.dropout < 1.0)) bad("dropout must be in [0, 1)");
}

// Level k of the U-Net: the down path c_{k-1} -> c_k and the up path that
// returns to c_{k-1} (or to the output channels at k = 0).
struct UNetLevelImpl : nn::Module {
  UNetLevelImpl(const UNetOptions& o, int k) : outermost(k == 0), innermost(k == o.depth - 1) {
    auto ch = [&](int level) { return o.ngf * std::min(1 << std::min(level, 3), 8); };
    const bool bias = o.norm != Norm::Batch;  // pix2pix: use_bias = (norm == instance)
    const int in = outermost ? o.in_channels : ch(k - 1);
    const int inner = ch(k);
    const int out = outermost ? o.out_channels : ch(k - 1);
    down_conv = register_module("down_conv", nn::Conv2d(conv4(in, inner, 2, bias)));
    if (!outermost && !innermost) down_norm = register_module("down_norm", NormLayer(o.norm, inner));
    // Inner levels receive their own output concatenated with the skip.
    const int up_in = innermost ? inner : 2 * inner;
    upsample = o.upsample;
    if (upsample == Upsample::Transpose)
      up_conv = register_module(
          "up_conv", nn::ConvTranspose2d(nn::ConvTranspose2dOptions(up_in, out, 4).stride(2).padding(1).bias(
                         outermost || bias)));
    else
      up_resize_conv = register_module(
          "up_conv", nn::Conv2d(nn::Conv2dOptions(up_in, out, 3).stride(1).padding(1).bias(outermost || bias)));
    if (!outermost) up_norm = register_module("up_norm", NormLayer(o.norm, out));
    dropout = (k >= 4 && k <= o.depth - 2) ? o.dropout : 0.0;
  }
  // x {N,C,s,s} -> {N,out,2s,2s}
  torch::Tensor up(torch::Tensor x, const ConvOptions& conv) {
    // Mixed precision: a layer kept in float32 inside a bfloat16 net (the
    // output layer, see infer) takes its input in its own type.
    const auto& w = upsample == Upsample::Transpose ? up_conv->weight : up_resize_conv->weight;
    if (x.scalar_type() != w.scalar_type()) x = x.to(w.scalar_type());
    if (upsample == Upsample::Transpose) return run(*up_conv, x, conv);
    namespace F = torch::nn::functional;
    auto o = F::InterpolateFuncOptions().scale_factor(std::vector<double>{2.0, 2.0});
    if (upsample == Upsample::Nearest) o.mode(torch::kNearest);
    else o.mode(torch::kBilinear).align_corners(false);
    return run(*up_resize_conv, F::interpolate(x, o), conv);
  }
  bool outermost, innermost;
  double dropout;
  Upsample upsample = Upsample::Transpose;
  nn::Conv2d up_resize_conv{nullptr};
  nn::Conv2d down_conv{nullptr};
  NormLayer down_norm{nullptr}, up_norm{nullptr};
  nn::ConvTranspose2d up_conv{nullptr};
};
TORCH_MODULE(UNetLevel);

}  // namespace

UNetGeneratorImpl::UNetGeneratorImpl(const UNetOptions& options) : options_(options) {
  check_options(options_);
  levels_ = register_module("levels", nn::ModuleList());
  for (int k = 0; k < options_.depth; ++k) levels_->push_back(UNetLevel(options_, k));
}

torch::Tensor UNetGeneratorImpl::forward(torch::Tensor x) { return torch::tanh(logits(std::move(x))); }

torch::Tensor UNetGeneratorImpl::logits(torch::Tensor x) {
  const int depth = options_.depth;
  const int64_t side = x.size(-1), multiple = int64_t(1) << depth;
  if (x.dim() != 4 || x.size(1) != options_.in_channels || x.size(-2) != side || side % multiple)
    throw std::invalid_argument("UNetGenerator: input must be {N," + std::to_string(options_.in_channels) +
                                ",S,S} with S a multiple of " + std::to_string(multiple) + ", got " +
                                c10::str(x.sizes()));
  auto level = [&](int k) { return levels_->ptr<UNetLevelImpl>(k); };
  // Down path. The original code's in-place LeakyReLU at the start of each
  // inner block also rewrites the tensor that the skip connection
  // concatenates, so the skips carry leaky(d), not d: kept, to be the same net.
  std::vector<torch::Tensor> skips;
  skips.reserve(depth);
  torch::Tensor d = run(*level(0)->down_conv, x, conv_);  // {N,ngf,S/2,S/2}
  for (int k = 1; k < depth; ++k) {
    // In place, as the original: no extra activation buffer (d is not needed:
    // neither convolution nor BatchNorm backward uses its own output).
    torch::Tensor a = torch::leaky_relu_(d, 0.2);
    skips.push_back(a);
    d = run(*level(k)->down_conv, a, conv_);  // {N,c_k,S/2^(k+1),..}
    if (level(k)->down_norm) d = level(k)->down_norm->forward(d);
  }
  // Up path, innermost first: u has c_k or 2c_k channels at S/2^(k+1).
  torch::Tensor u = d;  // {N,8ngf,S/2^depth,..}
  for (int k = depth - 1; k >= 1; --k) {
    auto L = level(k);
    u = L->up_norm->forward(L->up(torch::relu_(u), conv_));  // u is a fresh cat/conv output
    if (L->dropout > 0 && is_training() && dropout_enabled_ && !dropout_seeds_.empty())
      u = per_sample_dropout(u, L->dropout, dropout_seeds_, k);
    else if (L->dropout > 0)
      u = torch::dropout(u, L->dropout, is_training() && dropout_enabled_);
    u = torch::cat({skips[k - 1], u}, 1);  // skip first, as in torch.cat([x, model(x)], 1)
  }
  return level(0)->up(torch::relu_(u), conv_);  // {N,out,S,S}
}

void UNetGeneratorImpl::set_replica_sum(const ReplicaSum& sum) { set_replica_sum_on(*this, sum); }
void PatchDiscriminatorImpl::set_replica_sum(const ReplicaSum& sum) { set_replica_sum_on(*this, sum); }

PatchDiscriminatorImpl::PatchDiscriminatorImpl(const PatchOptions& o) : options_(o) {
  if (o.in_channels < 1 || o.in_channels > 64) throw std::invalid_argument("PatchOptions: in_channels must be in [1, 64]");
  if (o.ndf < 1 || o.ndf > 1024) throw std::invalid_argument("PatchOptions: ndf must be in [1, 1024]");
  if (o.n_layers < 1 || o.n_layers > 8) throw std::invalid_argument("PatchOptions: n_layers must be in [1, 8]");
  const bool bias = o.norm != Norm::Batch;
  net_ = register_module("net", nn::Sequential());
  net_->push_back(nn::Conv2d(conv4(o.in_channels, o.ndf, 2, true)));
  net_->push_back(nn::LeakyReLU(nn::LeakyReLUOptions().negative_slope(0.2).inplace(true)));
  int mult = 1;
  for (int n = 1; n <= o.n_layers; ++n) {
    const int prev = mult;
    mult = std::min(1 << n, 8);
    // The last of these keeps the resolution (stride 1): 70x70 receptive field at n_layers 3.
    net_->push_back(nn::Conv2d(conv4(o.ndf * prev, o.ndf * mult, n < o.n_layers ? 2 : 1, bias)));
    net_->push_back(NormLayer(o.norm, o.ndf * mult));
    net_->push_back(nn::LeakyReLU(nn::LeakyReLUOptions().negative_slope(0.2).inplace(true)));
  }
  net_->push_back(nn::Conv2d(conv4(o.ndf * mult, 1, 1, true)));
}

torch::Tensor PatchDiscriminatorImpl::forward(torch::Tensor x) {
  if (x.dim() != 4 || x.size(1) != options_.in_channels)
    throw std::invalid_argument("PatchDiscriminator: input must be {N," + std::to_string(options_.in_channels) +
                                ",H,W}, got " + c10::str(x.sizes()));
  if (conv_.engine == ConvEngine::Torch) return net_->forward(x);
  for (auto& m : *net_) {
    if (auto* c = m.ptr()->as<nn::Conv2d>()) x = run(*c, x, conv_);
    else x = m.forward(x);
  }
  return x;
}

void init_pix2pix(torch::nn::Module& net, double gain) {
  torch::NoGradGuard no_grad;
  for (auto& m : net.modules(/*include_self=*/false)) {
    const bool conv = m->as<nn::Conv2d>() || m->as<nn::ConvTranspose2d>();
    const bool bn = m->as<nn::BatchNorm2d>() != nullptr;
    if (!conv && !bn) continue;
    for (auto& p : m->named_parameters(/*recurse=*/false)) {
      if (p.key() == "weight") p.value().normal_(bn ? 1.0 : 0.0, gain);
      if (p.key() == "bias") p.value().zero_();
    }
  }
}

int64_t count_parameters(const torch::nn::Module& net) {
  int64_t n = 0;
  for (const auto& p : net.parameters()) n += p.numel();
  return n;
}

}  // namespace reefgen::model
