#pragma once
// Straight flat channels on land (docs/REALISM.md "Straight flat channels"):
// what a depression drained by a straight breach or a flat fill looks like
// from above — a long thin strip of ground with no fall, where a carved
// valley keeps falling and bends. LibTorch-free, deterministic.
#include <cstdint>

#include <opencv2/core.hpp>

namespace reefgen::terrain {

// A cell is flat below this slope (rise over run, 0.5 %): a river on a
// floodplain falls ~0.1 %, but a channel carved into an island's flank falls
// more than 1 %; a breach's flat fill falls nothing.
inline constexpr double kFlatChannelMaxSlope = 0.005;
// A flat component is a straight channel when its rotated bounding box is at
// least this long (pixels) ...
inline constexpr double kFlatChannelMinLengthPx = 25;
// ... and at least this many times longer than wide.
inline constexpr double kFlatChannelMinElongation = 5;

struct FlatChannelStats {
  int64_t channels = 0;        // inland flat land components at least 25 px long and 5× longer than wide
  int64_t coastal = 0;         // the same touching the sea (flat spits and beach strips, not channels)
  double land_km2 = 0;         // land (above sea level) area
  double per_1000_km2 = 0;     // inland channels per 1000 km² of land (0 without land)
  double longest_px = 0;       // the longest such channel (its box's long side)
};

// Components (8-connected) of land cells (height > 0) whose central-difference
// slope is below kFlatChannelMaxSlope; each one's smallest rotated rectangle
// gives its length (long side) and width (short side, at least 1 px). A
// component with a cell within 2 cells of the sea (at or below 0 m) is a
// low spit or a beach strip, counted apart: a channel runs between banks.
// Throws reefgen::Error on an empty field or a cell size that is not > 0.
FlatChannelStats flat_channel_stats(const cv::Mat1f& height_m, double metres_per_px);

}  // namespace reefgen::terrain
