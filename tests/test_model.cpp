// pix2pix networks: sizes, parameter counts, receptive field, and equality
// with the Python reference (scripts/reference/pix2pix_ref.py).
#include <cstdlib>
#include <thread>

#include <algorithm>
#include <array>
#include <iostream>

#include <gtest/gtest.h>

#include "reefgen/cpu.hpp"
#include "reefgen/model/fast_unet.hpp"
#include "reefgen/model/networks.hpp"
#include "reefgen/train/pix2pix.hpp"
#include "reference_io.hpp"

using namespace reefgen;
using model::PatchDiscriminator;
using model::UNetGenerator;

// LibTorch starts with one thread here; use the machine's cores.
static const bool kThreadsSet = [] {
  torch::set_num_threads(std::max(1u, std::thread::hardware_concurrency()));
  return true;
}();

TEST(Networks, ParameterCountsMatchPix2pixAtNgf64) {
  UNetGenerator g(model::UNetOptions{});
  PatchDiscriminator d(model::PatchOptions{});
  EXPECT_EQ(model::count_parameters(*g), 54409857);
  EXPECT_EQ(model::count_parameters(*d), 2766657);
}

TEST(Networks, ShapesAndOutputRange) {
  torch::manual_seed(1);
  model::UNetOptions go;
  go.ngf = 4;
  UNetGenerator g(go);
  model::init_pix2pix(*g);
  PatchDiscriminator d(model::PatchOptions{4, 4, 3, model::Norm::Batch});
  const auto x = torch::rand({2, 3, 256, 256}) * 2 - 1;
  const auto y = g->forward(x);
  EXPECT_EQ(y.sizes(), (std::vector<int64_t>{2, 1, 256, 256}));
  EXPECT_LE(y.abs().max().item<float>(), 1.0f);
  EXPECT_EQ(d->forward(torch::cat({x, y}, 1)).sizes(), (std::vector<int64_t>{2, 1, 30, 30}));
  // A side that is not a multiple of 2^depth is refused with the reason.
  try {
    g->forward(torch::zeros({1, 3, 100, 100}));
    FAIL() << "expected an error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("multiple of 256"), std::string::npos) << e.what();
  }
  EXPECT_THROW(UNetGenerator(model::UNetOptions{3, 1, 64, 4}), std::invalid_argument);
}

// 2-px checkerboard of a field: mean |h00 − h01 − h10 + h11| over 2×2 cells
// of the central half (away from the zero padding's border effects).
static double central_checkerboard(const torch::Tensor& y) {  // {1,1,S,S}
  const int64_t S = y.size(-1), a = S / 4, b = 3 * S / 4;
  const auto c = y[0][0].slice(0, a, b).slice(1, a, b);
  const auto e = c.slice(0, 0, c.size(0), 2), o = c.slice(0, 1, c.size(0), 2);
  const auto d = e.slice(1, 0, c.size(1), 2) - e.slice(1, 1, c.size(1), 2) - o.slice(1, 0, c.size(1), 2) +
                 o.slice(1, 1, c.size(1), 2);
  return d.abs().mean().item<double>();
}

// Resize-convolution cannot draw checkerboards: on a constant input the
// decoder sees constant (nearest-upsampled) maps, so the output is constant
// away from the border. The same net with transposed convolutions, same
// seed, draws the 2-px pattern (its even and odd outputs use different taps).
TEST(Networks, ResizeConvolutionHasNoCheckerboard) {
  auto run = [](model::Upsample u) {
    torch::manual_seed(3);
    model::UNetOptions o;
    o.ngf = 4;
    o.depth = 5;
    o.norm = model::Norm::None;
    o.upsample = u;
    UNetGenerator g(o);
    model::init_pix2pix(*g, 0.3);
    g->eval();
    torch::NoGradGuard ng;
    return g->forward(torch::full({1, 3, 256, 256}, 0.3f));
  };
  const double resize = central_checkerboard(run(model::Upsample::Nearest));
  const double transpose = central_checkerboard(run(model::Upsample::Transpose));
  EXPECT_LT(resize, 1e-6);
  EXPECT_GT(transpose, 1e-3);
  EXPECT_LT(central_checkerboard(run(model::Upsample::Bilinear)), 1e-6);
  EXPECT_EQ(model::upsample_from_string("bilinear"), model::Upsample::Bilinear);
  EXPECT_THROW(model::upsample_from_string("pixelshuffle"), std::invalid_argument);
}

TEST(Networks, PatchGanReceptiveFieldIs70) {
  PatchDiscriminator d(model::PatchOptions{4, 2, 3, model::Norm::None});
  model::init_pix2pix(*d);
  auto x = torch::randn({1, 4, 128, 128}).set_requires_grad(true);
  const auto logits = d->forward(x);  // {1,1,14,14}
  logits.index({0, 0, 7, 7}).backward();
  const auto touched = x.grad().abs().sum(std::vector<int64_t>{0, 1}).nonzero();  // {K,2} pixel coordinates
  const torch::Tensor lo = std::get<0>(touched.min(0));
  const torch::Tensor hi = std::get<0>(touched.max(0));
  EXPECT_EQ((hi - lo + 1).min().item<int64_t>(), 70);
  EXPECT_EQ((hi - lo + 1).max().item<int64_t>(), 70);
}

TEST(Networks, DropoutOnlyInTrainModeAndWhenEnabled) {
  torch::manual_seed(3);
  model::UNetOptions go;
  go.ngf = 2;
  UNetGenerator g(go);
  model::init_pix2pix(*g);
  const auto x = torch::rand({1, 3, 256, 256});
  torch::NoGradGuard no_grad;
  g->train();
  const auto a = g->forward(x), b = g->forward(x);
  EXPECT_FALSE(torch::equal(a, b)) << "dropout should make two train-mode passes differ";
  g->set_dropout_enabled(false);
  EXPECT_TRUE(torch::equal(g->forward(x), g->forward(x)));
}

// --- Equivalence with the reference --------------------------------------

namespace {
const char* reference_dir() { return std::getenv("REEFGEN_REFERENCE_DIR"); }

bool have_reference() {
  const char* dir = reference_dir();
  return dir && std::filesystem::exists(std::filesystem::path(dir) / "reference.json");
}

void skip_or_fail_without_reference() {
  if (std::getenv("REEFGEN_REQUIRE_REFERENCE"))
    FAIL() << "reference outputs missing in " << (reference_dir() ? reference_dir() : "(unset)")
           << " although REEFGEN_REQUIRE_REFERENCE is set: install python3-torch";
}

double max_abs_diff(const torch::Tensor& a, const torch::Tensor& b) {
  EXPECT_EQ(a.sizes(), b.sizes());
  return (a - b).abs().max().item<double>();
}

train::Pix2PixOptions options_of(const test::Reference& ref) {
  train::Pix2PixOptions o;
  o.g.ngf = ref.meta.at("ngf");
  o.g.depth = ref.meta.at("depth");
  o.d.ndf = ref.meta.at("ndf");
  return o;
}
}  // namespace

TEST(Reference, ForwardMatchesPythonWithin1e4) {
  if (!have_reference()) {
    skip_or_fail_without_reference();
    GTEST_SKIP() << "no Python reference (python3-torch absent): equivalence not checked";
  }
  const auto ref = test::load_reference(reference_dir());
  const auto o = options_of(ref);
  UNetGenerator g(o.g);
  PatchDiscriminator d(o.d);
  // Every tensor on both sides, same shapes: the same architecture.
  EXPECT_EQ(test::copy_weights(*g, ref, "G.") + test::copy_weights(*d, ref, "D."),
            ref.tensors.size() - 2 - 5);  // minus x, y and the five outputs
  EXPECT_EQ(model::count_parameters(*g), ref.meta.at("params_G").get<int64_t>());
  EXPECT_EQ(model::count_parameters(*d), ref.meta.at("params_D").get<int64_t>());
  const auto& x = ref.at("x");
  const auto& y = ref.at("y");
  torch::NoGradGuard no_grad;
  g->train();
  g->set_dropout_enabled(false);
  const model::FastUNetOptions fo{int(x.size(0)), int(x.size(-1)), model::FastPrecision::Fp32};
  // reefgen's oneDNN engine (what infer runs), built before the pass below
  // updates the running statistics: batch statistics do not depend on them.
  model::FastUNet fast_train(*g, fo);
  EXPECT_LT(max_abs_diff(g->forward(x), ref.at("out.G.train")), 1e-4) << "G, BatchNorm batch statistics";
  EXPECT_LT(max_abs_diff(fast_train.forward(x), ref.at("out.G.train")), 1e-4) << "oneDNN engine, batch statistics";
  g->eval();  // running statistics as updated by the pass above
  EXPECT_LT(max_abs_diff(g->forward(x), ref.at("out.G.eval")), 1e-4) << "G, BatchNorm running statistics";
  EXPECT_LT(max_abs_diff(model::FastUNet(*g, fo).forward(x), ref.at("out.G.eval")), 1e-4)
      << "oneDNN engine, running statistics";
  const auto xy = torch::cat({x, y}, 1);
  d->train();
  EXPECT_LT(max_abs_diff(d->forward(xy), ref.at("out.D.train")), 1e-4) << "D, train mode";
  d->eval();
  EXPECT_LT(max_abs_diff(d->forward(xy), ref.at("out.D.eval")), 1e-4) << "D, eval mode";
}

TEST(Reference, TwoTrainingStepsMatchPython) {
  if (!have_reference()) {
    skip_or_fail_without_reference();
    GTEST_SKIP() << "no Python reference (python3-torch absent): training step not checked";
  }
  const auto ref = test::load_reference(reference_dir());
  struct Run {
    std::vector<std::array<double, 4>> losses;
    std::vector<torch::Tensor> grads;  // G's gradients of the first step
    std::vector<torch::Tensor> d1;     // D's parameters after the first step
    torch::Tensor out;                 // G's eval output after both steps
  };
  auto train_two_steps = [&](model::ConvEngine engine, double input_scale) {
    train::Pix2PixOptions o = options_of(ref);
    o.conv.engine = engine;
    train::Pix2Pix p(o);
    test::copy_weights(*p.G(), ref, "G.");
    test::copy_weights(*p.D(), ref, "D.");
    p.G()->set_dropout_enabled(false);
    Run r;
    for (int s = 0; s < 2; ++s) {
      const train::Losses l = p.step(ref.at("x") * input_scale, ref.at("y"));
      r.losses.push_back({l.g_gan, l.g_l1, l.d_real, l.d_fake});
      if (s > 0) continue;
      for (const auto& w : p.G()->parameters()) r.grads.push_back(w.grad().to(torch::kFloat64).clone());
      for (const auto& w : p.D()->parameters()) r.d1.push_back(w.detach().clone());
    }
    torch::NoGradGuard no_grad;
    p.G()->eval();
    r.out = p.G()->forward(ref.at("x"));
    return r;
  };
  // G's loss of the first step (Pix2Pix::step's, the reference options: GAN +
  // λ·L1) and its gradients in float64, against D as `d1` left it.
  auto first_g_gradients_f64 = [&](const std::vector<torch::Tensor>& d1) {
    const train::Pix2PixOptions o = options_of(ref);
    train::Pix2Pix p(o);
    test::copy_weights(*p.G(), ref, "G.");
    p.G()->set_dropout_enabled(false);
    p.G()->train();
    p.D()->train();
    p.G()->to(torch::kFloat64);
    p.D()->to(torch::kFloat64);
    {
      torch::NoGradGuard no_grad;
      const auto dp = p.D()->parameters();
      for (size_t i = 0; i < dp.size(); ++i) dp[i].copy_(d1[i]);
    }
    const auto x = ref.at("x").to(torch::kFloat64), y = ref.at("y").to(torch::kFloat64);
    const auto fake = torch::tanh(p.G()->logits(x));
    const auto pred = p.D()->forward(torch::cat({x, fake}, 1));
    const auto loss = torch::nn::functional::binary_cross_entropy_with_logits(pred, torch::ones_like(pred)) +
                      (fake - y).abs().mean() * o.lambda_l1;
    loss.backward();
    std::vector<torch::Tensor> g;
    for (const auto& w : p.G()->parameters()) g.push_back(w.grad().clone());
    return g;
  };
  const Run lt = train_two_steps(model::ConvEngine::Torch, 1.0);
  const Run dn = train_two_steps(model::ConvEngine::OneDnn, 1.0);  // what `reefgen train` runs
  const auto& losses = ref.meta.at("losses");
  for (const Run* r : {&lt, &dn})
    for (int s = 0; s < 2; ++s)
      for (int k = 0; k < 4; ++k)
        EXPECT_NEAR(r->losses[s][k], losses[s][k].get<double>(), 1e-4 * std::max(1.0, std::abs(r->losses[s][k])))
            << (r == &lt ? "torch" : "onednn") << " engine, step " << s << " loss " << ref.meta.at("loss_names")[k];
  // The first step's gradients of every G parameter against the same step in
  // float64 (the exact sums, to fp32's eyes). A gradient is a sum of K
  // products (K = N·H·W of the layer's output) and any fp32 summation order
  // is off by at most γ_K·Σ|terms| (Higham, Accuracy and Stability of
  // Numerical Algorithms, §3.1): the bound depends on K and the magnitudes,
  // not on which order a CPU's kernels take. LibTorch's own fp32 error
  // against float64 measures that scale on this CPU's data (its largest over
  // the parameters: the layer with the largest K·Σ|terms| sets it); oneDNN's
  // kernels (another blocking, brgemm on AMX) are held to kOrderFactor times
  // it, never below the reference bars' 1e-4. Measured on an AVX2-only EPYC:
  // LibTorch 2.7e-5, oneDNN 6.4e-5; on a Sapphire Rapids (AMX) oneDNN stood
  // 1.4e-4 from LibTorch. A wrong kernel is off by the gradient's own size.
  constexpr double kOrderFactor = 16;
  const std::vector<torch::Tensor> exact = first_g_gradients_f64(lt.d1);
  ASSERT_EQ(lt.grads.size(), dn.grads.size());
  ASSERT_EQ(lt.grads.size(), exact.size());
  std::vector<double> lt_err, dn_err;
  for (size_t i = 0; i < lt.grads.size(); ++i) {
    const double scale = std::max(1.0, exact[i].abs().max().item<double>());
    lt_err.push_back(max_abs_diff(lt.grads[i], exact[i]) / scale);
    dn_err.push_back(max_abs_diff(dn.grads[i], exact[i]) / scale);
  }
  const double worst_lt = *std::max_element(lt_err.begin(), lt_err.end());
  const double worst_dn = *std::max_element(dn_err.begin(), dn_err.end());
  for (size_t i = 0; i < lt.grads.size(); ++i) {
    EXPECT_LT(lt_err[i], 1e-4) << "torch engine: gradient of G parameter " << i << " against float64";
    EXPECT_LT(dn_err[i], std::max(1e-4, kOrderFactor * worst_lt))
        << "onednn engine: gradient of G parameter " << i << " (LibTorch's largest fp32 error " << worst_lt << ")";
  }
  std::cerr << "[ gradient ] largest error against float64: torch " << worst_lt << ", onednn " << worst_dn << " ("
            << reefgen::cpu_summary() << ")\n";
  // The weights after two Adam steps: G's eval output. LibTorch's kernels
  // round as the reference does: within 1e-4.
  EXPECT_LT(max_abs_diff(lt.out, ref.at("out.G.after_steps")), 1e-4) << "torch engine";
  // Adam's first steps divide each gradient by its own magnitude, so
  // components that are rounding noise (BatchNorm over 2x2 maps cancels most
  // of a gradient) move weights by up to lr whatever their size. How far one
  // float rounding moves the result is measured here: LibTorch's own run with
  // its input scaled by (1 + 1e-7) (2.2e-4 on an AMD EPYC, where oneDNN
  // lands 1.4e-4 from the reference). Other correct
  // kernels (oneDNN's, whose rounding differs) are held to twice that.
  const double rounding = max_abs_diff(train_two_steps(model::ConvEngine::Torch, 1.0 + 1e-7).out, lt.out);
  EXPECT_GT(rounding, 0.0) << "the perturbation changed nothing: the bound below would be vacuous";
  EXPECT_LT(max_abs_diff(dn.out, ref.at("out.G.after_steps")), std::max(1e-4, 2.0 * rounding))
      << "onednn engine (one rounding of the input moves LibTorch's result by " << rounding << ")";
}
