#pragma once
// Label sketches from thresholded noise (the paper's Figure 17): something to
// feed `reefgen infer` without drawing. Each island is a radial bump whose
// outline is roughened by fBm; the bump is cut into the five regions by
// nested thresholds, so regions stay ordered (mountain inside beach inside
// lagoon inside reef inside abyss) as in hand-drawn sketches.
#include <cstdint>

#include <opencv2/core.hpp>

#include "reefgen/labels.hpp"

namespace reefgen::procgen {

struct SketchParams {
  int size_px = 256;          // W, [16, 4096]
  int islands = 1;            // islands on the canvas, [1, 16]; several are smaller and kept apart
  double subsidence = -1;     // λ in [0, 1]; -1 = random per island
  double radius = 0.55;       // outer (reef) radius of a single island, canvas half-widths, (0, 1]
  double roughness = 0.35;    // fBm amplitude on the bump, [0, 1]
  double frequency = 2.5;     // fBm features per canvas half-width, (0, 32]
};

using reefgen::Sketch;  // common/labels.hpp: shared with islands/

// Pure in (params, seed). Throws reefgen::Error for out-of-range params.
Sketch random_sketch(const SketchParams& p, uint64_t seed);

}  // namespace reefgen::procgen
