#pragma once
// Sketch -> height field with an exported generator (paper §7).
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "reefgen/labels.hpp"
#include "reefgen/model/generator_file.hpp"

namespace reefgen::infer {

struct InferOptions {
  bool stochastic = false;     // dropout on (pix2pix's noise source): varied outputs per --seed
  bool running_stats = false;  // BatchNorm running statistics instead of pix2pix's test-time batch statistics
  uint64_t seed = 0;           // dropout masks when stochastic
};

// The decoded sketch re-encoded in the canonical palette at the model's size:
// regions by nearest neighbour (never blended), subsidence bilinear.
cv::Mat3b canonical_sketch(const DecodedSketch& sketch, int size_px);

// Heights in metres at the sketch's own size (bilinear back from the model's
// side when the sketch is another size), always inside the model's range.
// Each output depends on its own sketch only: batch-statistics mode runs one
// sketch per forward (a batch would share BatchNorm statistics), running
// statistics mode batches 8 at a time.
std::vector<cv::Mat1f> infer_heights(model::GeneratorFile& g, const std::vector<DecodedSketch>& sketches,
                                     const InferOptions& o);

}  // namespace reefgen::infer
