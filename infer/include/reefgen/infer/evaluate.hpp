#pragma once
// `reefgen eval` as a library: a generator measured on held-out pairs, on
// clean and perturbed sketches (docs/INFERENCE.md), and the report files.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "reefgen/constants.hpp"
#include "reefgen/infer/metrics.hpp"
#include "reefgen/model/generator_file.hpp"

namespace reefgen::infer {

// One held-out pair: the sketch as stored (BGR) and its true heights.
struct EvalPair {
  cv::Mat3b label_bgr;
  cv::Mat1f truth_m;
  int64_t index = 0;  // the pair's index in the dataset (seeds its perturbations)
  std::string name;   // the label file, relative to the dataset
  double maturity = 1;  // the erosion maturity its truth was made at (the manifest's); read by a generator with the maturity channel
};
// Reads a pair and checks it: both files size_px² (the dataset's size), the
// heights finite. Errors name the file and the fix (rebuild the dataset).
EvalPair read_eval_pair(const std::filesystem::path& label, const std::filesystem::path& height, int size_px,
                        int64_t index, const std::string& name);

struct EvalOptions {
  bool perturb = true;         // also blur, JPEG q50, hue jitter and brush noise
  bool running_stats = false;  // BatchNorm running statistics instead of batch statistics
  double world_size_m = kCanvasWorldSizeM;  // canvas width, m (slopes), (0, 1e7]
  bool quiet = false;          // no progress on stderr
  bool raw = false;            // the network's bare answer (InferOptions::amplify off), not what infer gives
};
struct EvalResult {
  nlohmann::json metrics;  // {perturbation name: MetricSums::finish()}
  nlohmann::json worst;    // the 4 worst clean pairs: index, label, mae_m
  cv::Mat worst_sheet;     // their label | truth | prediction rows
};
// One sketch per forward (batch statistics must not mix pairs).
EvalResult evaluate(model::GeneratorFile& g, const std::vector<EvalPair>& pairs, const EvalOptions& o);

// Painted sketches, which have no ground truth (docs/MODEL.md): per sketch
// and overall, young land above the sea, young abyss deep, the reef crest,
// the checkerboard amplitude (sketch_checks); and a grid of sketch | result
// tiles, two per row, to look at.
struct SketchesResult {
  nlohmann::json overall;    // shares, reef_crest_m_median, checkerboard_m_mean / _max
  nlohmann::json per_sketch; // one object per file
  cv::Mat grid;
};
SketchesResult evaluate_sketches(model::GeneratorFile& g, const std::vector<std::filesystem::path>& files,
                                 double young_max, bool quiet);

// OUT/eval.json (the report), OUT/eval.md (a table per perturbation and per
// region) and OUT/worst.png, each written atomically.
void write_eval_files(const std::filesystem::path& dir, const nlohmann::json& report, const cv::Mat& worst_sheet);

}  // namespace reefgen::infer
