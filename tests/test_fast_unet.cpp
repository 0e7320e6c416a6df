// The oneDNN inference engine (model/fast_unet): the same function as
// UNetGenerator::forward for every architecture and mode it accepts, the same
// bytes whatever the thread count, bf16 within the height bars of float32,
// and clear refusals.
#include <algorithm>
#include <thread>

#include <gtest/gtest.h>

#include "reefgen/model/dnnl_conv.hpp"
#include "reefgen/model/fast_unet.hpp"
#include "reefgen/model/generator_file.hpp"
#include "reefgen/model/networks.hpp"
#include "reefgen/labels.hpp"
#include "reefgen/model/codec.hpp"
#include "test_util.hpp"
#include "shipped_inputs.hpp"
#include "bf16_bounds.hpp"

using namespace reefgen;
using model::FastPrecision;
using model::FastUNet;
using model::FastUNetOptions;
using model::Norm;
using model::UNetGenerator;
using model::UNetOptions;
using model::Upsample;
using test::painted_inputs_256;
using test::PaintedInput;
using test::shipped_generator;
using test::bf16_mean_bound_m;

static const int kCores = int(std::max(1u, std::thread::hardware_concurrency()));
static const bool kThreadsSet = [] {
  torch::set_num_threads(kCores);
  return true;
}();

namespace {

// A small net with non-trivial BatchNorm affine weights and running
// statistics (pix2pix's init leaves them at N(1, .02) and 0/1).
UNetGenerator net(Upsample up, Norm norm, int ngf, int depth, uint64_t seed) {
  torch::manual_seed(seed);
  UNetOptions o;
  o.ngf = ngf;
  o.depth = depth;
  o.norm = norm;
  o.upsample = up;
  UNetGenerator g(o);
  model::init_pix2pix(*g, 0.08);  // larger than 0.02 so that every layer matters to the output
  torch::NoGradGuard ng;
  for (auto& b : g->named_buffers()) {
    if (b.key().find("running_mean") != std::string::npos) b.value().uniform_(-0.3, 0.3);
    if (b.key().find("running_var") != std::string::npos) b.value().uniform_(0.5, 2.0);
  }
  for (auto& p : g->named_parameters())
    if (p.key().find(".bn.bias") != std::string::npos) p.value().uniform_(-0.2, 0.2);
  return g;
}

float max_diff(const torch::Tensor& a, const torch::Tensor& b) { return (a - b).abs().max().item<float>(); }

struct Case {
  Upsample up;
  Norm norm;
  bool train;  // BatchNorm batch statistics (pix2pix test time) vs running statistics
  int batch;
};

std::string name(const Case& c) {
  return model::to_string(c.up) + "/" + model::to_string(c.norm) + (c.train ? "/batch-stats" : "/running-stats") +
         "/N=" + std::to_string(c.batch);
}

}  // namespace

TEST(FastUNet, EqualsLibTorchForwardWithin1e4) {
  std::vector<Case> cases;
  for (Upsample up : {Upsample::Transpose, Upsample::Nearest, Upsample::Bilinear})
    for (Norm n : {Norm::Batch, Norm::Instance, Norm::None})
      for (bool train : {true, false})
        for (int batch : {1, 2}) {
          if (n != Norm::Batch && !train) continue;  // running statistics exist for BatchNorm only
          cases.push_back({up, n, train, batch});
        }
  c10::InferenceMode im;
  uint64_t seed = 1;
  for (const Case& c : cases) {
    // ngf 16 / depth 6 at 64²: every level kind (outermost, inner with norm,
    // 1×1 innermost) and channel counts that are and are not multiples of 16.
    for (int ngf : {16, 6}) {
      UNetGenerator g = net(c.up, c.norm, ngf, 6, seed++);
      g->train(c.train);
      g->set_dropout_enabled(false);
      const torch::Tensor x = torch::rand({c.batch, 3, 64, 64}) * 2 - 1;
      FastUNet fast(*g, FastUNetOptions{c.batch, 64, FastPrecision::Fp32});
      const torch::Tensor want = g->forward(x);
      const torch::Tensor got = fast.forward(x);
      ASSERT_EQ(got.sizes(), want.sizes()) << name(c);
      EXPECT_LT(max_diff(got, want), 1e-4) << name(c) << " ngf " << ngf;
      EXPECT_GT(want.std().item<float>(), 0.02) << name(c) << ": the test net must not be flat";
    }
  }
}

TEST(FastUNet, FailsWhenAWeightChanges) {
  // The comparison above would pass for an engine that ignored some layer if
  // that layer did not matter: perturbing one deep weight must move the output.
  c10::InferenceMode im;
  UNetGenerator g = net(Upsample::Transpose, Norm::Batch, 16, 6, 99);
  g->train(true);
  g->set_dropout_enabled(false);
  const torch::Tensor x = torch::rand({1, 3, 64, 64}) * 2 - 1;
  FastUNet before(*g, FastUNetOptions{1, 64, FastPrecision::Fp32});
  // (Scaling would not do: BatchNorm after it normalises a scale away.)
  g->named_parameters()["levels.4.up_conv.weight"].add_(torch::randn_like(g->named_parameters()["levels.4.up_conv.weight"]) * 0.08);
  FastUNet after(*g, FastUNetOptions{1, 64, FastPrecision::Fp32});
  EXPECT_GT(max_diff(before.forward(x), after.forward(x)), 1e-3);
  EXPECT_LT(max_diff(after.forward(x), g->forward(x)), 1e-4);
}

TEST(FastUNet, SameBytesWhateverTheThreadCount) {
  c10::InferenceMode im;
  for (FastPrecision p : {FastPrecision::Fp32, FastPrecision::Bf16}) {
    for (Upsample up : {Upsample::Transpose, Upsample::Bilinear}) {
      UNetGenerator g = net(up, Norm::Instance, 32, 7, 7);
      g->train(true);
      g->set_dropout_enabled(false);
      const torch::Tensor x = torch::rand({1, 3, 128, 128}) * 2 - 1;
      torch::Tensor y1, yn;
      try {
        torch::set_num_threads(1);
        y1 = FastUNet(*g, FastUNetOptions{1, 128, p}).forward(x);
        torch::set_num_threads(std::max(2, kCores));
        yn = FastUNet(*g, FastUNetOptions{1, 128, p}).forward(x);
      } catch (const std::runtime_error& e) {
        torch::set_num_threads(kCores);
        if (p == FastPrecision::Bf16 && !model::bf16_convolution_available())
          GTEST_SKIP() << "no bf16 convolutions on this CPU: " << e.what();
        throw;
      }
      torch::set_num_threads(kCores);
      EXPECT_TRUE(torch::equal(y1, yn)) << (p == FastPrecision::Bf16 ? "bf16 " : "fp32 ") << model::to_string(up)
                                        << ": max diff " << max_diff(y1, yn);
    }
  }
}

TEST(FastUNet, ShippedModelFp32AndBf16WithinTheHeightBars) {
  // The model users run, on the painted test sketches: fp32 equals LibTorch
  // to a centimetre; bf16 stays within 1 m of float32 at the 99th percentile
  // on each sketch (the product's bar) and within its mantissa's bound on
  // average (bf16_bounds.hpp: a CPU's kernels may round in another order).
  model::GeneratorFile gf = shipped_generator();
  c10::InferenceMode im;
  const double half_span_m = (gf.range.hi_m - gf.range.lo_m) / 2;
  FastUNet f32(*gf.g, FastUNetOptions{1, 256, FastPrecision::Fp32});
  std::unique_ptr<FastUNet> b16;
  try {
    b16 = std::make_unique<FastUNet>(*gf.g, FastUNetOptions{1, 256, FastPrecision::Bf16});
  } catch (const std::runtime_error& e) {
    if (model::bf16_convolution_available()) throw;
    std::cerr << "no bf16 convolutions on this CPU, bf16 not checked: " << e.what() << "\n";
  }
  const double mean_bound_m = bf16_mean_bound_m(gf.g, gf.range.lo_m, gf.range.hi_m);
  const std::vector<PaintedInput> painted = painted_inputs_256();
  for (const PaintedInput& p : painted) {
    const torch::Tensor ref = gf.g->forward(p.x);
    EXPECT_LT(max_diff(f32.forward(p.x), ref) * half_span_m, 0.01) << p.name << ": fp32 engine, metres";
    if (!b16) continue;
    const torch::Tensor err_m = (b16->forward(p.x) - ref).abs().flatten() * half_span_m;
    const double p99 = std::get<0>(err_m.sort()).index({int64_t(0.99 * double(err_m.numel()))}).item<double>();
    EXPECT_LT(p99, 1.0) << p.name << ": bf16 p99 error, metres";
    EXPECT_LT(err_m.mean().item<double>(), mean_bound_m) << p.name << ": bf16 mean error, metres";
    EXPECT_GT(err_m.max().item<double>(), 0.0) << "bf16 must actually run in bf16";
  }
  EXPECT_GE(painted.size(), 10u) << "painted sketches at 256²";
}

// The shipped generator parks no cell of its answers in tanh's flat tail,
// where no loss can move it: a generator whose logits reached −80 at the
// canvas's top-left drew a fixed pattern there once trained on a floor with
// relief (docs/MODEL.md "Saturated cells"). Over the painted sketches, the
// logits stay within ±kLogitCeiling, and the corners painted abyss get
// alike answers (the highest of each one's 8×8 cells).
TEST(FastUNet, ShippedModelParksNoCellInTanhsTail) {
  constexpr double kLogitCeiling = 6;     // tanh′(6) = 2.5e-5: still a gradient; training bounds at 3.8
  constexpr double kCornerSpreadM = 15;   // the corners' 8×8 maxima (metres) agree within this
  model::GeneratorFile gf = shipped_generator();
  c10::InferenceMode im;
  const double half_span_m = (gf.range.hi_m - gf.range.lo_m) / 2;
  const std::vector<PaintedInput> painted = painted_inputs_256();
  int compared = 0;
  for (const PaintedInput& p : painted) {
    const torch::Tensor z = gf.g->logits(p.x)[0][0];  // {256,256}
    EXPECT_LT(z.abs().max().item<double>(), kLogitCeiling) << p.name;
    // The 8×8 answer's highest cell, metres, at the corners painted abyss 16 cells deep.
    std::vector<double> corners;
    for (const int64_t r : {0, 248})
      for (const int64_t c : {0, 248}) {
        const cv::Mat1b near = p.sketch.label(cv::Rect(int(c == 0 ? 0 : 240), int(r == 0 ? 0 : 240), 16, 16));
        if (cv::countNonZero(near != uint8_t(kAbyss)) > 0) continue;
        corners.push_back((torch::tanh(z.slice(0, r, r + 8).slice(1, c, c + 8)).max().item<double>() + 1) * half_span_m +
                          gf.range.lo_m);
      }
    if (corners.size() < 2) continue;
    ++compared;
    const auto [lo, hi] = std::minmax_element(corners.begin(), corners.end());
    EXPECT_LT(*hi - *lo, kCornerSpreadM) << p.name << ": the abyss corners' highest cells differ by " << *hi - *lo
                                         << " m";
  }
  EXPECT_GE(compared, 10) << "painted sketches with at least two abyss corners";
  EXPECT_GE(painted.size(), 10u) << "painted sketches at 256²";
}

TEST(FastUNet, RefusesWhatItCannotRun) {
  UNetGenerator g = net(Upsample::Bilinear, Norm::Batch, 8, 6, 3);
  g->train(true);
  g->set_dropout_enabled(true);  // stochastic inference: dropout masks
  EXPECT_NE(model::fast_unet_unsupported(*g), "");
  EXPECT_THROW(FastUNet(*g, FastUNetOptions{1, 64, FastPrecision::Fp32}), std::invalid_argument);
  g->set_dropout_enabled(false);
  EXPECT_EQ(model::fast_unet_unsupported(*g), "");
  EXPECT_THROW(FastUNet(*g, FastUNetOptions{1, 48, FastPrecision::Fp32}), std::invalid_argument);  // not a multiple of 64
  EXPECT_THROW(FastUNet(*g, FastUNetOptions{0, 64, FastPrecision::Fp32}), std::invalid_argument);
  FastUNet fast(*g, FastUNetOptions{1, 64, FastPrecision::Fp32});
  try {
    fast.forward(torch::zeros({2, 3, 64, 64}));
    FAIL() << "expected an error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("{1,3,64,64}"), std::string::npos) << e.what();
  }
}

// The Winograd decoder (winograd_up.hpp) against oneDNN's direct parity
// convolutions: a 256² input puts levels 1-3 at sides 64, 32 and 16, where it
// is used (16 with sgemm only). Equal within float rounding (1e-5 of the
// output range), different bits (the path ran), batched too, and the same
// bytes whatever the thread count, with either GEMM backend; a backend name
// it does not know is refused by name.
TEST(FastUNet, WinogradDecoderEqualsDirectConvolutions) {
  c10::InferenceMode im;
  // Both GEMM backends on any CPU: this CPU's own and the other one, forced.
  for (const char* gemm : {"sgemm", "matmul"}) {
    const test::ScopedEnv force("REEFGEN_WINOGRAD_GEMM", gemm);
    for (int batch : {1, 2}) {
      UNetGenerator g = net(Upsample::Transpose, Norm::Batch, 8, 8, 11);
      g->train(true);
      g->set_dropout_enabled(false);
      const torch::Tensor x = torch::rand({batch, 3, 256, 256}) * 2 - 1;
      FastUNetOptions direct{batch, 256, FastPrecision::Fp32, false}, wino{batch, 256, FastPrecision::Fp32, true};
      const torch::Tensor yd = FastUNet(*g, direct).forward(x);
      torch::set_num_threads(1);
      const torch::Tensor y1 = FastUNet(*g, wino).forward(x);
      torch::set_num_threads(std::max(2, kCores));
      const torch::Tensor yn = FastUNet(*g, wino).forward(x);
      torch::set_num_threads(kCores);
      const std::string what = std::string(gemm) + " batch " + std::to_string(batch);
      EXPECT_LT(max_diff(yd, y1), 1e-5) << what;
      EXPECT_GT(max_diff(yd, y1), 0.0) << what << ": the Winograd path did not run";
      EXPECT_TRUE(torch::equal(y1, yn)) << what << ": thread count changed the bytes, max diff " << max_diff(y1, yn);
      // And LibTorch's own forward, the definition.
      EXPECT_LT(max_diff(g->forward(x), y1), 1e-4) << what;
    }
  }
  const test::ScopedEnv unknown("REEFGEN_WINOGRAD_GEMM", "blas");
  UNetGenerator g = net(Upsample::Transpose, Norm::Batch, 8, 8, 11);
  g->set_dropout_enabled(false);
  try {
    FastUNet(*g, FastUNetOptions{1, 256, FastPrecision::Fp32, true});
    ADD_FAILURE() << "REEFGEN_WINOGRAD_GEMM=blas was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("REEFGEN_WINOGRAD_GEMM='blas'"), std::string::npos) << e.what();
  }
}
