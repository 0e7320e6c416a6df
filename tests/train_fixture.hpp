#pragma once
// What the training tests share: a tiny dataset on disk and tiny settings.
#include <string>
#include <vector>

#include "reefgen/constants.hpp"
#include "reefgen/image_io.hpp"
#include "reefgen/labels.hpp"
#include "reefgen/procgen/generator.hpp"
#include "reefgen/procgen/random_spec.hpp"
#include "reefgen/train/params.hpp"
#include "test_util.hpp"

namespace reefgen::test {

// A dataset folder in the format of `reefgen dataset build`: `n` generated
// islands at 64 px, the last `n_val` in the val split; with maturities, pair
// i's manifest record holds maturities[i] (as a dataset drawing them does).
inline fs::path make_dataset(const std::string& name, int n, int n_val, const std::vector<double>& maturities = {}) {
  const fs::path d = temp_dir(name);
  fs::create_directories(d / "train");
  fs::create_directories(d / "val");
  write_json_atomic(d / "dataset.json", {{"params", {{"size_px", 64}}}, {"height_normalisation_m", {kAbyssFloorM, kHeightCeilingM}}});
  procgen::RenderOptions opt;
  opt.size_px = 64;
  std::string manifest;
  for (int i = 0; i < n; ++i) {
    procgen::IslandSpec s = procgen::random_spec(99, uint64_t(i));
    s.subsidence = 0.25 * (i % 4);
    const procgen::IslandFields f = procgen::generate(s, opt);
    const std::string split = i >= n - n_val ? "val" : "train";
    char stem[32];
    std::snprintf(stem, sizeof stem, "%s/%08d", split.c_str(), i);
    write_png(d / (std::string(stem) + ".label.png"), encode_labels(f.label, s.subsidence));
    write_exr_height(d / (std::string(stem) + ".height.exr"), f.height_m);
    const std::string label = std::string(stem) + ".label.png", height = std::string(stem) + ".height.exr";
    nlohmann::json record{{"index", i}, {"split", split}, {"label", label}, {"height", height},
                          {"label_fnv64", file_checksum(d / label)}, {"height_fnv64", file_checksum(d / height)}};
    if (size_t(i) < maturities.size()) record["maturity"] = maturities[size_t(i)];
    manifest += record.dump() + "\n";
  }
  write_text_atomic(d / "manifest.jsonl", manifest);
  return d;
}

inline train::TrainParams tiny_params() {
  train::TrainParams p;
  p.ngf = 4;
  p.ndf = 4;
  p.depth = 6;  // 64 px
  p.epochs = 1;
  p.epochs_decay = 1;
  p.log_every = 2;
  p.val_every = 5;
  p.checkpoint_every = 4;
  p.val_samples = 2;
  p.loader_threads = 2;
  p.prefetch = 3;
  return p;
}

}  // namespace reefgen::test
