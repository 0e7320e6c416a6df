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

#include "reefgen/train/checkpoint.hpp"
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

}  // namespace reefgen::train
