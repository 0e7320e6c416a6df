#pragma once
// The closed depressions left in a height field after erosion or in a model
// answer: filled, then breached (docs/EROSION.md). Deterministic and
// single-threaded.
#include <cstdint>

#include <opencv2/core.hpp>

namespace reefgen::terrain {

// Closed depressions shallower than this are left as they are (m): half the
// 1 m a pit must have to count in the realism statistics (docs/REALISM.md).
constexpr float kPitDepthM = 0.5f;

// Drains the closed depressions of the land that are deeper than
// `max_depth_m` (the remaining pits of an eroded or predicted field): one
// deeper than `breach_m` is first raised to breach_m below its spill level,
// then its outflow path is cut down (breached) so that water leaves it; with
// breach_m ≤ max_depth_m they are only filled, to max_depth_m below the spill
// (flat floors). Returns the cells changed.
int64_t drain_pits(cv::Mat1f& height_m, float max_depth_m = kPitDepthM, float breach_m = 0.f);

}  // namespace reefgen::terrain
