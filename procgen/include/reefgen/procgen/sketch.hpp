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

// An archipelago at the model's own scale: a W×H sea of islands
// whose sizes are in metres, so a pixel means the same ground as in the
// model's 256² canvas. Three kinds, drawn in turn: young high islands
// (λ 0–0.15: a wide mountain, a narrow fringing lagoon), barrier-reef
// islands (λ 0.25–0.4: a smaller mountain in a wide lagoon) and atolls
// (λ 0.85–1: a reef and islet ring round a lagoon, all under the sea as the
// generator's atoll preset is). Radii are log-uniform in
// [min_radius_m, max_radius_m] with the first island the largest; some
// islands cross the canvas border. The abyss is bright (λ 0).
struct ArchipelagoParams {
  int width_px = 2048;            // W, [16, 16384]
  int height_px = 2048;           // H, [16, 16384]
  int islands = 24;               // [1, 512]
  double metres_per_px = 6000.0 / 256;  // ground of one pixel, m, (0, 1000]
  double min_radius_m = 400;      // outer (reef) radius of the smallest island, m, > 0
  double max_radius_m = 10000;    // of the largest, m, ≥ min_radius_m (capped to a third of the shorter side)
  double roughness = 0.3;         // fBm amplitude on each island's bump, [0, 1]
  double frequency = 2.5;         // fBm features per island radius, (0, 32]
};
Sketch archipelago_sketch(const ArchipelagoParams& p, uint64_t seed);

}  // namespace reefgen::procgen
