// dnnl_conv2d (model/dnnl_conv.hpp): the training convolutions on oneDNN must
// compute what LibTorch's conv2d / conv_transpose2d compute — forward and the
// three gradients — for every shape the networks use and a few they do not.
#include <gtest/gtest.h>
#include "reefgen/cpu.hpp"
#include <torch/torch.h>

#include <set>

#include "reefgen/model/dnnl_conv.hpp"
#include "reefgen/model/networks.hpp"

using namespace reefgen::model;

namespace {

struct ConvCase {
  int64_t n, cin, cout, side, k, stride, pad;
  bool transposed, bias;
};

double rel_err(const torch::Tensor& a, const torch::Tensor& b) {
  return (a - b).abs().max().item<double>() / std::max(1.0, b.abs().max().item<double>());
}

// Forward and gradients of x, w and b, by both paths, for one loss.
struct Grads {
  torch::Tensor y, dx, dw, db;
};
Grads run(const ConvCase& c, bool dnnl, ConvPrecision prec = ConvPrecision::Fp32) {
  torch::manual_seed(7);
  auto x = torch::randn({c.n, c.cin, c.side, c.side}).requires_grad_();
  auto w = (c.transposed ? torch::randn({c.cin, c.cout, c.k, c.k}) : torch::randn({c.cout, c.cin, c.k, c.k}))
               .mul_(0.1)
               .requires_grad_();
  torch::Tensor b = c.bias ? torch::randn({c.cout}).requires_grad_() : torch::Tensor();
  torch::Tensor y;
  if (dnnl) y = dnnl_conv2d(x, w, b, {c.stride, c.pad, c.transposed}, prec);
  else y = c.transposed ? torch::conv_transpose2d(x, w, b, c.stride, c.pad) : torch::conv2d(x, w, b, c.stride, c.pad);
  // A loss whose gradient is not constant: exercises every output position.
  const auto weights = torch::linspace(-1, 1, y.numel()).reshape(y.sizes());
  (y * weights).sum().backward();
  return {y.detach(), x.grad(), w.grad(), c.bias ? b.grad() : torch::Tensor()};
}

}  // namespace

TEST(DnnlConv, MatchesLibTorchForwardAndGradientsWithin1e4) {
  // Sides ≤ 8 positions per axis run on the plain (GEMM) layout, larger ones
  // on oneDNN's packed layouts: both are covered.
  const std::vector<ConvCase> cases = {
      {1, 3, 8, 32, 4, 2, 1, false, true},    // G's first layer
      {2, 16, 32, 16, 4, 2, 1, false, false}, // encoder, batch 2, BatchNorm nets (no bias)
      {1, 32, 32, 2, 4, 2, 1, false, true},   // 2x2 -> 1x1 innermost
      {1, 8, 16, 17, 4, 1, 1, false, true},   // D's stride-1 layers (odd side)
      {1, 16, 1, 15, 4, 1, 1, false, true},   // D's output layer
      {1, 32, 16, 1, 4, 2, 1, true, false},   // innermost transposed 1x1 -> 2x2
      {2, 24, 8, 8, 4, 2, 1, true, true},     // decoder, channels not a multiple of 16
      {1, 16, 1, 16, 4, 2, 1, true, true},    // G's output layer
      {1, 12, 6, 16, 3, 1, 1, false, true},   // resize-convolution generator's 3x3
  };
  for (const ConvCase& c : cases) {
    const Grads a = run(c, false), b = run(c, true);
    const std::string what = std::string(c.transposed ? "transposed " : "") + std::to_string(c.cin) + "->" +
                             std::to_string(c.cout) + " k" + std::to_string(c.k) + " s" + std::to_string(c.stride) +
                             " @" + std::to_string(c.side);
    ASSERT_EQ(a.y.sizes(), b.y.sizes()) << what;
    EXPECT_LT(rel_err(b.y, a.y), 1e-4) << what << ": forward";
    EXPECT_LT(rel_err(b.dx, a.dx), 1e-4) << what << ": input gradient";
    EXPECT_LT(rel_err(b.dw, a.dw), 1e-4) << what << ": weight gradient";
    if (c.bias) {
      EXPECT_LT(rel_err(b.db, a.db), 1e-4) << what << ": bias gradient";
    }
    // Not a vacuous comparison: the outputs are far from zero.
    EXPECT_GT(a.y.abs().max().item<double>(), 0.1) << what;
  }
}

TEST(DnnlConv, Bf16StaysWithinBfloat16Rounding) {
  if (!bf16_convolution_available())
    GTEST_SKIP() << "no bf16 convolutions on this CPU (" << reefgen::cpu_summary() << "): bf16 needs AVX-512";
  // Packed (16x16 input) and plain (4x4 input: ≤ 64 positions) layers.
  for (const ConvCase& c : {ConvCase{1, 64, 32, 16, 4, 2, 1, true, true}, ConvCase{1, 64, 32, 4, 4, 2, 1, true, true},
                        ConvCase{1, 64, 32, 16, 4, 2, 1, false, true}}) {
  const Grads a = run(c, false), b = run(c, true, ConvPrecision::Bf16);
  // bf16 keeps 8 bits of mantissa (relative rounding 2^-9 per operand); sums
  // of 256 terms in float32 stay within ~1 %.
  EXPECT_LT(rel_err(b.y, a.y), 2e-2);
  EXPECT_LT(rel_err(b.dx, a.dx), 2e-2);
  EXPECT_LT(rel_err(b.dw, a.dw), 2e-2);
  EXPECT_GT(rel_err(b.y, a.y), 0.0) << "bf16 changed nothing: the float32 path ran";
  }
}

TEST(DnnlConv, PackedWeightsFollowInPlaceUpdates) {
  torch::manual_seed(3);
  auto w = torch::randn({32, 32, 4, 4}).requires_grad_();
  const auto x = torch::randn({1, 32, 32, 32});  // 16x16 outputs: blocked, packed weights
  size_t held = 0;
  {  // the outputs' autograd graphs hold w: let them go before w is freed
    const auto y1 = dnnl_conv2d(x, w, {}, {2, 1, false});
    {
      torch::NoGradGuard ng;
      w.mul_(2.0);  // as an optimiser step does: in place, version bumped
    }
    const auto y2 = dnnl_conv2d(x, w, {}, {2, 1, false});
    EXPECT_LT(rel_err(y2, y1 * 2.0), 1e-5) << "a stale packed copy of the weights was used";
    held = dnnl_weight_cache_size();
    EXPECT_GE(held, 1u) << "32 channels are packed into a blocked layout, so a copy is cached";
  }
  w = torch::Tensor();  // the parameter is freed: its packed copy goes at the next lookup
  auto w2 = torch::randn({32, 32, 4, 4});
  dnnl_conv2d(x, w2, {}, {2, 1, false});
  EXPECT_LE(dnnl_weight_cache_size(), held);
}

TEST(DnnlConv, RefusesMismatchedShapes) {
  const auto x = torch::randn({1, 4, 8, 8});
  EXPECT_THROW(dnnl_conv2d(x, torch::randn({8, 5, 4, 4}), {}, {2, 1, false}), std::invalid_argument);
  EXPECT_THROW(dnnl_conv2d(x, torch::randn({8, 4, 4, 4}), torch::randn({3}), {2, 1, false}), std::invalid_argument);
  EXPECT_THROW(dnnl_conv2d(x.to(torch::kFloat64), torch::randn({8, 4, 4, 4}), {}, {2, 1, false}), std::invalid_argument);
  EXPECT_THROW(dnnl_conv2d(x, torch::randn({8, 4, 4, 4}), {}, {0, 1, false}), std::invalid_argument);
}

namespace {
// Autograd nodes of y's graph whose name contains `part`.
int count_nodes(const torch::Tensor& y, const std::string& part) {
  std::set<torch::autograd::Node*> seen;
  std::vector<torch::autograd::Node*> todo{y.grad_fn().get()};
  int n = 0;
  while (!todo.empty()) {
    auto* node = todo.back();
    todo.pop_back();
    if (!node || !seen.insert(node).second) continue;
    if (node->name().find(part) != std::string::npos) ++n;
    for (const auto& e : node->next_edges()) todo.push_back(e.function.get());
  }
  return n;
}
}  // namespace

TEST(DnnlConv, NetworksUseItOnlyWhenAsked) {
  UNetOptions go;
  go.ngf = 4;
  go.depth = 5;
  go.upsample = Upsample::Transpose;
  UNetGenerator g(go);
  PatchOptions po;
  po.ndf = 4;
  PatchDiscriminator d(po);
  const auto x = torch::rand({1, 3, 32, 32});
  EXPECT_EQ(count_nodes(g->forward(x), "DnnlConv"), 0);
  g->set_conv({ConvEngine::OneDnn, ConvPrecision::Fp32});
  d->set_conv({ConvEngine::OneDnn, ConvPrecision::Fp32});
  const auto y = g->forward(x);
  EXPECT_EQ(count_nodes(y, "DnnlConv"), 2 * go.depth) << "every down and up convolution of G";
  EXPECT_EQ(count_nodes(d->forward(torch::cat({x, y}, 1)), "DnnlConv"), 2 * go.depth + po.n_layers + 2)
      << "D's convolutions on top of G's";
  go.upsample = Upsample::Bilinear;
  UNetGenerator r(go);
  r->set_conv({ConvEngine::OneDnn, ConvPrecision::Fp32});
  EXPECT_EQ(count_nodes(r->forward(x), "DnnlConv"), 2 * go.depth) << "resize-convolution generator";
}
