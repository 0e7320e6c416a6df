#pragma once
// Seeds that re-roll the island (docs/INFERENCE.md "Variations"): the
// network answers a painting with one island, the mean of those it saw for
// that painting. A seed moves the summit and ridges inside the painted land
// before the amplification, whose seeded lobes, roughening and erosion then
// cut the valleys anew. LibTorch-free.
#include <cstdint>

#include <opencv2/core.hpp>

namespace reefgen::infer {

// How far a cell's height may come from, as a share of the cell's distance
// to the coast (the warp never reaches the sea: |shift| < distance, so the
// coast, the sea and every painted region stay where they are, and the
// warp never folds: its gradient stays below 1). 0.45 moves a 3 km-wide
// island's summit by up to ~700 m.
inline constexpr double kRerollShiftShare = 0.7;
// Size of the warp's features, m: an island's summit and main ridges
// (two octaves, 6 and 3 km: a shift that turns the whole massif one way,
// bent across it).
inline constexpr double kRerollFeatureM = 4000;

// h'(x) = h(x + v·k·D(x)·n(x)) on land (h > 0), k = kRerollShiftShare, v =
// variation in [0, 1], D the distance to the nearest sea cell (px), n a
// seeded noise vector with |n| ≤ 1. The sea is unchanged; land stays land.
// Pure in (height_m, cell size, seed, variation); any shape.
cv::Mat1f reroll_land(const cv::Mat1f& height_m, double metres_per_px, uint64_t seed, double variation);

}  // namespace reefgen::infer
