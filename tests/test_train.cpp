// Training on tiny settings (ngf 4-8, 64x64, a dozen pairs): learning on a
// fixed batch, resume = uninterrupted, checkpoint and generator round trips,
// data loading and jitter alignment, config and file errors.
#include <fstream>
#include <functional>
#include <optional>
#include <sstream>
#include <thread>

#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "reefgen/age.hpp"
#include "reefgen/image_io.hpp"
#include "reefgen/labels.hpp"
#include "reefgen/model/generator_file.hpp"
#include "reefgen/procgen/generator.hpp"
#include "reefgen/procgen/random_spec.hpp"
#include "reefgen/train/data.hpp"
#include "reefgen/train/trainer.hpp"
#include "test_util.hpp"
#include "train_fixture.hpp"

using namespace reefgen;
using namespace reefgen::train;
using test::expect_error_naming;
using test::make_dataset;
using test::temp_dir;
using test::tiny_params;
using nlohmann::json;

namespace {

void expect_same_weights(torch::nn::Module& a, torch::nn::Module& b) {
  const auto pa = a.named_parameters(), pb = b.named_parameters();
  ASSERT_EQ(pa.size(), pb.size());
  for (const auto& kv : pa) EXPECT_TRUE(torch::equal(kv.value(), pb[kv.key()])) << kv.key();
  const auto ba = a.named_buffers(), bb = b.named_buffers();
  for (const auto& kv : ba) EXPECT_TRUE(torch::equal(kv.value(), bb[kv.key()])) << kv.key();
}

// Log rows without the two timing columns (s_per_iter, allreduce_s).
std::string log_without_timing(const fs::path& p) {
  std::ifstream in(p);
  std::string line, out;
  while (std::getline(in, line)) {
    line = line.substr(0, line.rfind(','));
    out += line.substr(0, line.rfind(',')) + "\n";
  }
  return out;
}

RunOptions run_in(const fs::path& data, const fs::path& out) {
  RunOptions r;
  r.data = data;
  r.out = out;
  return r;
}

// One step of a tiny pix2pix (ngf 8, U-Net depth 5, ndf 8; the rest from
// `o`) on a fixed 32² pair, dropout off; with step_seed, torch's generator
// is reseeded before the step, as the trainer does.
Losses tiny_step(Pix2PixOptions o, std::optional<uint64_t> step_seed = std::nullopt) {
  torch::manual_seed(3);
  o.g.ngf = 8;
  o.g.depth = 5;
  o.d.ndf = 8;
  Pix2Pix p(o);
  p.G()->set_dropout_enabled(false);
  torch::manual_seed(4);
  const auto label = torch::rand({1, 3, 32, 32}) * 2 - 1;
  if (step_seed) torch::manual_seed(*step_seed);
  return p.step(label, torch::tanh(label.sum(1, true)));
}

struct Loaded {
  Pix2Pix p;
  int64_t step;
};
Loaded load_run(const fs::path& run, const TrainParams& params) {
  Pix2Pix p(pix2pix_options(params));
  const int64_t step = load_checkpoint(run / "checkpoint.pt", p, params, nullptr);
  return {std::move(p), step};
}

}  // namespace

TEST(TrainParams, JsonRoundTripAndErrors) {
  // Every field off its default and back (torch + bf16 is refused, so bf16's
  // neighbour "auto" stands in for the precision).
  test::expect_params_round_trip<TrainParams>([](const json& j) { return train_params_from_json(j, "test"); },
                                              [](TrainParams& p) { p.precision = "auto"; });
  expect_error_naming([] { train_params_from_json(json{{"lr", -1.0}}, "cfg.json"); }, "lr");
  expect_error_naming([] { train_params_from_json(json{{"learning_rate", 0.1}}, "cfg.json"); }, "learning_rate");
  expect_error_naming([] { train_params_from_json(json{{"norm", "layer"}}, "cfg.json"); }, "norm");
  expect_error_naming([] { train_params_from_json(json{{"engine", "cuda"}}, "cfg.json"); }, "engine");
  expect_error_naming([] { train_params_from_json(json{{"precision", "fp16"}}, "cfg.json"); }, "precision");
  expect_error_naming([] { train_params_from_json(json{{"engine", "torch"}, {"precision", "bf16"}}, "cfg.json"); },
                      "needs engine = 'onednn'");
  expect_error_naming([] { train_params_from_json(json{{"depth", 3}}, "cfg.json"); }, "depth");
  expect_error_naming([] { train_params_from_json(json{{"ngf", "many"}}, "cfg.json"); }, "cfg.json");
  expect_error_naming([] { train_params_from_json(json{{"epochs", 0}, {"epochs_decay", 0}}, "cfg.json"); }, "epochs");
}

// Where a run's params come from: --config, else a resumed run's run.json,
// else the defaults; flags (overrides) win over each; errors name the source.
TEST(TrainParams, RunParamsFromConfigRunJsonOrDefaults) {
  const fs::path d = temp_dir("run_params");
  const TrainParams defaults;
  EXPECT_EQ(json(train_params_for_run("", d, false, json::object())), json(defaults));
  TrainParams saved;
  saved.ngf = 8;
  saved.seed = 5;
  write_json_atomic(d / "run.json", json{{"config", json(saved)}, {"step", 3}});
  EXPECT_EQ(train_params_for_run("", d, true, json::object()).ngf, 8) << "resume reads run.json";
  EXPECT_EQ(train_params_for_run("", d, false, json::object()).ngf, defaults.ngf) << "a fresh run ignores it";
  write_json_atomic(d / "cfg.json", json{{"ngf", 16}, {"lr", 1e-4}});
  const TrainParams c = train_params_for_run((d / "cfg.json").string(), d, true, json{{"seed", 9}});
  EXPECT_EQ(c.ngf, 16) << "--config wins over run.json";
  EXPECT_EQ(c.lr, 1e-4);
  EXPECT_EQ(c.seed, 9u) << "a flag wins over the config";
  expect_error_naming([&] { train_params_for_run((d / "cfg.json").string(), d, false, json{{"ngf", -1}}); },
                      "cfg.json with the command-line flags");
  write_json_atomic(d / "run.json", json{{"step", 3}});
  expect_error_naming([&] { train_params_for_run("", d, true, json::object()); }, "run.json: no \"config\"");
  expect_error_naming([&] { train_params_for_run((d / "missing.json").string(), d, false, json::object()); },
                      "missing.json");
  fs::remove_all(d);
}

TEST(TrainParams, LearningRateConstantThenLinearToZero) {
  TrainParams p;
  p.lr = 2e-4;
  EXPECT_DOUBLE_EQ(lr_at(p, 0, 10, 4), 2e-4);
  EXPECT_DOUBLE_EQ(lr_at(p, 9, 10, 4), 2e-4);
  EXPECT_DOUBLE_EQ(lr_at(p, 10, 10, 4), 2e-4 * 4 / 5);
  EXPECT_DOUBLE_EQ(lr_at(p, 13, 10, 4), 2e-4 * 1 / 5);
  EXPECT_DOUBLE_EQ(lr_at(p, 14, 10, 4), 0.0);
}

// The shore weighting against a hand computation: two cells, one at sea level
// (weight 1 + extra) and one far below it (weight ~1).
TEST(Train, ShoreWeightedL1MatchesHandComputation) {
  TrainParams params;
  params.l1_shore_weight = 9;
  params.l1_shore_m = 3;
  const model::HeightRange range{-100, 560};
  const Pix2PixOptions o = pix2pix_options(params, range);
  const double per_m = 2.0 / 660.0;
  EXPECT_NEAR(o.l1.sea, 100 * per_m - 1, 1e-12);
  EXPECT_NEAR(o.l1.band, 3 * per_m, 1e-12);
  const float sea = static_cast<float>(o.l1.sea), deep = -1.0f;
  const torch::Tensor truth = torch::tensor({sea, deep}).view({1, 1, 1, 2});
  const torch::Tensor fake = torch::tensor({sea + 0.1f, deep + 0.3f}).view({1, 1, 1, 2});
  // The deep cell lies 100 m = 33 bands below the sea: its weight is 1.
  const double expected = (10 * 0.1 + 1 * 0.3) / 11.0;
  EXPECT_NEAR(weighted_l1(fake, truth, o.l1).item<double>(), expected, 1e-6);
  // extra 0 is pix2pix's plain mean, bit for bit.
  L1Weighting plain = o.l1;
  plain.extra = 0;
  EXPECT_TRUE(torch::equal(weighted_l1(fake, truth, plain), torch::nn::functional::l1_loss(fake, truth)));
  // The gradient reaches the fake and is larger at the shore.
  torch::Tensor f = fake.clone().requires_grad_(true);
  weighted_l1(f, truth, o.l1).backward();
  const auto g = f.grad().flatten();
  EXPECT_NEAR(g[0].item<double>(), 10.0 / 11.0, 1e-6);
  EXPECT_NEAR(g[1].item<double>(), 1.0 / 11.0, 1e-6);
}

TEST(Train, SlopeL1ChargesAShapeThatL1Forgives) {
  // A cone's profile 0, 1, 2, 3, 4 against one with a bench: 0, 1, 2, 2, 4
  // (one cell 1 low). Per-cell L1: 1/5. Slopes: truth 1,1,1,1; bench
  // 1,1,0,2: |Δ| errors 0,0,1,1 -> 2/4 along x, 0 along y; halved: 1/4.
  const torch::Tensor truth = torch::tensor({0.f, 1.f, 2.f, 3.f, 4.f}).view({1, 1, 1, 5}).repeat({1, 1, 2, 1});
  const torch::Tensor bench = torch::tensor({0.f, 1.f, 2.f, 2.f, 4.f}).view({1, 1, 1, 5}).repeat({1, 1, 2, 1});
  EXPECT_NEAR(torch::nn::functional::l1_loss(bench, truth).item<double>(), 0.2, 1e-6);
  EXPECT_NEAR(slope_l1(bench, truth).item<double>(), 0.25, 1e-6);
  // A uniform offset keeps every slope: no charge.
  EXPECT_NEAR(slope_l1(truth + 3, truth).item<double>(), 0.0, 1e-7);
  // The gradient pulls the bench cell up: it reaches fake, with the sign that lowers the loss.
  torch::Tensor f = bench.clone().requires_grad_(true);
  slope_l1(f, truth).backward();
  EXPECT_LT(f.grad()[0][0][0][3].item<double>(), 0.0);
  // lambda_slope reaches the options, and a step with it reports the larger reconstruction term.
  TrainParams params;
  params.lambda_slope = 500;
  EXPECT_EQ(pix2pix_options(params).lambda_slope, 500);
  const auto loss_with = [](double lambda_slope) {
    Pix2PixOptions o;
    o.lambda_slope = lambda_slope;
    return tiny_step(o).g_l1;
  };
  EXPECT_GT(loss_with(500), loss_with(0));
}

// rise_l1 charges a ring valley on a cone (a fall along the truth's uphill
// direction where the truth rises) and not an offset of the same per-cell L1,
// nor a valley running down the cone; its gradient reaches fake.
TEST(Train, RiseL1ChargesARingAndNotAnOffsetOrARadialValley) {
  const int64_t S = 64;
  const torch::Tensor y = torch::arange(S, torch::kFloat32).view({1, 1, S, 1}).expand({1, 1, S, S}) - 31.5;
  const torch::Tensor x = torch::arange(S, torch::kFloat32).view({1, 1, 1, S}).expand({1, 1, S, S}) - 31.5;
  const torch::Tensor r = torch::sqrt(x * x + y * y);
  const double sea = -0.5;
  const torch::Tensor cone = 0.8 - 0.05 * r;  // land (above sea) within r = 26
  const torch::Tensor ring = cone - 0.2 * torch::exp(-torch::pow((r - 12) / 2, 2));
  const float c = (ring - cone).abs().mean().item<float>();
  // A valley 0.2 deep down the ray y = 0, x > 0, full depth from r 6 to 18.
  const torch::Tensor along = torch::clamp(torch::min((r - 4) / 2, (20 - r) / 2), 0, 1) * (x > 0).to(torch::kFloat32);
  const torch::Tensor valley = cone - 0.2 * torch::exp(-torch::pow(y / 1.5, 2)) * along;
  const double charge_ring = rise_l1(ring, cone, sea).item<double>();
  EXPECT_GT(charge_ring, 0.005);
  EXPECT_LT(rise_l1(cone + c, cone, sea).item<double>(), 1e-6);
  EXPECT_NEAR(rise_l1(cone, cone, sea).item<double>(), 0.0, 1e-7);
  EXPECT_LT(rise_l1(valley, cone, sea).item<double>(), 0.25 * charge_ring)
      << "a valley down the cone is charged like a ring (per-cell L1 " << (valley - cone).abs().mean().item<double>()
      << " against the ring's " << c << ")";
  torch::Tensor f = ring.clone().requires_grad_(true);
  rise_l1(f, cone, sea).backward();
  EXPECT_GT(f.grad().abs().sum().item<double>(), 0.0);
  TrainParams params;
  params.lambda_rise = 300;
  EXPECT_EQ(pix2pix_options(params).lambda_rise, 300);
}

// logit_excess charges only logits beyond ±kLogitMax, linearly; and it moves
// a generator whose answer is parked in tanh's tail, which no other term of
// G's loss can: with the output layer's bias at −60 every cell is exactly −1
// in float32 and G's gradients are all zero without the bound.
TEST(Train, LogitBoundMovesASaturatedGeneratorTheOtherTermsCannot) {
  const torch::Tensor z = torch::tensor({0.0f, 3.0f, -3.8f, 4.8f, -13.8f});
  EXPECT_NEAR(logit_excess(z).item<double>(), (1.0 + 10.0) / 5, 1e-5);
  EXPECT_EQ(logit_excess(z.slice(0, 0, 3)).item<double>(), 0.0);
  const auto bias_after_steps = [](double lambda_logit) {
    torch::manual_seed(3);
    Pix2PixOptions o;
    o.g.ngf = 8;
    o.g.depth = 5;
    o.d.ndf = 8;
    o.lr = 0.05;
    o.lambda_logit = lambda_logit;
    Pix2Pix p(o);
    p.G()->set_dropout_enabled(false);
    torch::Tensor bias;
    for (const auto& kv : p.G()->named_parameters())
      if (kv.key() == "levels.0.up_conv.bias") bias = kv.value();
    {
      torch::NoGradGuard ng;
      bias.fill_(-60);
    }
    torch::manual_seed(4);
    const auto label = torch::rand({1, 3, 32, 32}) * 2 - 1;
    for (int i = 0; i < 5; ++i) p.step(label, torch::tanh(label.sum(1, true)));
    return bias.item<double>();
  };
  EXPECT_EQ(bias_after_steps(0), -60.0) << "a saturated G moved without the bound: the premise of the bound is wrong";
  EXPECT_GT(bias_after_steps(100), -60.0 + 0.1) << "the bound did not pull the parked logits back";
  TrainParams params;
  params.lambda_logit = 250;
  EXPECT_EQ(pix2pix_options(params).lambda_logit, 250);
}

// d_crop: D sees each step's pairs at a random offset (drawn from torch's
// generator, so a reseeded step repeats it); the step runs on the smaller
// view and its losses differ from the whole pair's.
TEST(Train, DCropShowsDARandomViewReproducibly) {
  const auto losses = [](int d_crop, uint64_t seed) {
    Pix2PixOptions o;
    o.d_crop = d_crop;
    const Losses l = tiny_step(o, seed);
    return std::vector<double>{l.g_gan, l.d_real, l.d_fake};
  };
  EXPECT_EQ(losses(8, 1), losses(8, 1));
  EXPECT_NE(losses(8, 1), losses(0, 1));
  bool moved = false;
  for (uint64_t s = 2; s < 8 && !moved; ++s) moved = losses(8, s) != losses(8, 1);
  EXPECT_TRUE(moved) << "the view never moved between steps";
  TrainParams params;
  params.d_crop_px = 8;
  EXPECT_EQ(pix2pix_options(params).d_crop, 8);
}

TEST(Train, LossGoesDownOnAFixedBatch) {
  // LibTorch's convolutions, reefgen's oneDNN ones, and those in bf16 (where
  // the CPU has it): each must learn, and bf16 must keep float32 weights.
  std::vector<model::ConvOptions> convs = {{model::ConvEngine::Torch, model::ConvPrecision::Fp32},
                                           {model::ConvEngine::OneDnn, model::ConvPrecision::Fp32}};
  if (model::cpu_has_native_bf16()) convs.push_back({model::ConvEngine::OneDnn, model::ConvPrecision::Bf16});
  for (const auto& conv : convs) {
    torch::manual_seed(5);
    Pix2PixOptions o;
    o.g.ngf = 8;
    o.g.depth = 6;
    o.d.ndf = 8;
    o.lr = 1e-3;
    o.conv = conv;
    Pix2Pix p(o);
    p.G()->set_dropout_enabled(false);
    const auto label = torch::rand({1, 3, 64, 64}) * 2 - 1;
    const auto height = torch::tanh(label.sum(1, true));  // a function of the label: learnable
    const double first = p.step(label, height).g_l1;
    double last = first;
    for (int s = 0; s < 150; ++s) last = p.step(label, height).g_l1;
    const std::string what = std::string(conv.engine == model::ConvEngine::Torch ? "torch" : "onednn") +
                             (conv.precision == model::ConvPrecision::Bf16 ? " bf16" : " fp32");
    EXPECT_LT(last, 0.5 * first) << what << ": G_L1 " << first << " -> " << last;
    for (const auto& w : p.G()->parameters()) EXPECT_EQ(w.scalar_type(), torch::kFloat32) << what;
  }
}

TEST(Train, ResumeEqualsUninterruptedBitForBit) {
  const fs::path data = make_dataset("resume_data", 8, 2);
  const TrainParams params = tiny_params();  // 6 train pairs: 12 steps
  const fs::path base = temp_dir("resume_runs");
  RunOptions full = run_in(data, base / "full");
  const RunResult r_full = run_training(params, full);
  EXPECT_EQ(r_full.step, 12);
  EXPECT_FALSE(r_full.interrupted);

  // Stopped by --max-steps at 5 (not a checkpoint multiple), then resumed.
  RunOptions part = run_in(data, base / "part");
  part.max_steps = 5;
  EXPECT_EQ(run_training(params, part).step, 5);
  part.max_steps = -1;
  part.resume = true;
  EXPECT_EQ(run_training(params, part).step, 12);

  // Stopped by the signal flag at step 7, then resumed with other thread settings.
  std::atomic<bool> stop{false};
  RunOptions sig = run_in(data, base / "sig");
  sig.stop = &stop;
  sig.on_step = [&](const StepReport& r) { if (r.step == 6) stop = true; };
  const RunResult r_sig = run_training(params, sig);
  EXPECT_TRUE(r_sig.interrupted);
  EXPECT_EQ(r_sig.step, 7);  // the flag is seen after the step that follows
  EXPECT_TRUE(fs::exists(base / "sig" / "generator.pt"));
  TrainParams other = params;
  other.loader_threads = 1;
  other.prefetch = 1;
  sig.stop = nullptr;
  sig.on_step = nullptr;
  sig.resume = true;
  EXPECT_EQ(run_training(other, sig).step, 12);

  auto a = load_run(base / "full", params), b = load_run(base / "part", params), c = load_run(base / "sig", params);
  EXPECT_EQ(a.step, 12);
  EXPECT_EQ(b.step, 12);
  expect_same_weights(*a.p.G(), *b.p.G());
  expect_same_weights(*a.p.D(), *b.p.D());
  expect_same_weights(*a.p.G(), *c.p.G());
  expect_same_weights(*a.p.D(), *c.p.D());
  EXPECT_EQ(log_without_timing(base / "full" / "log.csv"), log_without_timing(base / "part" / "log.csv"));
  EXPECT_EQ(log_without_timing(base / "full" / "log.csv"), log_without_timing(base / "sig" / "log.csv"));
  EXPECT_EQ(read_text(base / "full" / "val.csv"), read_text(base / "sig" / "val.csv"));

  // Resuming a folder without a checkpoint is refused (it used to start a fresh default run).
  RunOptions empty = run_in(data, base / "empty");
  empty.resume = true;
  expect_error_naming([&] { run_training(params, empty); }, "no checkpoint.pt to resume");
  // A second process on a run folder in use is refused, naming the folder.
  {
    const DirLock held(base / "full", "run folder");
    RunOptions busy = run_in(data, base / "full");
    busy.resume = true;
    expect_error_naming([&] { run_training(params, busy); }, "another reefgen process");
  }
  // Temp files of a dead process are removed on resume; a live one's are kept.
  {
    pid_t child = fork();
    if (child == 0) _exit(0);
    int status = 0;
    waitpid(child, &status, 0);  // a PID that no longer runs
    const fs::path stale = base / "full" / ("checkpoint.pt.tmp." + std::to_string(child) + ".0");
    const fs::path stale2 = base / "full" / ("log.csv.tmp." + std::to_string(child) + ".3");
    const fs::path live = base / "full" / ("log.csv.tmp." + std::to_string(getppid()) + ".1");
    for (const auto& f : {stale, stale2, live}) write_text_atomic(f, "x");
    RunOptions again = run_in(data, base / "full");
    again.resume = true;
    run_training(params, again);  // the run is complete: it only re-exports
    EXPECT_FALSE(fs::exists(stale));
    EXPECT_FALSE(fs::exists(stale2));
    EXPECT_TRUE(fs::exists(live));
    fs::remove(live);
  }
  // A run folder is never silently reused.
  expect_error_naming([&] { run_training(params, run_in(data, base / "full")); }, "--resume");
  // Resuming with a different config is refused, naming the key.
  TrainParams changed = params;
  changed.lr = 1e-3;
  RunOptions again = run_in(data, base / "full");
  again.resume = true;
  expect_error_naming([&] { run_training(changed, again); }, "lr");
  // Another convolution engine or precision changes the results: refused too.
  TrainParams torch_engine = params;
  torch_engine.engine = "torch";
  expect_error_naming([&] { run_training(torch_engine, again); }, "engine");
  TrainParams bf16 = params;
  bf16.precision = "bf16";
  expect_error_naming([&] { run_training(bf16, again); }, "precision");
  // "auto" is decided once and recorded as what ran.
  TrainParams automatic = params;
  automatic.precision = "auto";
  RunOptions fresh = run_in(data, base / "auto");
  fresh.max_steps = 1;
  run_training(automatic, fresh);
  EXPECT_EQ(read_json(base / "auto" / "run.json").at("config").at("precision"),
            model::cpu_has_native_bf16() ? "bf16" : "fp32");
  fs::remove_all(base);
  fs::remove_all(data);
}

TEST(Train, CheckpointRoundTripAndBadFiles) {
  const fs::path d = temp_dir("ckpt");
  const TrainParams params = tiny_params();
  torch::manual_seed(1);
  Pix2Pix p(pix2pix_options(params));
  const auto x = torch::rand({1, 3, 64, 64}) * 2 - 1, y = torch::rand({1, 1, 64, 64}) * 2 - 1;
  p.step(x, y);
  LogWindow w;
  w.sums[1] = 12.5;
  w.steps = 3;
  save_checkpoint(d / "c.pt", p, params, 42, w);
  EXPECT_EQ(test::count_files(d), 1);  // no temporary left behind

  torch::manual_seed(2);
  Pix2Pix q(pix2pix_options(params));
  LogWindow w2;
  EXPECT_EQ(load_checkpoint(d / "c.pt", q, params, &w2), 42);
  EXPECT_EQ(w2.sums[1], 12.5);
  EXPECT_EQ(w2.steps, 3);
  expect_same_weights(*p.G(), *q.G());
  expect_same_weights(*p.D(), *q.D());
  // Optimizer state restored: the next step is the same on both.
  torch::manual_seed(7);
  const Losses lp = p.step(x, y);
  torch::manual_seed(7);
  const Losses lq = q.step(x, y);
  EXPECT_EQ(lp.g_l1, lq.g_l1);
  expect_same_weights(*p.G(), *q.G());

  // Truncated, foreign, missing.
  const std::string bytes = read_text(d / "c.pt");
  write_text_atomic(d / "truncated.pt", bytes.substr(0, bytes.size() / 2));
  expect_error_naming([&] { load_checkpoint(d / "truncated.pt", q, params, nullptr); }, "truncated.pt");
  write_text_atomic(d / "foreign.pt", "not a checkpoint at all");
  expect_error_naming([&] { load_checkpoint(d / "foreign.pt", q, params, nullptr); }, "foreign.pt");
  model::save_generator(d / "g.pt", p.G(), {}, 64, 1);
  expect_error_naming([&] { load_checkpoint(d / "g.pt", q, params, nullptr); }, "expected a checkpoint");
  expect_error_naming([&] { load_checkpoint(d / "missing.pt", q, params, nullptr); }, "missing.pt");
  fs::remove_all(d);
}

// --init: a new run starts from another run's G and D (fine-tuning with
// another loss weight), with fresh optimizers at step 0; another
// architecture, a missing or a foreign file is refused before anything is written.
TEST(Train, InitStartsFromAnotherRunsWeights) {
  const fs::path data = make_dataset("init_data", 5, 1);
  TrainParams params = tiny_params();  // 4 train pairs: 8 steps
  const fs::path base = temp_dir("init_runs");
  ASSERT_EQ(run_training(params, run_in(data, base / "src")).step, 8);
  Loaded src = load_run(base / "src", params);

  // Right after loading, the weights are the source's, whatever the seed.
  TrainParams tuned = params;
  tuned.seed = 5;
  tuned.lambda_l1 = 250;
  torch::manual_seed(tuned.seed);
  Pix2Pix q(pix2pix_options(tuned));
  load_checkpoint_weights(base / "src" / "checkpoint.pt", q, tuned);
  expect_same_weights(*src.p.G(), *q.G());
  expect_same_weights(*src.p.D(), *q.D());

  // A run with --init: starts at step 0, records where it came from, and its
  // first step moves from the source's weights (one step from them differs
  // from one step from a fresh initialisation).
  RunOptions ft = run_in(data, base / "tuned");
  ft.init_from = base / "src" / "checkpoint.pt";
  ft.max_steps = 1;
  ASSERT_EQ(run_training(tuned, ft).step, 1);
  const json rj = read_json(base / "tuned" / "run.json");
  ASSERT_TRUE(rj.contains("init_from"));
  EXPECT_NE(rj["init_from"]["path"].get<std::string>().find("src"), std::string::npos);
  RunOptions fresh = run_in(data, base / "fresh");
  fresh.max_steps = 1;
  ASSERT_EQ(run_training(tuned, fresh).step, 1);
  Loaded a = load_run(base / "tuned", tuned), b = load_run(base / "fresh", tuned);
  EXPECT_EQ(a.step, 1);
  const auto wa = a.p.G()->parameters()[0], wb = b.p.G()->parameters()[0], ws = src.p.G()->parameters()[0];
  EXPECT_FALSE(torch::equal(wa, wb));
  EXPECT_LT((wa - ws).abs().max().item<float>(), (wb - ws).abs().max().item<float>());
  // Resuming it keeps the record.
  ft.max_steps = 2;
  ft.resume = true;
  ASSERT_EQ(run_training(tuned, ft).step, 2);
  EXPECT_EQ(read_json(base / "tuned" / "run.json")["init_from"], rj["init_from"]);

  TrainParams wider = params;
  wider.ngf = 8;
  RunOptions bad = run_in(data, base / "bad");
  bad.init_from = base / "src" / "checkpoint.pt";
  expect_error_naming([&] { run_training(wider, bad); }, "ngf = 4 there, 8 here");
  bad.init_from = base / "nowhere.pt";
  expect_error_naming([&] { run_training(params, bad); }, "nowhere.pt");
  // An exported generator starts G alone, D fresh (fine-tuning a shipped model).
  torch::manual_seed(tuned.seed);
  Pix2Pix g_only(pix2pix_options(tuned));
  load_checkpoint_weights(base / "src" / "generator.pt", g_only, tuned);
  expect_same_weights(*src.p.G(), *g_only.G());
  EXPECT_FALSE(torch::equal(src.p.D()->parameters()[0], g_only.D()->parameters()[0]));
  bad.init_from = base / "src" / "generator.pt";
  expect_error_naming([&] { run_training(wider, bad); }, "another architecture");
  bad.init_from = base / "src" / "run.json";  // neither a checkpoint nor a generator
  expect_error_naming([&] { run_training(params, bad); }, "run.json");
  EXPECT_FALSE(fs::exists(base / "bad" / "checkpoint.pt"));
  fs::remove_all(base);
}

// The maturity's code: 0 at the unit maturity, ±1 at the ends of the range,
// clamped past them, monotonic; the plane appended to the label unchanged.
TEST(Codec, TheMaturityPlane) {
  EXPECT_EQ(model::maturity_code(1), 0.f);
  EXPECT_NEAR(model::maturity_code(kMaxMaturity), 1.f, 1e-7);
  EXPECT_NEAR(model::maturity_code(kMinMaturity), -1.f, 1e-6);
  EXPECT_EQ(model::maturity_code(1e6), model::maturity_code(kMaxMaturity));
  EXPECT_EQ(model::maturity_code(1e-9), model::maturity_code(kMinMaturity));
  EXPECT_LT(model::maturity_code(0.5), model::maturity_code(2));
  EXPECT_NEAR(model::maturity_code(5), std::log(5.0) / std::log(20.0), 1e-6);
  cv::Mat3b label(8, 6, cv::Vec3b(10, 200, 30));
  const torch::Tensor t3 = model::network_input(label, model::kLabelChannels, 7);
  EXPECT_TRUE(torch::equal(t3, model::label_to_tensor(label)));
  const torch::Tensor t4 = model::network_input(label, model::kLabelAndMaturityChannels, 5);  // {4,8,6}
  ASSERT_EQ(t4.sizes(), (std::vector<int64_t>{4, 8, 6}));
  EXPECT_TRUE(torch::equal(t4.narrow(0, 0, 3), t3));
  EXPECT_TRUE(torch::all(t4[3] == model::maturity_code(5)).item<bool>());
  EXPECT_THROW(model::network_input(label, 5, 1), std::invalid_argument);
}

// The maturity channel (docs/MODEL.md "The age channel"): each pair's
// manifest maturity reaches G and D as a constant fourth plane; a G widened
// from a three-channel generator file answers as the file's G did, at every
// maturity (the new channel's weights start at zero); a run with the channel
// exports a four-channel generator, and a checkpoint without it is refused.
TEST(Train, TheMaturityChannelCarriesEachPairsMaturity) {
  const fs::path data = make_dataset("maturity_data", 5, 1, {0.1, 1, 5, 20, 2});
  const DatasetInfo d = open_dataset(data);
  ASSERT_EQ(d.train.size(), 4u);
  EXPECT_EQ(d.train[0].maturity, 0.1);
  EXPECT_EQ(d.train[3].maturity, 20);
  EXPECT_EQ(open_dataset(make_dataset("no_maturity_data", 2, 1)).train[0].maturity, 1);
  const Sample three = load_sample(d, d.train[0], {}, 0);
  const Sample four = load_sample(d, d.train[0], {}, 0, model::kLabelAndMaturityChannels);
  ASSERT_EQ(three.label.size(0), 3);
  ASSERT_EQ(four.label.size(0), 4);
  EXPECT_TRUE(torch::equal(four.label.narrow(0, 0, 3), three.label));
  EXPECT_NEAR(four.label[3].min().item<float>(), std::log(0.1) / std::log(kMaxMaturity), 1e-6);
  EXPECT_EQ(four.label[3].min().item<float>(), four.label[3].max().item<float>());
  // Jittered and flipped, the plane stays the pair's.
  const Sample jittered = load_sample(d, d.train[3], {true, 1.2, true}, 11, model::kLabelAndMaturityChannels);
  EXPECT_EQ(jittered.label[3].min().item<float>(), 1.f);
  EXPECT_EQ(jittered.label[3].max().item<float>(), 1.f);

  const fs::path base = temp_dir("maturity_runs");
  TrainParams params = tiny_params();
  torch::manual_seed(3);
  Pix2Pix p3(pix2pix_options(params));
  model::save_generator(base / "g3.pt", p3.G(), {}, 64, 1);
  TrainParams aged = params;
  aged.maturity_channel = true;
  EXPECT_EQ(pix2pix_options(aged).g.in_channels, 4);
  EXPECT_EQ(pix2pix_options(aged).d.in_channels, 5);
  torch::manual_seed(4);
  Pix2Pix p4(pix2pix_options(aged));
  load_checkpoint_weights(base / "g3.pt", p4, aged);
  {
    torch::NoGradGuard no_grad;
    for (Pix2Pix* p : {&p3, &p4}) {
      p->G()->eval();
      p->G()->set_dropout_enabled(false);
    }
    const torch::Tensor x = torch::rand({1, 3, 64, 64}) * 2 - 1;  // {1,3,S,S}
    const torch::Tensor y3 = p3.G()->forward(x);
    for (const double m : {0.1, 1.0, 20.0}) {
      const torch::Tensor x4 = model::with_maturity(x[0], m).unsqueeze(0);  // {1,4,S,S}
      EXPECT_LT((p4.G()->forward(x4) - y3).abs().max().item<float>(), 1e-5f) << "maturity " << m;
    }
  }

  RunOptions run = run_in(data, base / "aged");
  run.max_steps = 2;
  ASSERT_EQ(run_training(aged, run).step, 2);
  EXPECT_EQ(model::load_generator(base / "aged" / "generator.pt").g->options().in_channels, 4);
  RunOptions plain = run_in(data, base / "plain");
  plain.max_steps = 1;
  ASSERT_EQ(run_training(params, plain).step, 1);
  RunOptions mixed = run_in(data, base / "mixed");
  mixed.init_from = base / "plain" / "checkpoint.pt";
  expect_error_naming([&] { run_training(aged, mixed); }, "maturity_channel = false there, true here");
  fs::remove_all(base);
}

TEST(Train, ExportedGeneratorReproducesG) {
  const fs::path d = temp_dir("gen");
  torch::manual_seed(3);
  model::UNetOptions o;
  o.ngf = 4;
  o.depth = 6;
  o.norm = model::Norm::Instance;
  model::UNetGenerator g(o);
  model::init_pix2pix(*g);
  model::save_generator(d / "g.pt", g, {-50, 300}, 64, 17);
  model::GeneratorFile f = model::load_generator(d / "g.pt");
  EXPECT_EQ(f.g->options().ngf, 4);
  EXPECT_EQ(f.g->options().norm, model::Norm::Instance);
  EXPECT_EQ(f.range.lo_m, -50);
  EXPECT_EQ(f.range.hi_m, 300);
  EXPECT_EQ(f.size_px, 64);
  EXPECT_EQ(f.train_step, 17);
  torch::NoGradGuard no_grad;
  g->eval();
  f.g->eval();
  const auto x = torch::rand({1, 3, 64, 64});
  EXPECT_TRUE(torch::equal(g->forward(x), f.g->forward(x)));
  write_text_atomic(d / "bad.pt", "garbage");
  EXPECT_THROW(model::load_generator(d / "bad.pt"), std::runtime_error);
  fs::remove_all(d);
}

TEST(Data, JitterMovesLabelAndHeightTogether) {
  // Pixel column c: label red channel = 4c, height = 4c metres. After resize,
  // crop and flip, both must still name the same source column (±1 px).
  const fs::path d = temp_dir("jitter");
  cv::Mat3b label(64, 64);
  cv::Mat1f height(64, 64);
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x) {
      label(y, x) = cv::Vec3b(0, uint8_t(4 * y), uint8_t(4 * x));  // BGR: R = 4x, G = 4y
      height(y, x) = float(4 * x);
    }
  write_png(d / "a.label.png", label);
  write_exr_height(d / "a.height.exr", height);
  DatasetInfo info;
  info.dir = d;
  info.size_px = 64;
  info.range = {0, 252};
  const PairRef ref{0, "a.label.png", "a.height.exr"};
  int flipped = 0;
  for (uint64_t seed = 0; seed < 16; ++seed) {
    const Sample s = load_sample(info, ref, {true, 1.25, true}, seed);
    const auto r = (s.label[0] + 1) * 127.5 / 4;   // source column per label pixel
    const auto h = (s.height[0] + 1) * 126.0 / 4;  // source column per height pixel
    EXPECT_LE((r - h).abs().max().item<double>(), 1.01) << "seed " << seed;
    flipped += r[0][0].item<double>() > r[0][63].item<double>();
  }
  EXPECT_GT(flipped, 2);
  EXPECT_LT(flipped, 14);
  // Labels stay palette values: never blended.
  const Sample s = load_sample(info, ref, {true, 1.25, true}, 3);
  const auto red = ((s.label[0] + 1) * 127.5).round();
  EXPECT_TRUE(torch::equal(torch::remainder(red, 4), torch::zeros_like(red)));
  fs::remove_all(d);
}

TEST(Data, SampleOrderIsAPermutationPerEpoch) {
  std::vector<int> seen(10, 0);
  for (int q = 10; q < 20; ++q) ++seen[sample_at(4, q, 10)];
  for (int c : seen) EXPECT_EQ(c, 1);
  // Shuffled anew each epoch and per seed (not one fixed order).
  std::vector<size_t> e1, e2, other_seed;
  for (int q = 0; q < 10; ++q) {
    e1.push_back(sample_at(4, q, 10));
    e2.push_back(sample_at(4, q + 10, 10));
    other_seed.push_back(sample_at(5, q, 10));
  }
  EXPECT_NE(e1, e2);
  EXPECT_NE(e1, other_seed);
}

TEST(Data, PrefetcherKeepsOrderAndRethrows) {
  Prefetcher pf([](int64_t s) { return Prefetcher::Batch{torch::full({1}, double(s)), torch::zeros({1})}; }, 3, 40, 3, 4);
  for (int s = 3; s < 40; ++s) EXPECT_EQ(pf.next().first.item<double>(), s);
  Prefetcher bad([](int64_t s) -> Prefetcher::Batch {
    if (s == 2) throw Error("pair 2 is broken");
    return {torch::zeros({1}), torch::zeros({1})};
  }, 0, 10, 2, 2);
  bad.next();
  bad.next();
  expect_error_naming([&] { bad.next(); }, "pair 2");
}

TEST(Data, BadDatasetsNameTheFile) {
  const fs::path d = make_dataset("bad_data", 3, 0);
  DatasetInfo info = open_dataset(d);
  EXPECT_EQ(info.train.size(), 3u);
  // Wrong size.
  write_png(d / info.train[0].label, cv::Mat3b(32, 32, cv::Vec3b(0, 0, 255)));
  expect_error_naming([&] { load_sample(info, info.train[0], {}, 0); }, info.train[0].label);
  // NaN heights.
  {  // reefgen never writes a NaN (write_exr_height refuses): plant one in an uncompressed file
    const float mark = 1234.5f, nan = std::numeric_limits<float>::quiet_NaN();
    write_exr_height(d / info.train[1].height, cv::Mat1f(64, 64, mark), {}, /*zip_level=*/0);
    std::string bytes = read_text(d / info.train[1].height);
    const std::string from(reinterpret_cast<const char*>(&mark), 4), to(reinterpret_cast<const char*>(&nan), 4);
    for (size_t at = bytes.find(from); at != std::string::npos; at = bytes.find(from, at + 4)) bytes.replace(at, 4, to);
    write_text_atomic(d / info.train[1].height, bytes);
  }
  expect_error_naming([&] { load_sample(info, info.train[1], {}, 0); }, "NaN");
  // Corrupt label.
  write_text_atomic(d / info.train[2].label, "not a png");
  expect_error_naming([&] { load_sample(info, info.train[2], {}, 0); }, info.train[2].label);
  // Missing manifest, bad manifest line.
  write_text_atomic(d / "manifest.jsonl", "{\"index\": 0}\n");
  expect_error_naming([&] { open_dataset(d); }, "manifest.jsonl:1");
  fs::remove(d / "manifest.jsonl");
  expect_error_naming([&] { open_dataset(d); }, "dataset merge");
  fs::remove_all(d);
}

// A manifest is not trusted blindly. Paths stay inside the
// dataset folder and indexes are unique (always checked); the files' bytes
// match the build's checksums (unless --no-verify).
TEST(Data, ManifestIsCheckedBeforeTraining) {
  const fs::path d = make_dataset("checked_data", 3, 1);
  const std::string good = read_text(d / "manifest.jsonl");
  augment::ManifestCheck no_sums;
  no_sums.verify_checksums = false;
  EXPECT_EQ(open_dataset(d).train.size(), 2u);
  auto with_line = [&](int k, const std::function<void(json&)>& edit) {
    std::istringstream in(good);
    std::string line, out;
    for (int i = 0; std::getline(in, line); ++i) {
      json r = json::parse(line);
      if (i == k) edit(r);
      out += r.dump() + "\n";
    }
    write_text_atomic(d / "manifest.jsonl", out);
  };
  // Outside the folder: relative with "..", or absolute; refused even unverified.
  for (const std::string bad : {"../../../../etc/passwd", "/etc/passwd", "train/../../x.png"}) {
    with_line(1, [&](json& r) { r["label"] = bad; });
    expect_error_naming([&] { open_dataset(d, no_sums); }, "outside the dataset folder");
    expect_error_naming([&] { open_dataset(d); }, "manifest.jsonl:2");
  }
  // A line listed twice.
  write_text_atomic(d / "manifest.jsonl", good + good.substr(0, good.find('\n') + 1));
  expect_error_naming([&] { open_dataset(d, no_sums); }, "listed again (first at line 1)");
  // Labels swapped in from another pair: the checksum names the file.
  write_text_atomic(d / "manifest.jsonl", good);
  const std::string l0 = read_text(d / "train/00000000.label.png"), l1 = read_text(d / "train/00000001.label.png");
  write_text_atomic(d / "train/00000000.label.png", l1);
  expect_error_naming([&] { open_dataset(d); }, "train/00000000.label.png: its bytes differ");
  EXPECT_EQ(open_dataset(d, no_sums).train.size(), 2u);  // --no-verify: the user's call
  write_text_atomic(d / "train/00000000.label.png", l0);
  // A missing pair file.
  fs::remove(d / "val/00000002.height.exr");
  expect_error_naming([&] { open_dataset(d); }, "val/00000002.height.exr: missing");
  // No checksums recorded (an older manifest): verify refuses, --no-verify reads it.
  with_line(0, [&](json& r) { r.erase("label_fnv64"); });
  expect_error_naming([&] { open_dataset(d); }, "--no-verify");
  fs::remove_all(d);
}

TEST(TrainParams, PaperConfigIsTheDefaults) {
  // configs/train/paper.json is just the serialised defaults (docs/DESIGN.md §5).
  const TrainParams p = train_params_from_json(read_json(REEFGEN_SOURCE_DIR "/configs/train/paper.json"), "paper.json");
  EXPECT_EQ(json(p), json(TrainParams{}));
}

TEST(TrainParams, EveryConfigInTheRepositoryIsSerialisedParams) {
  // configs/train/*.json are read by scripts/train-shipped.sh: each must load
  // and hold every field (a file missing one would silently take the default).
  int n = 0;
  for (const auto& e : fs::directory_iterator(REEFGEN_SOURCE_DIR "/configs/train")) {
    if (e.path().extension() != ".json") continue;
    SCOPED_TRACE(e.path().string());
    const json stored = read_json(e.path().string());
    const TrainParams p = train_params_from_json(stored, e.path().string());
    EXPECT_EQ(json(p), stored);
    ++n;
  }
  EXPECT_GE(n, 5);  // paper, shipped, shipped-tune, shipped-tune2, shipped-tune3
}

TEST(FusedAdam, MatchesLibTorchAdamAndIgnoresThreadCount) {
  auto run = [](bool fused, int threads) {
    torch::set_num_threads(threads);
    torch::manual_seed(11);
    std::vector<torch::Tensor> params = {torch::randn({300000}).set_requires_grad(true),
                                         torch::randn({7, 5}).set_requires_grad(true)};
    const auto options = torch::optim::AdamOptions(2e-4).betas(std::make_tuple(0.5, 0.999));
    std::unique_ptr<torch::optim::Adam> opt;
    if (fused) opt = std::make_unique<FusedAdam>(params, options);
    else opt = std::make_unique<torch::optim::Adam>(params, options);
    for (int s = 0; s < 5; ++s) {
      clear_grads(params);
      (params[0].sin().sum() + params[1].pow(2).sum()).backward();
      opt->step();
    }
    return std::vector<torch::Tensor>{params[0].detach().clone(), params[1].detach().clone()};
  };
  const auto ref = run(false, 2), f2 = run(true, 2), f1 = run(true, 1);
  for (size_t i = 0; i < ref.size(); ++i) {
    EXPECT_LT((ref[i] - f2[i]).abs().max().item<double>(), 1e-6) << "tensor " << i;
    EXPECT_TRUE(torch::equal(f1[i], f2[i])) << "thread count changed the update of tensor " << i;
  }
  torch::set_num_threads(std::max(1u, std::thread::hardware_concurrency()));
}

// A pair that cannot be read mid-run (here: damaged, --no-verify)
// stops training with the weights of the last finished step saved first.
TEST(Train, UnreadablePairMidRunSavesACheckpoint) {
  const fs::path data = make_dataset("midrun_data", 12, 0);
  const fs::path base = temp_dir("midrun");
  write_text_atomic(data / "train/00000011.label.png", "not a png any more");
  TrainParams p = tiny_params();
  p.checkpoint_every = 1000;  // no periodic checkpoint: only the failure's
  p.epochs = 20;
  RunOptions run = run_in(data, base / "run");
  run.verify_data = false;
  std::string message;
  try {
    run_training(p, run);
  } catch (const Error& e) {
    message = e.what();
  }
  ASSERT_NE(message.find("00000011.label.png"), std::string::npos) << message;
  const size_t at = message.find("checkpoint saved at step ");
  ASSERT_NE(at, std::string::npos) << message;
  const int64_t step = std::stoll(message.substr(at + 25));
  EXPECT_GT(step, 0);
  Pix2Pix q(pix2pix_options(p));
  EXPECT_EQ(load_checkpoint(base / "run" / "checkpoint.pt", q, p, nullptr, nullptr, 1), step);
  // Verified (the default), the damage is found before the first step.
  RunOptions checked = run_in(data, base / "checked");
  expect_error_naming([&] { run_training(p, checked); }, "its bytes differ");
  EXPECT_FALSE(fs::exists(base / "checked" / "checkpoint.pt"));
  fs::remove_all(base);
  fs::remove_all(data);
}
