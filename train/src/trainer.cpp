#include "reefgen/train/trainer.hpp"

#include "run_folder.hpp"

#include <chrono>
#include <cmath>
#include <fstream>
#include <optional>
#include <thread>

#include <opencv2/imgproc.hpp>

#include "reefgen/io.hpp"
#include "reefgen/model/archive.hpp"
#include "reefgen/model/generator_file.hpp"
#include "reefgen/model/torch_threads.hpp"
#include "reefgen/preview.hpp"
#include "reefgen/rng.hpp"
#include "reefgen/sha256.hpp"
#include "reefgen/text.hpp"
#include "reefgen/train/data.hpp"
#include "reefgen/train/fused_adam.hpp"
#include "reefgen/version.hpp"

namespace reefgen::train {

using nlohmann::json;
namespace fs = std::filesystem;
using detail::append_line;
using detail::check_run_apart_from_data;
using detail::open_run_folder;
using detail::restore_start;
using detail::run_record;

namespace {

// Runs f() and then puts back BatchNorm running statistics and modes, so
// validation passes leave no trace in the training state.
template <class F>
void without_side_effects(model::UNetGenerator& g, F f) {
  std::vector<torch::Tensor> saved;
  for (const auto& b : g->buffers()) saved.push_back(b.clone());
  const bool training = g->is_training(), dropout = g->dropout_enabled();
  f();
  torch::NoGradGuard no_grad;
  size_t i = 0;
  for (auto& b : g->buffers()) b.copy_(saved[i++]);
  g->train(training);
  g->set_dropout_enabled(dropout);
}

cv::Mat3b tensor_to_label_bgr(const torch::Tensor& t) {  // {in,S,S} in [-1,1]: its label channels
  torch::Tensor u8 = t.narrow(0, 0, model::kLabelChannels).add(1.0).mul(127.5).round().clamp(0, 255).to(torch::kUInt8).permute({1, 2, 0}).contiguous();
  cv::Mat3b rgb(int(t.size(1)), int(t.size(2)));
  std::memcpy(rgb.data, u8.data_ptr<uint8_t>(), size_t(u8.numel()));
  cv::Mat3b bgr;
  cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
  return bgr;
}

// Rank 0's step, weights and optimizer states, everywhere: a fresh run's
// initialisation, an --init's weights or a resumed checkpoint. From here on
// the ranks stay equal: same averaged gradients, same Adam updates.
void sync_from_rank0(Comm& comm, Pix2Pix& p, int64_t& step) {
  torch::NoGradGuard no_grad;
  torch::Tensor st = torch::tensor({step}, torch::kInt64);
  comm.broadcast({st}, "the broadcast of the starting step");
  step = st.item<int64_t>();
  std::vector<torch::Tensor> weights;
  for (torch::nn::Module* m : {static_cast<torch::nn::Module*>(p.G().get()), static_cast<torch::nn::Module*>(p.D().get())}) {
    for (auto& t : m->parameters()) weights.push_back(t);
    for (auto& b : m->buffers()) weights.push_back(b);
  }
  comm.broadcast(weights, "the broadcast of G's and D's weights");
  for (torch::optim::Adam* opt : {&p.opt_G(), &p.opt_D()}) {
    const bool has = !opt->state().empty();
    torch::Tensor flag = torch::tensor({int64_t(has)}, torch::kInt64);
    comm.broadcast({flag}, "the broadcast of the optimizer states");
    if (!flag.item<int64_t>()) continue;
    std::vector<torch::Tensor> moments;
    std::vector<torch::optim::AdamParamState*> states;
    for (auto& group : opt->param_groups())
      for (auto& param : group.params()) {
        auto& slot = opt->state()[adam_state_key(param)];
        if (!slot) {  // a rank without the checkpoint: zero state, overwritten below
          auto fresh = std::make_unique<torch::optim::AdamParamState>();
          fresh->step(0);
          fresh->exp_avg(torch::zeros_like(param, at::MemoryFormat::Preserve));
          fresh->exp_avg_sq(torch::zeros_like(param, at::MemoryFormat::Preserve));
          slot = std::move(fresh);
        }
        auto& a = static_cast<torch::optim::AdamParamState&>(*slot);
        states.push_back(&a);
        moments.push_back(a.exp_avg());
        moments.push_back(a.exp_avg_sq());
      }
    torch::Tensor steps = torch::empty({int64_t(states.size())}, torch::kInt64);
    for (size_t i = 0; i < states.size(); ++i) steps[int64_t(i)] = states[i]->step();
    moments.push_back(steps);
    comm.broadcast(moments, "the broadcast of the optimizer states");
    for (size_t i = 0; i < states.size(); ++i) states[i]->step(steps[int64_t(i)].item<int64_t>());
  }
}


// The schedule in steps: B samples per rank, Bg per step in all; pix2pix's
// constant learning rate, then its linear decay; `end` stops at --max-steps.
struct StepPlan {
  int64_t n = 0, B = 0, Bg = 0, per_epoch = 0, constant = 0, decay = 0, total = 0, end = 0;
};
StepPlan plan_steps(const TrainParams& params, int64_t n, int world, int64_t max_steps) {
  StepPlan s;
  s.n = n;
  s.B = params.batch_size;
  s.Bg = s.B * world;
  s.per_epoch = (n + s.Bg - 1) / s.Bg;
  s.constant = std::llround(params.epochs * s.per_epoch);
  s.decay = std::llround(params.epochs_decay * s.per_epoch);
  s.total = s.constant + s.decay;
  if (s.total < 1)
    throw Error("training config: epochs " + std::to_string(params.epochs) + " + epochs_decay " +
                std::to_string(params.epochs_decay) + " give 0 steps over " + std::to_string(n) +
                " training pairs; raise epochs (e.g. --epochs 1)");
  s.end = max_steps >= 0 ? std::min(s.total, max_steps) : s.total;
  return s;
}

// Every rank must run the same job on the same data: compared with rank 0's.
void check_same_job(Comm& comm, const json& mine, int rank, const RunOptions& run) {
  const json lead_job = json::parse(comm.broadcast_string(mine.dump(), "the start of the job"));
  for (const auto& [k, v] : lead_job.items())
    if (mine.at(k) != v)
      throw Error("rank " + std::to_string(rank) + ": " +
                  (k == "config" ? "its training config differs from rank 0's"
                                 : "its dataset " + run.data.string() + " differs from rank 0's (" + k + ")") +
                  "; give every rank the same --config, flags and dataset");
}

// Rank 0's validation: a grid of fixed samples (label | truth | G's answer)
// and the mean absolute error in metres over the validation pairs.
struct Validator {
  Pix2Pix& p;
  const DatasetInfo& data;
  const std::vector<PairRef>& val;  // the val split, else the training pairs
  std::vector<Sample> fixed;
  const TrainParams& params;
  fs::path out;

  int in_channels() const { return in_channels_of(params); }

  Validator(Pix2Pix& p_, const DatasetInfo& d, bool lead, const TrainParams& pr, const fs::path& run_out)
      : p(p_), data(d), val(d.val.empty() ? d.train : d.val), params(pr), out(run_out) {
    for (int i = 0; lead && i < std::min<int>(params.val_samples, int(val.size())); ++i)
      fixed.push_back(load_sample(data, val[size_t(i)], {}, 0, in_channels()));
  }

  void write_grid(int64_t s) {
    std::vector<cv::Mat> rows;
    without_side_effects(p.G(), [&] {
      torch::NoGradGuard no_grad;
      p.G()->train();  // pix2pix's test-time mode: batch statistics; dropout off
      p.G()->set_dropout_enabled(false);
      for (const Sample& v : fixed) {
        const torch::Tensor pred = p.G()->forward(v.label.unsqueeze(0))[0];  // {1,S,S}
        const cv::Mat1f truth_m = model::tensor_to_height(v.height, data.range);
        const cv::Mat1f pred_m = model::tensor_to_height(pred, data.range);
        cv::Mat row;
        cv::hconcat(std::vector<cv::Mat>{tensor_to_label_bgr(v.label), render_preview(truth_m), render_preview(pred_m)}, row);
        rows.push_back(row);
      }
    });
    cv::Mat grid;
    cv::vconcat(rows, grid);
    ensure_writable_dir(out / "val");
    char name[48];
    std::snprintf(name, sizeof name, "step-%08lld.png", static_cast<long long>(s));
    write_png(out / "val" / name, grid);
  }

  double mae_m(bool batch_stats) {
    double sum = 0;
    int64_t count = 0;
    without_side_effects(p.G(), [&] {
      torch::NoGradGuard no_grad;
      p.G()->train(batch_stats);
      p.G()->set_dropout_enabled(false);
      for (size_t i = 0; i < std::min(val.size(), size_t(params.val_max_pairs)); ++i) {
        const Sample v = load_sample(data, val[i], {}, 0, in_channels());
        sum += (p.G()->forward(v.label.unsqueeze(0))[0] - v.height).abs().mean().item<double>();
        ++count;
      }
    });
    const double metres_per_unit = (data.range.hi_m - data.range.lo_m) / 2.0;
    return count ? sum / double(count) * metres_per_unit : 0.0;
  }
};

// Losses averaged over the ranks (what a one-process run would log), and
// one rank's Ctrl-C stops all of them after the same step.
Losses average_over_ranks(Comm& comm, const Losses& l, int world, int64_t step, bool& stopping, double& allreduce_s) {
  torch::Tensor t = torch::tensor({l.g_gan, l.g_l1, l.d_real, l.d_fake, stopping ? 1.0 : 0.0}, torch::kFloat64);
  comm.allreduce_sum({t}, "the all-reduce of step " + std::to_string(step + 1) + "'s losses");
  auto v = t.accessor<double, 1>();
  stopping = v[4] > 0;
  allreduce_s = comm.take_collective_seconds();
  return {v[0] / world, v[1] / world, v[2] / world, v[3] / world};
}

// A step's losses and time into the log window; every log_every steps (and
// at the end) one log.csv row of the window's means, then a new window.
void log_step(LogWindow& window, const Losses& l, double dt, double allreduce_s, int64_t step, const StepPlan& plan,
              double lr, const TrainParams& params, bool lead, const fs::path& log_csv) {
  const double ls[4] = {l.g_gan, l.g_l1, l.d_real, l.d_fake};
  for (int k = 0; k < 4; ++k) window.sums[k] += ls[k];
  window.steps += 1;
  window.seconds += dt;
  window.timed_steps += 1;
  window.allreduce_seconds += allreduce_s;
  if (step % params.log_every != 0 && step != plan.total) return;
  std::string row = std::to_string(step) + "," + short_num(double(step) / double(plan.per_epoch)) + "," + short_num(lr);
  for (double s : window.sums) row += "," + short_num(s / double(window.steps));
  const double timed_steps = double(std::max<int64_t>(1, window.timed_steps));
  row += "," + short_num(window.seconds / timed_steps) + "," + short_num(window.allreduce_seconds / timed_steps);
  if (lead) append_line(log_csv, "step,epoch,lr,G_GAN,G_L1,D_real,D_fake,s_per_iter,allreduce_s", row);
  window = {};
}


// One rank's job, opened in the order its guards run: the process group
// (a bad environment fails before anything is read), the dataset, the
// threads, the schedule, then rank 0's run folder.
struct Job {
  TrainParams params;  // precision "auto" resolved
  std::unique_ptr<Comm> comm;
  int rank = 0, world = 1;
  bool lead = true;  // rank 0: the only rank that touches the run folder
  DatasetInfo data;
  StepPlan plan;
  std::optional<DirLock> lock;
  fs::path ckpt, log_csv, val_csv;
};

// The threads of this process: all cores by default, shared between the
// ranks of this machine.
void set_torch_threads(const TrainParams& params, const DistConfig& dist) {
  const int all = std::max(1, int(std::thread::hardware_concurrency()) / std::max(1, dist.local_world_size));
  model::use_torch_threads(params.threads > 0 ? params.threads : all);
  at::globalContext().setDeterministicAlgorithms(params.deterministic, /*warn_only=*/true);
}

void open_job(Job& job, const TrainParams& requested, const RunOptions& run) {
  validate(requested, "training config");
  // precision "auto" decided once, here: run.json and the checkpoints record
  // what ran, so a resume on a CPU that would decide otherwise is refused.
  job.params = requested;
  job.params.precision = resolved_precision(requested);
  if (run.dist.world_size > 1) job.comm = Comm::connect(run.dist);
  job.rank = run.dist.rank;
  job.world = run.dist.world_size;
  job.lead = job.rank == 0;
  augment::ManifestCheck check;
  check.verify_checksums = run.verify_data;
  check.threads = torch::get_num_threads();
  check.quiet = !job.lead || !run.on_log;
  job.data = open_dataset(run.data, check);
  const int multiple = 1 << job.params.depth;
  if (job.data.size_px % multiple)
    throw Error(run.data.string() + ": pairs are " + std::to_string(job.data.size_px) +
                " px, not a multiple of 2^depth = " + std::to_string(multiple) +
                "; lower depth or build the dataset at another size");
  if (!(run.bucket_mb > 0 && run.bucket_mb <= 1024))
    throw Error("--bucket-mb " + short_num(run.bucket_mb) + ": must be in (0, 1024]");
  set_torch_threads(job.params, run.dist);
  job.plan = plan_steps(job.params, int64_t(job.data.train.size()), job.world, run.max_steps);
  check_run_apart_from_data(run);
  job.ckpt = run.out / "checkpoint.pt";
  job.log_csv = run.out / "log.csv";
  job.val_csv = run.out / "val.csv";
  if (job.lead) open_run_folder(run, job.data, job.plan.n, job.lock);
}

// run.json's record of what runs: config, data, schedule, sizes.
json describe_run(const Job& job, const RunOptions& run, Pix2Pix& p) {
  const StepPlan& plan = job.plan;
  return {{"reefgen_version", kVersion},
          {"config", job.params},
          {"seed", job.params.seed},
          {"data", fs::absolute(run.data).string()},
          {"size_px", job.data.size_px},
          {"manifest_fnv64", file_checksum(run.data / "manifest.jsonl")},
          {"height_range_m", {job.data.range.lo_m, job.data.range.hi_m}},
          {"pairs", {{"train", plan.n}, {"val", job.data.val.size()}}},
          {"steps", {{"per_epoch", plan.per_epoch}, {"constant", plan.constant}, {"decay", plan.decay}, {"total", plan.total}}},
          {"parameters", {{"G", model::count_parameters(*p.G())}, {"D", model::count_parameters(*p.D())}}},
          {"torch_threads", torch::get_num_threads()},
          {"world_size", job.world},
          {"global_batch", plan.Bg}};
}

// The step to start from, the same on every rank: rank 0 restores (resume
// or --init) and records run.json; the others check they run the same job
// and take rank 0's step, weights and optimizer states.
int64_t start_step(Job& job, const RunOptions& run, Pix2Pix& p, LogWindow& window) {
  int64_t step = job.lead ? restore_start(run, p, job.params, window, job.world, job.plan.Bg) : 0;
  const json record = describe_run(job, run, p);
  if (job.lead) write_json_atomic(run.out / "run.json", run_record(record, run));
  if (job.comm) {
    check_same_job(*job.comm,
                   {{"config", comparable_config(job.params, job.world)},
                    {"manifest_fnv64", record.at("manifest_fnv64")},
                    {"pairs", record.at("pairs")}},
                   job.rank, run);
    sync_from_rank0(*job.comm, p, step);
  }
  return step;
}

// Global sample q = s·Bg + rank·B + b: the stream a one-process run with the
// global batch would read, whatever the number of ranks.
int64_t sample_index(const Job& job, int64_t step, int64_t b) {
  return step * job.plan.Bg + job.rank * job.plan.B + b;
}

// Step s's batch for this rank, jittered per sample from its stream index.
Prefetcher::Batch load_batch(const Job& job, int64_t s) {
  const JitterOptions jitter{job.params.jitter, job.params.jitter_scale, job.params.flip};
  const uint64_t seed = job.params.seed;
  std::vector<torch::Tensor> labels, heights;
  for (int64_t b = 0; b < job.plan.B; ++b) {
    const int64_t q = sample_index(job, s, b);
    const PairRef& ref = job.data.train[sample_at(seed, q, job.data.train.size())];
    Sample smp = load_sample(job.data, ref, jitter, derive_seed(seed, uint64_t(q), "jitter"), in_channels_of(job.params));
    labels.push_back(smp.label);
    heights.push_back(smp.height);
  }
  return {torch::stack(labels), torch::stack(heights)};  // {B,in,S,S}, {B,1,S,S}
}

// Dropout draws from torch's generator, reseeded per step, and each sample's
// masks come from its stream index: a resumed run draws exactly what the
// uninterrupted one would have, whatever batch or rank a sample lands in.
void seed_dropout(const Job& job, Pix2Pix& p, int64_t step) {
  torch::manual_seed(derive_seed(job.params.seed, uint64_t(step), "dropout"));
  std::vector<uint64_t> seeds;
  for (int64_t b = 0; b < job.plan.B; ++b)
    seeds.push_back(derive_seed(job.params.seed, uint64_t(sample_index(job, step, b)), "dropout"));
  p.G()->set_dropout_seeds(std::move(seeds));
}

void check_finite(const Losses& l, int64_t step, const fs::path& ckpt) {
  if (!std::isfinite(l.g_gan + l.g_l1 + l.d_real + l.d_fake))
    throw Error("training diverged at step " + std::to_string(step + 1) + " (a loss is NaN or infinite); "
                "lower lr or resume from the last checkpoint in " + ckpt.string());
}

// Said once everything is checked: what runs the step.
void say_engine(const Job& job, const TrainParams& requested, const RunOptions& run) {
  if (!run.on_log || !job.lead) return;
  std::string ranks;
  if (job.comm)
    ranks = " per rank; " + std::to_string(job.world) + " ranks (" + run.dist.source + "), global batch " +
            std::to_string(job.plan.Bg);
  run.on_log("convolutions: " + job.params.engine + ", " + job.params.precision +
             (requested.precision == "auto" ? " (auto on this CPU)" : "") + "; " +
             std::to_string(torch::get_num_threads()) + " threads" + ranks);
}

// The next batch; a pair that cannot be read mid-run (deleted, damaged)
// first saves the weights after the last finished step, so --resume loses
// nothing.
Prefetcher::Batch next_batch_or_checkpoint(Prefetcher& loader, const Job& job, Pix2Pix& p, int64_t step,
                                           const LogWindow& window, int64_t saved_step) {
  try {
    return loader.next();
  } catch (const Error& e) {
    const bool saves = job.lead && step > 0;
    if (saves && saved_step != step) save_checkpoint(job.ckpt, p, job.params, step, window, job.world);
    throw Error(std::string(e.what()) + (saves ? " [checkpoint saved at step " + std::to_string(step) +
                                                     "; fix the dataset, then --resume]"
                                               : ""));
  }
}

// Rank 0 after step `step`: the validation grid, the epoch's validation
// error, the checkpoint. Returns whether it wrote a checkpoint.
bool validate_and_save(const Job& job, const RunOptions& run, Pix2Pix& p, Validator& val, const LogWindow& window,
                       int64_t step, int64_t end, bool stopping) {
  const StepPlan& plan = job.plan;
  if (step % job.params.val_every == 0 || step == plan.total || step == end) val.write_grid(step);  // end: --max-steps too
  if (step % plan.per_epoch == 0 || step == plan.total)
    append_line(job.val_csv, "step,epoch,mae_m_batchstats,mae_m_running",
                std::to_string(step) + "," + short_num(double(step) / double(plan.per_epoch)) + "," + short_num(val.mae_m(true)) +
                    "," + short_num(val.mae_m(false)));
  if (!(step % job.params.checkpoint_every == 0 || step == end || stopping)) return false;
  save_checkpoint(job.ckpt, p, job.params, step, window, job.world);
  if (run.on_log) run.on_log("checkpoint at step " + std::to_string(step) + ": " + job.ckpt.string());
  return true;
}

// generator.pt beside the checkpoint: what `reefgen infer` loads.
void export_generator(const Job& job, const RunOptions& run, Pix2Pix& p, int64_t step) {
  try {
    model::save_generator(run.out / "generator.pt", p.G(), job.data.range, job.data.size_px, step);
  } catch (const std::exception& e) {
    throw Error(e.what());
  }
}

}  // namespace

// pix2pix's loop (pytorch/examples' dcgan shape): each step takes a batch,
// updates D on real and fake pairs and G on GAN + L1 (Pix2Pix::step), then
// logs, validates and checkpoints. The loop ends at the end of the run, at
// --max-steps or on a signal; every case leaves a usable generator.pt.
RunResult run_training(const TrainParams& requested, const RunOptions& run) {
  Job job;
  open_job(job, requested, run);
  torch::manual_seed(job.params.seed);  // weight initialisation
  Pix2Pix p(pix2pix_options(job.params, job.data.range));
  LogWindow window;
  int64_t step = start_step(job, run, p, window);
  const int64_t end = job.plan.end;
  Validator validator(p, job.data, job.lead, job.params, run.out);
  RunResult result{step, job.plan.total, false};
  if (step >= end) {  // nothing left to train: the generator still matches the checkpoint
    if (job.lead) export_generator(job, run, p, step);
    return result;
  }
  say_engine(job, requested, run);
  p.set_comm(job.comm.get(), run.bucket_mb);
  Prefetcher loader([&job](int64_t s) { return load_batch(job, s); }, step, end, job.params.loader_threads,
                    job.params.prefetch);
  int64_t saved_step = -1;
  using clock = std::chrono::steady_clock;
  while (step < end) {
    const auto t0 = clock::now();
    const double lr = lr_at(job.params, step, job.plan.constant, job.plan.decay);
    p.set_lr(lr);
    auto [label, height] = next_batch_or_checkpoint(loader, job, p, step, window, saved_step);
    seed_dropout(job, p, step);
    Losses l = p.step(label, height);
    bool stopping = run.stop && run.stop->load();
    double allreduce_s = 0;
    if (job.comm) l = average_over_ranks(*job.comm, l, job.world, step, stopping, allreduce_s);
    check_finite(l, step, job.ckpt);
    ++step;
    const double dt = std::chrono::duration<double>(clock::now() - t0).count();
    log_step(window, l, dt, allreduce_s, step, job.plan, lr, job.params, job.lead, job.log_csv);
    if (job.lead && validate_and_save(job, run, p, validator, window, step, end, stopping)) saved_step = step;
    if (run.on_step) run.on_step({step, job.plan.total, lr, dt, allreduce_s, l});
    if (stopping && step < end) {
      result.interrupted = true;
      break;
    }
  }
  result.step = step;
  if (job.lead) export_generator(job, run, p, step);
  return result;
}

}  // namespace reefgen::train
