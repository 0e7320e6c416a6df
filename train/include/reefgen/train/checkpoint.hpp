#pragma once
// A training run's checkpoint (RUN/checkpoint.pt, docs/TRAINING.md): G and D,
// both Adam states by parameter position, the step, the log window and the
// RNG, with a SHA-256 of all of it — so a resumed run continues bit for bit
// and a damaged file is refused. Also loading another run's weights (--init).
#include <cstdint>
#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "reefgen/train/params.hpp"
#include "reefgen/train/pix2pix.hpp"

namespace reefgen::train {

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

// The config a checkpoint must agree with to be resumed: the params without
// the settings that do not change the result (threads, loader, the batch's
// split over ranks), with the global batch.
nlohmann::json comparable_config(const TrainParams& p, int64_t world_size);

}  // namespace reefgen::train
