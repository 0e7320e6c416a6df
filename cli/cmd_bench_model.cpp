// reefgen bench train | infer: pix2pix speed at the paper's setting, one JSON
// object on stdout. scripts/bench-model.sh runs these against the Python
// reference in the same session and prints the ratios (docs/BENCHMARKS.md).
#include <algorithm>
#include <chrono>
#include <cstdio>

#include "app.hpp"
#include "reefgen/files.hpp"
#include "reefgen/model/fast_unet.hpp"
#include "reefgen/model/torch_threads.hpp"
#include "reefgen/train/pix2pix.hpp"

namespace reefgen {

namespace {

int depth_for(int size) {
  int d = 0;
  while ((1 << (d + 1)) <= size && d < 8) ++d;
  return d;
}

struct BenchModelArgs {
  int ngf = 64, size = 256, reps = 5, threads = default_threads(), batch = 8;
  std::string upsample = "transpose", norm = "batch", precision = "fp32", engine = "onednn";
  bool no_winograd = false;
};

// pix2pix at the benchmark's size and options (the engine and precision train with).
train::Pix2PixOptions bench_options(const BenchModelArgs& a, bool training) {
  train::Pix2PixOptions o;
  o.g.ngf = a.ngf;
  o.g.depth = depth_for(a.size);
  try {
    o.g.upsample = model::upsample_from_string(a.upsample);
    o.g.norm = o.d.norm = model::norm_from_string(a.norm);
  } catch (const std::invalid_argument& e) {
    throw Error(e.what());
  }
  if (a.precision != "fp32" && a.precision != "bf16") throw Error("--precision: use fp32 or bf16");
  o.d.ndf = a.ngf;
  if (training) {
    if (a.precision == "bf16" && a.engine == "torch") throw Error("--precision bf16 needs --engine onednn");
    o.conv.engine = a.engine == "torch" ? model::ConvEngine::Torch : model::ConvEngine::OneDnn;
    o.conv.precision = a.precision == "bf16" ? model::ConvPrecision::Bf16 : model::ConvPrecision::Fp32;
  }
  return o;
}

// `bench train`: seconds per training iteration, median of --reps.
int bench_train(const BenchModelArgs& a, train::Pix2Pix& p, const torch::Tensor& x, const torch::Tensor& y) {
  std::vector<double> t;
  p.step(x, y);  // warm-up: allocations, oneDNN primitive creation
  for (int r = 0; r < a.reps; ++r) t.push_back(seconds_of([&] { p.step(x, y); }));
  std::printf("{\"bench\": \"train\", \"impl\": \"reefgen\", \"engine\": \"%s\", \"precision\": \"%s\", "
              "\"upsample\": \"%s\", \"norm\": \"%s\", \"ngf\": %d, \"size\": %d, \"threads\": %d, "
              "\"reps\": %d, \"s_per_iter\": %.4f}\n",
              a.engine.c_str(), a.precision.c_str(), a.upsample.c_str(), a.norm.c_str(), a.ngf, a.size,
              a.threads, a.reps, median(t));
  return 0;
}

// `bench infer`: ms per sketch with batch and running statistics, sketches/s in batches.
int bench_infer(const BenchModelArgs& a, train::Pix2Pix& p) {
  c10::InferenceMode inference;  // as infer_heights
  auto& g = p.G();
  const bool bf16 = a.precision == "bf16";
  if (bf16 && a.engine == "torch") {
    // As the LibTorch bf16 copy: every layer bf16 but the output convolution.
    for (auto& t : g->named_parameters())
      if (t.key().rfind("levels.0.up_conv.", 0) != 0) t.value().set_data(t.value().to(torch::kBFloat16));
    for (auto& t : g->buffers())
      if (t.is_floating_point()) t.set_data(t.to(torch::kBFloat16));
  }
  g->set_dropout_enabled(false);
  // Median seconds per forward of `n` sketches, G in train mode (batch
  // statistics, pix2pix's test time) or eval mode (running statistics).
  auto measure = [&](bool train_mode, int n, int reps) {
    g->train(train_mode);
    const auto xb = torch::rand({n, 3, a.size, a.size}) * 2 - 1;
    std::function<void()> f;
    std::shared_ptr<model::FastUNet> fast;
    if (a.engine == "onednn") {
      fast = std::make_shared<model::FastUNet>(
          *g, model::FastUNetOptions{n, a.size, bf16 ? model::FastPrecision::Bf16 : model::FastPrecision::Fp32,
                                     !a.no_winograd});
      f = [&] { fast->forward(xb); };
    } else {
      const auto xin = xb.to(bf16 ? torch::kBFloat16 : torch::kFloat32);
      f = [&, xin] { g->forward(xin); };
    }
    f();  // warm-up
    std::vector<double> ts;
    for (int r = 0; r < reps; ++r) ts.push_back(seconds_of(f));
    return median(ts);
  };
  const double batchstats = measure(true, 1, a.reps);
  const double running = measure(false, 1, a.reps);
  // Throughput: running statistics batch freely (batch statistics run one sketch per forward).
  const double batch_s = measure(false, a.batch, std::max(1, a.reps / 2));
  std::printf("{\"bench\": \"infer\", \"impl\": \"reefgen\", \"engine\": \"%s\", \"upsample\": \"%s\", \"norm\": \"%s\", \"precision\": \"%s\", "
              "\"ngf\": %d, \"size\": %d, \"threads\": %d, \"reps\": %d, \"ms_batchstats\": %.2f, \"ms_running_stats\": %.2f, \"batch\": %d, "
              "\"sketches_per_s\": %.2f}\n",
              a.engine.c_str(), a.upsample.c_str(), a.norm.c_str(), a.precision.c_str(), a.ngf, a.size, a.threads, a.reps,
              batchstats * 1e3, running * 1e3, a.batch, a.batch / batch_s);
  return 0;
}

int run_bench_model(const BenchModelArgs& a, bool training) {
  if (a.reps < 1 || a.threads < 1 || a.batch < 1) throw Error("--reps, --threads and --batch must be ≥ 1");
  if (a.size < 32 || a.size > 4096 || (a.size & (a.size - 1))) throw Error("--size " + std::to_string(a.size) + ": must be a power of two in 32..4096");
  model::use_torch_threads(a.threads);
  torch::manual_seed(1);
  train::Pix2Pix p(bench_options(a, training));
  // Drawn for both benches: the same random stream as before they were split.
  const auto x = torch::rand({1, 3, a.size, a.size}) * 2 - 1;
  const auto y = torch::rand({1, 1, a.size, a.size}) * 2 - 1;
  return training ? bench_train(a, p, x, y) : bench_infer(a, p);
}

}  // namespace

std::function<int()> add_bench_model_commands(CLI::App* bench) {
  auto a = std::make_shared<BenchModelArgs>();
  auto* tr = bench->add_subcommand("train", "seconds per pix2pix training iteration (batch 1), median of --reps");
  auto* in = bench->add_subcommand("infer", "ms per 256² sketch (model loaded once), median of --reps; sketches/s in batches");
  for (auto* s : {tr, in}) {
    s->add_option("--ngf", a->ngf, "G and D filters")->capture_default_str();
    s->add_option("--size", a->size, "Side of the square input (power of two ≥ 32)")->capture_default_str();
    s->add_option("--reps", a->reps, "Timed repetitions after one warm-up")->capture_default_str();
    s->add_option("--threads", a->threads, "LibTorch threads (default: all cores)");
  }
  in->add_option("--batch", a->batch, "Batch size for the throughput figure")->capture_default_str();
  in->add_flag("--no-winograd", a->no_winograd, "oneDNN's direct kernels for the whole decoder (the reference for Winograd's gain)");
  for (auto* s : {tr, in}) {
    s->add_option("--upsample", a->upsample, "G's decoder: transpose (pix2pix), nearest or bilinear")->capture_default_str();
    s->add_option("--norm", a->norm, "batch (pix2pix) or instance")->capture_default_str();
  }
  for (auto* s : {tr, in}) {
    s->add_option("--precision", a->precision, "fp32 or bf16")->capture_default_str();
    s->add_option("--engine", a->engine,
                  "onednn (reefgen's engines: what infer and train run) or torch (LibTorch's own kernels)")
        ->check(CLI::IsMember({"onednn", "torch"}))
        ->capture_default_str();
  }
  return [a, tr]() -> int { return run_bench_model(*a, tr->parsed()); };
}

}  // namespace reefgen
