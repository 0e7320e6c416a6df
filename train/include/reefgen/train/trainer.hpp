#pragma once
// The training run: one flat loop over steps, with everything a person needs
// to follow it in the run folder and everything needed to resume it exactly.
//
// Data-parallel (RunOptions::dist with world_size > 1): every rank runs this
// loop on its slice of each global batch; only rank 0 reads or writes the
// run folder (the other ranks need the dataset only).
//
// RUN/run.json        resolved config, seed, version, parameter counts, dataset
// RUN/log.csv         step,epoch,lr,G_GAN,G_L1,D_real,D_fake,s_per_iter,allreduce_s (window means)
// RUN/val.csv         step,epoch,mae_m_batchstats,mae_m_running (per epoch, val split)
// RUN/val/step-N.png  fixed validation samples: label | truth | prediction
// RUN/checkpoint.pt   G, D, both Adam states, step, log window, RNG state
// RUN/generator.pt    G alone for `reefgen infer` (written at the end / on interrupt)
#include <atomic>
#include <cstdint>
#include <filesystem>
#include <functional>

#include "reefgen/train/distributed.hpp"
#include "reefgen/train/params.hpp"
#include "reefgen/train/pix2pix.hpp"

namespace reefgen::train {

struct StepReport {
  int64_t step = 0, total = 0;  // steps done, steps of the whole run
  double lr = 0, seconds_per_step = 0;
  double allreduce_seconds = 0;  // of the last step, in collectives (0 with one rank)
  Losses losses;                // of the last step
};

struct RunOptions {
  std::filesystem::path data, out;
  bool resume = false;
  // A new run whose G and D start from another run's checkpoint.pt (same
  // architecture) with fresh optimizers at step 0: fine-tuning with another
  // loss weight or schedule. Ignored by a resume (its checkpoint has weights).
  std::filesystem::path init_from;
  int64_t max_steps = -1;                  // stop (with a checkpoint) after this many steps in all; -1 = the whole run
  const std::atomic<bool>* stop = nullptr; // set by SIGINT/SIGTERM: checkpoint and return
  std::function<void(const StepReport&)> on_step;  // progress display
  std::function<void(const std::string&)> on_log;  // one-line events (checkpoint written, ...); rank 0 only
  // Which rank of how many (default: one process). batch_size is per rank:
  // the global batch is batch_size × world_size, sample for sample the batch
  // of a one-process run with that batch size.
  DistConfig dist;
  // Gradients travel in buckets of about this many MB, each all-reduced as
  // soon as backward has produced it (PyTorch DDP's bucket_cap_mb). Changes
  // the speed only, (0, 1024]; 4 beat 1 and 25 on 2 cores (docs/BENCHMARKS.md).
  double bucket_mb = 4;
  // The dataset's files against the manifest's checksums before the first
  // step (augment::read_manifest); false: `--no-verify`.
  bool verify_data = true;
};

struct RunResult {
  int64_t step = 0, total = 0;
  bool interrupted = false;  // stopped by the flag before the end
};

RunResult run_training(const TrainParams& params, const RunOptions& run);

// The architecture keys of TrainParams (what must match for weights to load).
bool same_architecture(const TrainParams& a, const TrainParams& b, std::string* differing = nullptr);
// Loads G's and D's weights (not optimizers, step or RNG) from a checkpoint
// of a run with the same architecture; throws reefgen::Error naming the file
// and the differing key otherwise.
void load_checkpoint_weights(const std::filesystem::path& path, Pix2Pix& p, const TrainParams& params);

// Checkpoint file (LibTorch archive, written atomically).
struct LogWindow {
  double sums[4] = {0, 0, 0, 0};  // G_GAN, G_L1, D_real, D_fake over the current log window
  int64_t steps = 0;
  // Wall-clock of the steps timed in this process; not checkpointed, so
  // checkpoints are byte-identical between interrupted and uninterrupted runs.
  double seconds = 0;
  int64_t timed_steps = 0;
  double allreduce_seconds = 0;  // in collectives over the timed steps
};
void save_checkpoint(const std::filesystem::path& path, Pix2Pix& p, const TrainParams& params, int64_t step,
                     const LogWindow& window, int world_size = 1);
// Restores weights, optimizers and RNG; returns the step. `torch_threads`, when
// given, receives the LibTorch thread count the checkpoint was written with. Throws reefgen::Error
// for a missing, truncated or foreign file and for a config that differs from
// `params` in anything but the thread and loader settings; the batch may be
// split over another number of ranks (`world_size` now, `world_size_then`
// receives the checkpoint's) as long as the global batch is the same.
int64_t load_checkpoint(const std::filesystem::path& path, Pix2Pix& p, const TrainParams& params, LogWindow* window,
                        int64_t* torch_threads = nullptr, int world_size = 1, int64_t* world_size_then = nullptr);

}  // namespace reefgen::train
