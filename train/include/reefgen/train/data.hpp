#pragma once
#include "reefgen/augment/manifest.hpp"
// Reads datasets written by `reefgen dataset build` (docs/DATASET.md) and
// turns pairs into network tensors, with pix2pix's jitter applied identically
// to label and height. Sample k of a run is a pure function of (seed, k), so
// background loading, resuming and thread counts never change what is seen.
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <exception>
#include <filesystem>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <torch/torch.h>

#include "reefgen/model/codec.hpp"

namespace reefgen::train {

struct PairRef {
  int64_t index = 0;
  std::string label, height;  // paths relative to the dataset folder
  double maturity = 1;        // the erosion maturity its truth was made at (the manifest's; 1 where none was drawn)
};

struct DatasetInfo {
  std::filesystem::path dir;
  int size_px = 0;
  model::HeightRange range;  // from dataset.json's height_normalisation_m
  std::vector<PairRef> train, val, test;
  const std::vector<PairRef>& split(const std::string& name) const;
};

// Reads DIR/dataset.json and DIR/manifest.jsonl, checked as
// augment::read_manifest says (paths inside DIR, indexes unique, and unless
// check.verify_checksums is off every file's checksum); throws reefgen::Error
// naming the file and the fix (missing, unmerged shards, bad lines).
DatasetInfo open_dataset(const std::filesystem::path& dir, const augment::ManifestCheck& check = {});

struct JitterOptions {
  bool on = false;
  double scale = 286.0 / 256.0;  // resize factor before the random crop back to the size
  bool flip = false;             // random horizontal flip
};

struct Sample {
  torch::Tensor label;   // {in,S,S}: the label map in [-1,1], then the maturity plane when asked (model/codec.hpp)
  torch::Tensor height;  // {1,S,S} in [-1,1]
};

// Loads and checks one pair (size, NaN), then jitters it with draws from `seed`:
// label by nearest neighbour (never blended), height bilinearly. in_channels:
// model::kLabelChannels, or kLabelAndMaturityChannels for the pair's maturity as a 4th plane.
Sample load_sample(const DatasetInfo& d, const PairRef& p, const JitterOptions& j, uint64_t seed,
                   int in_channels = model::kLabelChannels);

// Position q of the endless sample stream (epoch q / n, a fresh permutation of
// the n pairs per epoch).
size_t sample_at(uint64_t seed, int64_t q, size_t n);

// Computes make(step) for the steps [first, end) on background threads, at
// most `depth` steps ahead of the consumer; next() returns them in order and
// rethrows a worker's exception.
class Prefetcher {
 public:
  using Batch = std::pair<torch::Tensor, torch::Tensor>;  // label {B,in,S,S}, height {B,1,S,S}
  Prefetcher(std::function<Batch(int64_t)> make, int64_t first, int64_t end, int threads, int depth);
  ~Prefetcher();
  Batch next();

 private:
  void work();
  std::function<Batch(int64_t)> make_;
  int64_t next_claim_, next_out_, end_;
  int depth_;
  std::map<int64_t, Batch> ready_;
  std::exception_ptr error_;
  bool stop_ = false;
  std::mutex m_;
  std::condition_variable cv_;
  std::vector<std::thread> threads_;
};

}  // namespace reefgen::train
